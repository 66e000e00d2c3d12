// Heat maps over a regular grid and 2D sequence matching (the paper's section III-D/E, docs/design.md
// steps 4-5) for robot firmware that links nightloc::core: interpolation of per-place values
// with precomputed sparse weights, sub-cell translation of earlier heat maps by odometry, their
// sum, and the hottest cell with the runner-up outside a radius (the confidence).
//
//   auto weights = std::make_shared<nightloc::HeatWeights>(100, 100, n_places, indptr, indices, data);
//   nightloc::HeatSequence sequence(weights, 10);           // the last 10 frames
//   per frame:
//     sequence.push(place_values, fill);                      // this frame's heat map minus fill
//     sequence.fuse(offsets);                                 // earlier frames moved by odometry, summed
//     nightloc::HeatPeak peak = nightloc::find_peak(sequence.fused(), 100, 100, disk);
//
// Conventions (python/nightloc/localization/heatmap.py, sequence.py): a heat map is row-major (height rows of
// width cells, row 0 = lowest y); a frame's map is stored as its excess over its fill value (zero
// where there is no data and beyond the grid), in float32; translation is bilinear with no
// wrap-around and zero from beyond the grid. The float arithmetic follows the Python reference
// operation by operation (see add_translated); nothing depends on the SIMD path.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace nightloc {

/// Sparse interpolation weights of a grid (CSR): the heat of cell c is
/// sum_{k in [indptr[c], indptr[c+1])} data[k] * values[indices[k]], summed in float32 in this
/// order (scipy's csr_matvec). Immutable once made: share one between sequences and threads.
class HeatWeights {
public:
    /// Throws std::invalid_argument unless indptr has height * width + 1 non-decreasing entries
    /// from 0 to indices.size() == data.size(), every index is < n_places and every weight finite.
    HeatWeights(std::size_t height, std::size_t width, std::size_t n_places, std::vector<std::int32_t> indptr,
                std::vector<std::int32_t> indices, std::vector<float> data);

    std::size_t height() const noexcept { return height_; }
    std::size_t width() const noexcept { return width_; }
    std::size_t cells() const noexcept { return height_ * width_; }
    std::size_t places() const noexcept { return places_; }

    /// heat (height * width) from place_values (places(), finite: std::invalid_argument otherwise).
    void interpolate(const float* place_values, float* heat) const;

    /// The weights as given (CSR).
    struct Csr {
        const std::vector<std::int32_t>& indptr;
        const std::vector<std::int32_t>& indices;
        const std::vector<float>& data;
    };
    Csr csr() const noexcept { return {indptr_, indices_, data_}; }

private:
    std::size_t height_, width_, places_;
    std::vector<std::int32_t> indptr_, indices_;
    std::vector<float> data_;
    std::size_t slots_ = 0;  // the most weights of one cell
    std::vector<float> ell_data_;
    std::vector<std::int32_t> ell_index_;
};

/// out[j, i] += E(j - shift_y, i - shift_x): `src` (height x width, rows `src_stride` elements
/// apart) extended with zeros beyond the grid and interpolated bilinearly, added to `out` (rows
/// `out_stride` apart; only its height x width cells are touched). Shifts are in cells (x along
/// columns, y along rows) and must be finite. Rounding follows nightloc.localization.sequence's reference:
/// with ix = floor(shift_x), fx = shift_x - ix (likewise y) and the weights a = T(1 - fx),
/// b = T(fx), wy0 = T(1 - fy), wy1 = T(fy) (computed in double, then rounded to T),
///     R(r, c) = a * src[r, c] + b * src[r, c - 1]
///     out[j, i] = (out[j, i] + wy0 * R(j - iy, i - ix)) + wy1 * R(j - iy - 1, i - ix)
/// each operation in T. Throws std::invalid_argument for zero sizes, strides shorter than a row
/// or non-finite shifts.
void add_translated(const float* src, std::size_t src_stride, float* out, std::size_t out_stride, std::size_t height,
                    std::size_t width, double shift_x, double shift_y);
void add_translated(const double* src, std::size_t src_stride, double* out, std::size_t out_stride, std::size_t height,
                    std::size_t width, double shift_x, double shift_y);

/// The cells around a peak that do not count as "another place": a (2 rows + 1) x (2 cols + 1)
/// mask centred on the peak, 1 = excluded (python/nightloc/localization/heatmap.py: a disk of
/// the confidence radius in metres).
struct PeakExclusion {
    std::size_t rows = 0, cols = 0;
    std::vector<std::uint8_t> mask{1};
};

/// Where a heat map is hottest.
struct HeatPeak {
    std::size_t cell = 0;     ///< row-major index of the first maximum
    float peak = 0;           ///< the maximum
    float floor = 0;          ///< the minimum
    float second = 0;         ///< the maximum over cells outside the exclusion around the peak
    bool has_second = false;  ///< false when the exclusion covers the whole grid
    bool finite = true;       ///< false when the map holds NaN or infinity (the rest is then unset)
};

/// Peak, floor and runner-up of a height x width map (row-major, contiguous).
HeatPeak find_peak(const float* heat, std::size_t height, std::size_t width, const PeakExclusion& exclusion);

/// The heat maps of the last `capacity` frames and their odometry-translated sum.
class HeatSequence {
public:
    /// Throws std::invalid_argument for a null `weights` or a zero capacity.
    HeatSequence(std::shared_ptr<const HeatWeights> weights, std::size_t capacity);

    /// Adds a frame: its excess map weights->interpolate(place_values) and its fill value (the
    /// frame's heat = excess + fill). The oldest frame is dropped when the sequence is full.
    /// Throws std::invalid_argument (the sequence unchanged) for non-finite values or fill.
    void push(const float* place_values, double fill);
    /// Adds a frame from its excess map itself (cells() finite values), e.g. to restore a saved
    /// sequence from frame() and fill(). Throws std::invalid_argument as push().
    void push_map(const float* excess, double fill);
    /// Forgets every frame.
    void clear() noexcept;
    std::size_t size() const noexcept { return count_; }
    std::size_t capacity() const noexcept { return capacity_; }

    /// fused = newest excess map + sum over the earlier frames (oldest first) of their excess map
    /// translated by offsets[2k], offsets[2k+1] (cells (x, y), size() - 1 rows), summed in that
    /// order in float32. Returns the sum of the fill values (fused + that = the sum of the frames'
    /// translated heat maps). Throws std::logic_error when the sequence is empty.
    double fuse(const double* offsets);
    /// The last fused map (height * width).
    const float* fused() const noexcept { return fused_.data(); }
    /// Frame k's excess map, 0 = oldest .. size() - 1 = newest, and its fill value.
    const float* frame(std::size_t k) const;
    double fill(std::size_t k) const;
    const HeatWeights& weights() const noexcept { return *weights_; }

private:
    std::size_t slot(std::size_t k) const { return (first_ + k) % capacity_; }
    float* next_slot();        // the map the next frame goes to (the oldest one's when full)
    void commit(double fill);  // makes that frame part of the sequence

    std::shared_ptr<const HeatWeights> weights_;
    std::size_t capacity_;
    std::vector<std::vector<float>> maps_;  // ring of excess maps, grown as frames come
    std::vector<double> fills_;
    std::size_t first_ = 0, count_ = 0;
    std::vector<float> fused_;
    std::vector<float> scratch_;  // rows of the translation
};

}  // namespace nightloc
