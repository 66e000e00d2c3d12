// Internal: the loops of the grid filter (grid_filter.cpp), one table per SIMD path. Element-wise
// IEEE arithmetic in a fixed order, sums in double over a fixed 16 lanes: every path gives the
// same values.
#pragma once

#include <cstddef>
#include <cstdint>

#include "nightloc/simd.hpp"

namespace nightloc::detail {

/// Lanes of the fixed-order double sums: element i of a run adds to lane i % 16.
inline constexpr std::size_t kSumLanes = 16;

/// Parameters of one extended-box pass (see GridFilter): taps -r..r weigh 1, taps +-(r+1) weigh
/// alpha, all times inv_w = 1 / (2r + 1 + 2 alpha).
struct BoxPass {
    std::size_t r;
    double alpha, inv_w;
};

/// Most taps of the heading blur.
inline constexpr std::size_t kMaxTaps = 4096;

/// The inputs of the measurement kernel (see FilterKernels::measure).
struct UpdateArgs {
    const float* data;            ///< ELL weights, slot k of cell c at k * n + c (unused slots weigh 0)
    const std::int32_t* index;    ///< ELL place indices, same layout
    const std::int32_t* places4;  ///< per block of 16 cells (c / 16) and slot k, at 4 (block slots + k): the
                                  ///< up to four places its 16 indices take (repeated to fill), or -1 when more
    std::size_t slots, n;         ///< slots per cell, cells
    const float* log_lik;         ///< bins rows of `stride` values: the log2-likelihood of each place
    std::size_t stride, bins;
    const float* source;         ///< bins x n: the predicted slices before the heading blur
    const float* taps;           ///< the heading blur: prior[b][c] = float(acc * a + f), acc = sum_t
    const std::size_t* offsets;  ///< taps[t] * source[(b - offsets[t]) mod bins][c] in float, t order
    std::size_t n_taps;
    float a, f;       ///< normalization and the uniform floor
    float* belief;    ///< bins x n (may be `source` when the blur is the identity)
    float* marginal;  ///< n
};

struct FilterKernels {
    /// One extended-box pass along the row axis: dst[j][i] = max(0, (acc + alpha (src[j-r-1][i] +
    /// src[j+r+1][i])) * inv_w) in float32, rows beyond [0, rows) zero, where acc is the running
    /// sum of src[j-r..j+r][i] (acc: cols floats of scratch): it starts as 0 + rows 0..r, and
    /// after output row j becomes (acc + src[j+r+1]) - src[j-r] (missing rows count 0; `zeros`:
    /// cols zeros). A running float sum leaves rounding residues of ~1e-7 of the largest value it
    /// carried; negative ones are cut to 0.
    void (*box_rows)(const float* src, float* dst, std::size_t rows, std::size_t cols, const BoxPass& pass, float* acc,
                     const float* zeros);
    /// dst[j][i] = sum_t taps[t] * src[j + t - offset][i] for t < n_taps (rows outside [0, rows)
    /// count 0; n_taps <= kMaxTaps), summed in float from 0 in t order. `zeros`: cols zeros.
    void (*conv_rows)(const float* src, float* dst, std::size_t rows, std::size_t cols, const float* taps,
                      std::size_t n_taps, std::ptrdiff_t offset, const float* zeros);
    /// dst[j][i] = sum_t taps[t] * src[j][i + t - offset] (columns outside [0, cols) count 0), in
    /// the same order; `padded`: cols + n_taps floats of scratch.
    void (*conv_cols)(const float* src, float* dst, std::size_t rows, std::size_t cols, const float* taps,
                      std::size_t n_taps, std::ptrdiff_t offset, float* padded);
    /// dst[c * rows + r] = src[r * cols + c].
    void (*transpose)(const float* src, float* dst, std::size_t rows, std::size_t cols);
    /// The heading blur of cells [c0, c0 + m) of every bin: belief[b][c] = float(acc * a + f) with
    /// acc = sum_t taps[t] * work[(b - offsets[t]) mod bins][c] summed in float from 0 in t order
    /// (n_taps <= kMaxTaps; slices n cells apart).
    void (*heading_conv)(const float* work, std::size_t bins, std::size_t n, std::size_t c0, std::size_t m,
                         const float* taps, const std::size_t* offsets, std::size_t n_taps, float a, float f,
                         float* belief);
    /// The measurement of cells [c0, c0 + m) of every bin (c0 a multiple of 16), bins in order:
    /// y = max(sum_k data[k n + c] * log_lik[b][index[k n + c]] (float, k order, from 0), -60);
    /// belief[b][c] = prior[b][c] * exp2(y) (exp2_approx; prior: see UpdateArgs);
    /// marginal[c] = (b == 0 ? 0 : marginal[c]) + belief[b][c].
    void (*measure)(const UpdateArgs& u, std::size_t c0, std::size_t m);
    /// values[c] = values[c] * a + f.
    void (*scale_add)(float* values, std::size_t n, float a, float f);
    /// lanes[c % 16] += values[c] (double).
    void (*sum)(const float* values, std::size_t n, double* lanes);
    /// out[c] = sum over b < bins of in[b * n + c], in float from 0 in b order.
    void (*sum_slices)(const float* in, std::size_t bins, std::size_t n, float* out);
};

/// 2^y for y in [-60, 0] in float32 (relative error < 3e-7): y = n + f with n = round-to-nearest,
/// a degree-5 polynomial in f in [-0.5, 0.5] (Horner), times 2^n. What measure computes.
float exp2_approx(float y) noexcept;

/// The total of 16 lane sums, added in lane order.
inline double lane_total(const double* lanes) noexcept {
    double total = 0;
    for (std::size_t l = 0; l < kSumLanes; ++l) total += lanes[l];
    return total;
}

/// The kernels of a path (a supported one: the caller checks).
const FilterKernels& filter_kernels(SimdBackend backend) noexcept;

}  // namespace nightloc::detail
