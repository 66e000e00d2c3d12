// Run-time selection of the SIMD path used by the kernels.
//
// Every path computes bit-identical results; they differ only in speed. The active path is the
// best one the CPU supports, unless the environment variable NIGHTLOC_SIMD (a name of
// kSimdBackendNames) names another supported one when the path is first queried, or
// set_simd_backend() forces one (tests use this to check every path on one machine).
#pragma once

#include <string>
#include <vector>

namespace nightloc {

enum class SimdBackend : int { scalar = 0, sse2 = 1, avx2 = 2, avx512bw = 3, neon = 4, neon_dotprod = 5 };

/// A path, its name and the architecture it runs on: the one place they are written (the bindings
/// and Python read them).
struct SimdBackendName {
    SimdBackend backend;
    const char* name;
    const char* architecture;  ///< "any" (the scalar reference), "x86-64" or "aarch64"
};

/// Every path the library knows (compiled into this build or not), slowest first per
/// architecture.
inline constexpr SimdBackendName kSimdBackendNames[] = {
    {SimdBackend::scalar, "scalar", "any"}, {SimdBackend::sse2, "sse2", "x86-64"},
    {SimdBackend::avx2, "avx2", "x86-64"},  {SimdBackend::avx512bw, "avx512bw", "x86-64"},
    {SimdBackend::neon, "neon", "aarch64"}, {SimdBackend::neon_dotprod, "neon-dotprod", "aarch64"},
};

/// Lower-case name of a path (see kSimdBackendNames).
const char* simd_backend_name(SimdBackend backend) noexcept;

/// All names of kSimdBackendNames, comma-separated (for messages).
std::string simd_backend_names();

/// Parses a name as returned by simd_backend_name(); false when the name is unknown.
bool parse_simd_backend(const std::string& name, SimdBackend& backend) noexcept;

/// True when the path is compiled into this build and the running CPU supports it.
bool simd_backend_supported(SimdBackend backend) noexcept;

/// All supported paths, slowest first.
std::vector<SimdBackend> supported_simd_backends();

/// The fastest supported path.
SimdBackend best_simd_backend() noexcept;

/// The path the kernels use now.
SimdBackend active_simd_backend() noexcept;

/// Forces a path for all later calls (process-wide). Throws std::invalid_argument when the path
/// is not supported on this CPU.
void set_simd_backend(SimdBackend backend);

/// Returns to the default choice (NIGHTLOC_SIMD if valid, else the best path).
void reset_simd_backend() noexcept;

}  // namespace nightloc
