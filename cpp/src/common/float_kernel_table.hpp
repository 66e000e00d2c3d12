// Internal: which table of float-vector kernels (heat maps, grid filter, route likelihood) serves
// a SIMD path: the one its registry entry names (SimdPath::float_kernels, simd_paths.cpp).
#pragma once

#include "common/arch.hpp"
#include "common/simd_paths.hpp"
#include "nightloc/simd.hpp"

namespace nightloc::detail {

/// The float kernels compiled per width: `scalar` (the reference; vectorization off where it
/// matters), `baseline` (4-lane vectors: SSE2 on x86, NEON on AArch64), and on x86 `avx2` (8
/// lanes) and `avx512` (16 lanes; both given on x86, nullptr elsewhere, where no path names them).
template <class Kernels>
struct FloatKernelTables {
    const Kernels& scalar;
    const Kernels& baseline;
    const Kernels* avx2;
    const Kernels* avx512;

    const Kernels& of(SimdBackend backend) const noexcept {
        switch (simd_path(backend).float_kernels) {
            case FloatKernelWidth::scalar:
                return scalar;
            case FloatKernelWidth::baseline:
                return baseline;
            case FloatKernelWidth::avx2:
                return avx2 != nullptr ? *avx2 : baseline;
            case FloatKernelWidth::avx512:
                return avx512 != nullptr ? *avx512 : baseline;
        }
        return scalar;
    }
};

}  // namespace nightloc::detail
