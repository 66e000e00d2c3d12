// Run-time SIMD path selection (see nightloc/simd.hpp).
#include "nightloc/simd.hpp"

#include <atomic>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "common/simd_paths.hpp"

namespace nightloc {
namespace {

constexpr int kUnset = -1;
std::atomic<int> g_active{kUnset};

// Whether the path is in the registry (compiled into this build) and the CPU runs it.
bool cpu_supports(SimdBackend backend) noexcept {
    const detail::SimdPath* path = detail::find_simd_path(backend);
    return path != nullptr && path->cpu_supports();
}

SimdBackend default_backend() noexcept {
    if (const char* env = std::getenv("NIGHTLOC_SIMD")) {
        SimdBackend requested;
        if (parse_simd_backend(env, requested) && cpu_supports(requested)) return requested;
    }
    return best_simd_backend();
}

}  // namespace

const char* simd_backend_name(SimdBackend backend) noexcept {
    for (const SimdBackendName& entry : kSimdBackendNames) {
        if (entry.backend == backend) return entry.name;
    }
    return "unknown";
}

std::string simd_backend_names() {
    std::string out;
    for (const SimdBackendName& entry : kSimdBackendNames) out += (out.empty() ? "" : ", ") + std::string(entry.name);
    return out;
}

bool parse_simd_backend(const std::string& name, SimdBackend& backend) noexcept {
    for (const SimdBackendName& entry : kSimdBackendNames) {
        if (name == entry.name) {
            backend = entry.backend;
            return true;
        }
    }
    return false;
}

bool simd_backend_supported(SimdBackend backend) noexcept { return cpu_supports(backend); }

std::vector<SimdBackend> supported_simd_backends() {
    std::vector<SimdBackend> out;
    for (const detail::SimdPath& path : detail::simd_paths()) {
        if (path.cpu_supports()) out.push_back(path.backend);
    }
    return out;
}

SimdBackend best_simd_backend() noexcept {
    // the last supported entry: the registry lists the paths slowest first
    SimdBackend best = SimdBackend::scalar;
    for (const detail::SimdPath& path : detail::simd_paths()) {
        if (path.cpu_supports()) best = path.backend;
    }
    return best;
}

SimdBackend active_simd_backend() noexcept {
    int current = g_active.load(std::memory_order_acquire);
    if (current == kUnset) {
        int chosen = static_cast<int>(default_backend());
        // Another thread may have raced us; either value is a valid default.
        g_active.compare_exchange_strong(current, chosen, std::memory_order_acq_rel);
        return static_cast<SimdBackend>(g_active.load(std::memory_order_acquire));
    }
    return static_cast<SimdBackend>(current);
}

void set_simd_backend(SimdBackend backend) {
    if (!cpu_supports(backend)) {
        throw std::invalid_argument(std::string("SIMD path '") + simd_backend_name(backend) +
                                    "' is not supported on this CPU or not compiled into this build");
    }
    g_active.store(static_cast<int>(backend), std::memory_order_release);
}

void reset_simd_backend() noexcept { g_active.store(static_cast<int>(default_backend()), std::memory_order_release); }

}  // namespace nightloc
