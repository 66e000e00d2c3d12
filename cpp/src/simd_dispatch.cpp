// Run-time SIMD path selection (see nightloc/simd.hpp).
#include "nightloc/simd.hpp"

#include <atomic>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "sad_kernels.hpp"

#if NIGHTLOC_ARM_KERNELS && defined(__linux__)
#include <sys/auxv.h>
#endif

namespace nightloc {
namespace {

#if NIGHTLOC_ARM_KERNELS && defined(__linux__)
constexpr unsigned long kHwcapAsimdDotProduct = 1ul << 20;  // HWCAP_ASIMDDP (asm/hwcap.h)
#endif

constexpr int kUnset = -1;
std::atomic<int> g_active{kUnset};

#if NIGHTLOC_ARM_KERNELS
// The dot-product extension (udot), from the kernel's hardware capabilities: never from compile
// flags, so one binary serves Cortex-A53/A72 (without) and A55/A76 and later (with).
bool arm_has_dotprod() noexcept {
#if defined(__linux__)
    return (getauxval(AT_HWCAP) & kHwcapAsimdDotProduct) != 0;
#else
    return false;
#endif
}
#endif

bool cpu_supports(SimdBackend backend) noexcept {
    switch (backend) {
        case SimdBackend::scalar:
            return true;
#if NIGHTLOC_X86_KERNELS
        case SimdBackend::sse2:
            return __builtin_cpu_supports("sse2");
        case SimdBackend::avx2:
            return __builtin_cpu_supports("avx2");
        case SimdBackend::avx512bw:
            return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw");
#endif
#if NIGHTLOC_ARM_KERNELS
        case SimdBackend::neon:
            return true;  // part of the AArch64 baseline
        case SimdBackend::neon_dotprod:
            return arm_has_dotprod();
#endif
        default:
            return false;
    }
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
    for (const SimdBackendName& entry : kSimdBackendNames) {
        if (cpu_supports(entry.backend)) out.push_back(entry.backend);
    }
    return out;
}

SimdBackend best_simd_backend() noexcept {
    // the last supported entry: the table lists each architecture's paths slowest first
    SimdBackend best = SimdBackend::scalar;
    for (const SimdBackendName& entry : kSimdBackendNames) {
        if (cpu_supports(entry.backend)) best = entry.backend;
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
