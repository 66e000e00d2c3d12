// Internal: the row kernels of frame preparation (prepare.cpp), one table per SIMD path.
// Every path computes the same bytes; they differ only in speed.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/arch.hpp"
#include "nightloc/prepare.hpp"
#include "nightloc/simd.hpp"

namespace nightloc::detail {

/// Sub-histograms of histogram_row (8 x 256 counters, summed at the end).
inline constexpr std::size_t kHistogramCopies = 8;

struct PrepareKernels {
    /// dst[x] = grey value of pixel x of a packed row of n pixels in `order` (not grey).
    void (*grey_row)(const std::uint8_t* src, std::size_t n, PixelOrder order, std::uint8_t* dst);
    /// counts[c * 256 + v] += number of pixels of value v (spread over kHistogramCopies copies c).
    void (*histogram_row)(const std::uint8_t* src, std::size_t n, std::uint32_t* counts);
    /// band[x] += src[x] (16-bit wrap-around: the caller flushes before 257 rows).
    void (*accumulate_row)(const std::uint8_t* src, std::size_t n, std::uint16_t* band);
    /// band[x] += lut[src[x]].
    void (*accumulate_lut_row)(const std::uint8_t* src, std::size_t n, const std::uint8_t* lut, std::uint16_t* band);
    /// prefix[0] = 0, prefix[x + 1] = band[0] + ... + band[x] for x < n (the caller keeps the sums
    /// below 2^32).
    void (*prefix_row)(const std::uint16_t* band, std::size_t n, std::uint32_t* prefix);
    /// Name of the instruction set the kernels were compiled for (for reports).
    const char* name;
};

/// The kernels of a path (its SimdPath entry's table; a supported path: the caller checks).
const PrepareKernels& prepare_kernels(SimdBackend backend) noexcept;

/// Each path's table, named by the SIMD path registry (simd_paths.cpp). avx512bw takes the
/// AVX-512 VBMI table lookup when the CPU has VBMI; both AArch64 paths share the NEON table.
const PrepareKernels& prepare_kernels_scalar() noexcept;
#if NIGHTLOC_X86_KERNELS
const PrepareKernels& prepare_kernels_sse2() noexcept;
const PrepareKernels& prepare_kernels_avx2() noexcept;
const PrepareKernels& prepare_kernels_avx512bw() noexcept;
#endif
#if NIGHTLOC_ARM_KERNELS
const PrepareKernels& prepare_kernels_neon() noexcept;
#endif

}  // namespace nightloc::detail
