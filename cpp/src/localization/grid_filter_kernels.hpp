// Internal: the loops of the grid filter (grid_filter.cpp), one table per SIMD path. Element-wise
// IEEE arithmetic in a fixed order, sums in double over fixed lanes: every path gives the same
// values.
#pragma once

#include <cstddef>
#include <cstdint>

#include "nightloc/simd.hpp"

namespace nightloc::detail {

/// Lanes of the fixed-order double sums: element i of a run adds to lane i % 16.
inline constexpr std::size_t kSumLanes = 16;

/// Cells per block of the measurement's interpolation (see UpdateArgs).
inline constexpr std::size_t kBlock = 16;

/// Bins per group of the log2-likelihoods (the measurement's bins per pass).
inline constexpr std::size_t kGroupBins = 4;

/// Parameters of one extended-box pass (see GridFilter): taps -r..r weigh 1, taps +-(r+1) weigh
/// alpha, all times inv_w = 1 / (2r + 1 + 2 alpha).
struct BoxPass {
    std::size_t r;
    double alpha, inv_w;
};

/// Most taps of a blur (per axis and over heading).
inline constexpr std::size_t kMaxTaps = 4096;

/// The inputs of the explicit prediction kernel (see FilterKernels::shift_blur).
struct ShiftBlurArgs {
    const float* src;  ///< rows x cols
    float* dst;        ///< rows x cols
    std::size_t rows, cols;
    const float* taps_y;  ///< row axis: taps_y[t] weighs source row j + t - off_y
    std::size_t n_y;
    std::ptrdiff_t off_y;
    const float* taps_x;  ///< column axis: taps_x[t] weighs source column i + t - off_x
    std::size_t n_x;
    std::ptrdiff_t off_x;
    float* buf;          ///< 2 span floats, span = cols + 2 pad rounded up to 16: two rows, zero outside
                         ///< [pad, pad + cols) (kept so)
    std::size_t pad;     ///< >= max(off_x, n_x - 1 - off_x, 0)
    const float* zeros;  ///< cols zeros
};

/// The inputs of the measurement kernel (see FilterKernels::measure). The cells are cut into
/// blocks of kBlock (the last one may be short). A dense block lists the places its cells use
/// (ascending; index `places` is the bin's fill, for cells without weights) with kBlock weights
/// each (the block's cells in order, 0 where a cell does not use the place); a cell's
/// log2-likelihood is then y = sum over the block's list of weight * log_lik[place][b], in list
/// order, from 0. Other blocks (more places than fit: dense maps) sum their cells' own ELL slots
/// in slot order.
struct UpdateArgs {
    const std::int32_t* block_start;   ///< blocks + 1 offsets into block_places; a block with none: ELL
    const std::int32_t* block_places;  ///< the dense blocks' places
    const float* block_weights;        ///< kBlock weights per entry of block_places
    const float* data;                 ///< ELL weights, slot k of cell c at k * n + c (unused slots weigh 0)
    const std::int32_t* index;         ///< ELL place indices, same layout
    std::size_t slots, n;              ///< slots per cell, cells
    const float* log_lik;              ///< the bins' group from bin `group_b0` on: places + 1 rows of
    std::size_t stride;                ///< `stride` values, row p place p's log2-likelihood in bins
                                       ///< group_b0, group_b0 + 1, ... (row `places`: the fill)
    std::size_t group_b0;
    const float* taps;   ///< the heading blur: prior[b][c] = float(acc * a + f), acc = sum_t taps[t] *
    std::size_t n_taps;  ///< in[t][c] summed in float from 0 in t order (in: the predicted slices)
    float a, f;          ///< normalization and the uniform floor
    float* belief;       ///< bins x n (bin b's slice may be in[t] when the blur is the identity)
    float* marginal;     ///< n
    /// The log2-likelihood of the cells of blocks that are not dense, bin b's at (b - group_b0) *
    /// n + c (made by FilterKernels::interpolate; null when every block is dense).
    const float* sparse_y = nullptr;
    /// When not null: bin_max[b] becomes the largest belief of bin b over the cells measured
    /// (from 0 when they start at cell 0).
    float* bin_max = nullptr;
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
    /// One slice's shift and blur with explicit taps, row by row (the row in `buf`, L1-resident):
    /// row[i] = sum_t taps_y[t] * src[j + t - off_y][i] (rows outside [0, rows) count 0), then
    /// dst[j][i] = sum_t taps_x[t] * row[i + t - off_x] (columns outside count 0), each summed in
    /// float from 0 in t order (n_y, n_x <= kMaxTaps).
    void (*shift_blur)(const ShiftBlurArgs& a);
    /// dst[c * rows + r] = src[r * cols + c].
    void (*transpose)(const float* src, float* dst, std::size_t rows, std::size_t cols);
    /// The heading blur of cells [c0, c0 + m) of every bin: belief[b][c] = float(acc * a + f) with
    /// acc = sum_t taps[t] * work[(b - offsets[t]) mod bins][c] summed in float from 0 in t order
    /// (n_taps <= kMaxTaps; slices n cells apart).
    void (*heading_conv)(const float* work, std::size_t bins, std::size_t n, std::size_t c0, std::size_t m,
                         const float* taps, const std::size_t* offsets, std::size_t n_taps, float a, float f,
                         float* belief);
    /// The measurement of cells [c0, c0 + m) of bins [b, b + bins) (c0 a multiple of kBlock), bin
    /// by bin in order; in[q * n_taps + t]: the n_taps predicted slices of bin b + q's prior:
    /// y (see UpdateArgs) floored at -60; belief[b][c] = prior[c] * exp2(y) (exp2_approx; prior:
    /// see UpdateArgs); marginal[c] = (b == 0 ? 0 : marginal[c]) + belief[b][c].
    void (*measure)(const UpdateArgs& u, std::size_t b, std::size_t bins, const float* const* in, std::size_t c0,
                    std::size_t m);
    /// The log2-likelihood y (see UpdateArgs, not floored) of every cell of the blocks that are not
    /// dense, for the `bins` bins of the group (from u.group_b0): y[(b - group_b0) * n + c], each
    /// summed over the cell's ELL slots in slot order from 0 (the measurement then reads it).
    void (*interpolate)(const UpdateArgs& u, std::size_t bins, float* y);
    /// Per row i of an n x S table: mins[i] its lowest value and best[i] the first column holding it;
    /// returns whether any value is NaN or infinite (then mins and best are not defined, but set).
    bool (*row_minima)(const float* table, std::size_t n, std::size_t S, float* mins, std::int32_t* best);
    /// Per reference i of an n x W table (W columns = W heading bins, a panorama): row
    /// rows[i] of ps (W values) becomes min(ps, v) with v[b] = float((1 - a) T[i][k] + a T[i][k + 1])
    /// in double, k = c0[i] + b and k + 1 taken mod W, a = fraction[i]; `twice`: 2 W floats of scratch.
    void (*lerp_rows)(const float* table, std::size_t n, std::size_t W, const std::int32_t* rows,
                      const std::int32_t* c0, const double* fraction, float* ps, float* twice);
    /// The per-column case of lerp_rows turned into log2-likelihoods at once: per reference i the
    /// W scores v[b] as lerp_rows computes them, y[b] = float(max(gain (double(v[b]) - s_min),
    /// lowest)), written to row rows[i] of the grouped layout of log_lik (see log_lik) where the
    /// reference is the first of its place (first[i] != 0), else the larger of the two kept (the
    /// place's lowest score: y falls with the score). `row_y`: W floats of scratch.
    void (*lerp_log_lik)(const float* table, std::size_t n, std::size_t W, const std::int32_t* rows,
                         const std::uint8_t* first, const std::int32_t* c0, const double* fraction, double gain,
                         double s_min, double lowest, float* y, std::size_t group_rows, float* row_y);
    /// low[b] = min(low[b], min over rows r < rows of the grouped log_lik y (see log_lik) in bin b).
    void (*group_min)(const float* y, std::size_t rows, std::size_t B, std::size_t group_rows, float* low);
    /// high[b] = max(high[b], max over the rows of values[r * B + b]) (rows x B values).
    void (*column_max)(const float* values, std::size_t rows, std::size_t B, float* high);
    /// The log2-likelihood of rows x B scores, float(max(gain (double(score) - s_min), lowest)),
    /// in groups of kGroupBins bins: bin b of row r at ((b / kGroupBins) group_rows + first_row +
    /// r) kGroupBins + b % kGroupBins of y.
    void (*log_lik)(const float* score, std::size_t rows, std::size_t B, double gain, double s_min, double lowest,
                    float* y, std::size_t group_rows, std::size_t first_row);
    /// scores[k] = float(double(sums[k]) / divisor) (rotational_sad's scores) for k < n.
    void (*scale_sums)(const std::uint32_t* sums, std::size_t n, double divisor, float* scores);
    /// The largest of n >= 1 values (no NaN).
    float (*max_value)(const float* values, std::size_t n);
    /// lanes[c % 16] += values[c] (double).
    void (*sum)(const float* values, std::size_t n, double* lanes);
    /// out[c] = sum over b < bins of in[b * n + c], in float from 0 in b order.
    void (*sum_slices)(const float* in, std::size_t bins, std::size_t n, float* out);
};

/// 2^y for y in [-60, 0] in float32 (relative error < 3e-7): y = n + f with n = round-to-nearest,
/// a degree-5 polynomial in f in [-0.5, 0.5] (Horner), times 2^n. What measure computes.
float exp2_approx(float y) noexcept;

/// The total of `count` lane sums, added in lane order.
inline double lane_total(const double* lanes, std::size_t count = kSumLanes) noexcept {
    double total = 0;
    for (std::size_t l = 0; l < count; ++l) total += lanes[l];
    return total;
}

/// The kernels of a path (a supported one: the caller checks).
const FilterKernels& filter_kernels(SimdBackend backend) noexcept;

}  // namespace nightloc::detail
