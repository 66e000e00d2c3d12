// Internal: which table of float-vector kernels (heat maps, grid filter) serves a SIMD path.
#pragma once

#include "nightloc/simd.hpp"
#include "sad_kernels.hpp"  // NIGHTLOC_X86_KERNELS

namespace nightloc::detail {

/// The float kernels compiled per path: `scalar` (the reference; vectorization off where it
/// matters), `baseline` (4-lane vectors: SSE2 on x86, NEON on AArch64), and on x86 `avx2` (8
/// lanes) and `avx512` (16 lanes; both given on x86, nullptr elsewhere). On AArch64 every path but scalar runs the NEON
/// table (the dot product adds nothing to float work); a path of another architecture gets the scalar table.
template <class Kernels>
struct FloatKernelTables {
    const Kernels& scalar;
    const Kernels& baseline;
    const Kernels* avx2;
    const Kernels* avx512;

    const Kernels& of(SimdBackend backend) const noexcept {
        switch (backend) {
            case SimdBackend::scalar:
                return scalar;
#if NIGHTLOC_X86_KERNELS
            case SimdBackend::sse2:
                return baseline;
            case SimdBackend::avx2:
                return *avx2;
            case SimdBackend::avx512bw:
                return *avx512;
            default:
                return scalar;  // another architecture's path: never active here
#else
            default:
                return baseline;
#endif
        }
    }
};

}  // namespace nightloc::detail
