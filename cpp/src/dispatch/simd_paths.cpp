// The SIMD path registry (common/simd_paths.hpp): one entry per path compiled into this build. The
// table names the kernels of every stage (matching, preparation), so it sits above them in its own
// folder; its interface sits below them in common/, where the stages ask for the active path.
#include "common/simd_paths.hpp"

#include <iterator>

#include "common/arch.hpp"
#include "matching/sad_kernels.hpp"
#include "preparation/prepare_kernels.hpp"

#if NIGHTLOC_ARM_KERNELS && defined(__linux__)
#include <sys/auxv.h>
#endif

namespace nightloc::detail {
namespace {

bool always() noexcept { return true; }

#if NIGHTLOC_X86_KERNELS
bool cpu_has_sse2() noexcept { return __builtin_cpu_supports("sse2"); }
bool cpu_has_avx2() noexcept { return __builtin_cpu_supports("avx2"); }
bool cpu_has_avx512bw() noexcept { return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw"); }
#endif

#if NIGHTLOC_ARM_KERNELS
// The dot-product extension (udot), from the kernel's hardware capabilities: never from compile
// flags, so one binary serves Cortex-A53/A72 (without) and A55/A76 and later (with).
bool cpu_has_dotprod() noexcept {
#if defined(__linux__)
    constexpr unsigned long kHwcapAsimdDotProduct = 1ul << 20;  // HWCAP_ASIMDDP (asm/hwcap.h)
    return (getauxval(AT_HWCAP) & kHwcapAsimdDotProduct) != 0;
#else
    return false;
#endif
}
#endif

// backend, CPU check, copies kernel, all-shift kernel, offsets kernel, alignment, staging,
// preparation kernels, float kernels.
constexpr SimdPath kPaths[] = {
    {SimdBackend::scalar, always, sad_copies_scalar, nullptr, nullptr, 1, false, prepare_kernels_scalar,
     FloatKernelWidth::scalar},
#if NIGHTLOC_X86_KERNELS
    {SimdBackend::sse2, cpu_has_sse2, sad_copies_sse2, nullptr, nullptr, 16, true, prepare_kernels_sse2,
     FloatKernelWidth::baseline},
    {SimdBackend::avx2, cpu_has_avx2, sad_copies_avx2, nullptr, nullptr, 32, true, prepare_kernels_avx2,
     FloatKernelWidth::avx2},
    // The all-shift and offsets kernels read references in place: no staging.
    {SimdBackend::avx512bw, cpu_has_avx512bw, sad_copies_avx512bw, avx512_all_shift_kernel, avx512_offsets_kernel, 64,
     false, prepare_kernels_avx512bw, FloatKernelWidth::avx512},
#endif
#if NIGHTLOC_ARM_KERNELS
    // NEON is part of the AArch64 baseline; the dot product does not help the float kernels.
    {SimdBackend::neon, always, sad_copies_neon, nullptr, nullptr, 16, true, prepare_kernels_neon,
     FloatKernelWidth::baseline},
    {SimdBackend::neon_dotprod, cpu_has_dotprod, sad_copies_neon_dotprod, nullptr, nullptr, 16, true,
     prepare_kernels_neon, FloatKernelWidth::baseline},
#endif
};

// Every entry has a public name, and no path is listed twice.
constexpr bool entries_are_named_once() {
    for (std::size_t i = 0; i < std::size(kPaths); ++i) {
        bool named = false;
        for (const SimdBackendName& entry : kSimdBackendNames) named = named || entry.backend == kPaths[i].backend;
        if (!named) return false;
        for (std::size_t j = 0; j < i; ++j)
            if (kPaths[j].backend == kPaths[i].backend) return false;
    }
    return kPaths[0].backend == SimdBackend::scalar;
}
static_assert(entries_are_named_once(), "each SIMD path entry needs a name in kSimdBackendNames, once; scalar first");

}  // namespace

SimdPathRange simd_paths() noexcept { return {std::begin(kPaths), std::end(kPaths)}; }

const SimdPath* find_simd_path(SimdBackend backend) noexcept {
    for (const SimdPath& path : kPaths) {
        if (path.backend == backend) return &path;
    }
    return nullptr;
}

const SimdPath& simd_path(SimdBackend backend) noexcept {
    const SimdPath* path = find_simd_path(backend);
    return path != nullptr ? *path : kPaths[0];
}

const SimdPath& active_simd_path() noexcept { return simd_path(active_simd_backend()); }

}  // namespace nightloc::detail
