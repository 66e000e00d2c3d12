// Heat maps and 2D sequence matching (see nightloc/heatmap.hpp). The translation works row by
// row: R(r, .), the x-interpolated source row, is computed once per source row and kept for the
// next output row, which needs it with the other y weight. The row loops are compiled for each
// SIMD path (heatmap_kernels.cpp); every path does the same IEEE operations in the same order.
#include "nightloc/heatmap.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "heatmap_kernels.hpp"
#include "nightloc/simd.hpp"

namespace nightloc {

// --------------------------------------------------------------------------------------------
// weights

HeatWeights::HeatWeights(std::size_t height, std::size_t width, std::size_t n_places, std::vector<std::int32_t> indptr,
                         std::vector<std::int32_t> indices, std::vector<float> data)
    : height_(height), width_(width), places_(n_places), indptr_(std::move(indptr)), indices_(std::move(indices)),
      data_(std::move(data)) {
    if (height == 0 || width == 0) throw std::invalid_argument("heat-map grid must have at least one cell");
    if (width > std::numeric_limits<std::size_t>::max() / height) throw std::invalid_argument("grid too large");
    if (indptr_.size() != height * width + 1) {
        throw std::invalid_argument("indptr must have height * width + 1 = " + std::to_string(height * width + 1) +
                                    " entries, got " + std::to_string(indptr_.size()));
    }
    if (indices_.size() != data_.size()) throw std::invalid_argument("indices and data differ in length");
    if (indptr_.front() != 0 || static_cast<std::size_t>(indptr_.back()) != indices_.size()) {
        throw std::invalid_argument("indptr must run from 0 to the number of weights");
    }
    for (std::size_t c = 0; c + 1 < indptr_.size(); ++c) {
        if (indptr_[c + 1] < indptr_[c]) throw std::invalid_argument("indptr must not decrease");
    }
    for (std::size_t k = 0; k < indices_.size(); ++k) {
        if (indices_[k] < 0 || static_cast<std::size_t>(indices_[k]) >= n_places) {
            throw std::invalid_argument("weight index " + std::to_string(indices_[k]) + " is not a place (0.." +
                                        std::to_string(n_places) + ")");
        }
        if (!std::isfinite(data_[k])) throw std::invalid_argument("weights must be finite");
    }
}

void HeatWeights::interpolate(const float* place_values, float* heat) const {
    const std::size_t n = cells();
    for (std::size_t c = 0; c < n; ++c) {
        float sum = 0.f;
        for (auto k = static_cast<std::size_t>(indptr_[c]); k < static_cast<std::size_t>(indptr_[c + 1]); ++k) {
            sum += data_[k] * place_values[static_cast<std::size_t>(indices_[k])];
        }
        heat[c] = sum;
    }
}

// --------------------------------------------------------------------------------------------
// translation

namespace {

template <class T>
void add_translated_impl(const T* src, std::size_t src_stride, T* out, std::size_t out_stride, std::size_t height,
                         std::size_t width, double shift_x, double shift_y) {
    if (height == 0 || width == 0) throw std::invalid_argument("heat maps must have at least one cell");
    if (src_stride < width || out_stride < width) throw std::invalid_argument("row stride shorter than a row");
    if (!std::isfinite(shift_x) || !std::isfinite(shift_y)) throw std::invalid_argument("shifts must be finite");
    const auto w = static_cast<double>(width), h = static_cast<double>(height);
    // beyond these, everything lands outside the grid (and the integer parts could overflow)
    if (shift_x >= w || shift_x < -w - 1.0 || shift_y >= h || shift_y < -h - 1.0) return;
    const double fx_floor = std::floor(shift_x), fy_floor = std::floor(shift_y);
    const auto ix = static_cast<std::ptrdiff_t>(fx_floor), iy = static_cast<std::ptrdiff_t>(fy_floor);
    const double fx = shift_x - fx_floor, fy = shift_y - fy_floor;
    const T a = static_cast<T>(1.0 - fx), b = static_cast<T>(fx);
    const T wy0 = static_cast<T>(1.0 - fy), wy1 = static_cast<T>(fy);
    const auto W = static_cast<std::ptrdiff_t>(width), H = static_cast<std::ptrdiff_t>(height);
    // output columns i whose source column c = i - ix lies in [0, width]
    const std::ptrdiff_t i_lo = std::max<std::ptrdiff_t>(0, ix), i_hi = std::min<std::ptrdiff_t>(W, W + ix + 1);
    // output rows j with a source row j - iy or j - iy - 1 in [0, height)
    const std::ptrdiff_t j_lo = std::max<std::ptrdiff_t>(0, iy), j_hi = std::min<std::ptrdiff_t>(H, H + iy + 1);
    if (i_lo >= i_hi || j_lo >= j_hi) return;
    const auto& k = detail::heat_kernels(active_simd_backend());
    const std::size_t c0 = static_cast<std::size_t>(i_lo - ix), n = static_cast<std::size_t>(i_hi - i_lo);
    std::vector<T> rows(3 * (width + 1), T(0));  // R of the current and the previous source row, zeros
    T* current = rows.data();
    T* previous = current + width + 1;
    const T* zeros = previous + width + 1;
    auto across = [&](std::ptrdiff_t r, T* row) {  // R(r, .) into row; false beyond the grid
        if (r < 0 || r >= H) return false;
        k.across(src + static_cast<std::size_t>(r) * src_stride, width, a, b, row);
        return true;
    };
    bool previous_valid = across(j_lo - iy - 1, previous);
    for (std::ptrdiff_t j = j_lo; j < j_hi; ++j) {
        const bool current_valid = across(j - iy, current);  // weight wy0; the previous row has wy1
        k.combine(out + static_cast<std::size_t>(j) * out_stride + static_cast<std::size_t>(i_lo),
                  (current_valid ? current : zeros) + c0, (previous_valid ? previous : zeros) + c0, n, wy0, wy1);
        std::swap(current, previous);
        previous_valid = current_valid;
    }
}

}  // namespace

void add_translated(const float* src, std::size_t src_stride, float* out, std::size_t out_stride, std::size_t height,
                    std::size_t width, double shift_x, double shift_y) {
    add_translated_impl(src, src_stride, out, out_stride, height, width, shift_x, shift_y);
}

void add_translated(const double* src, std::size_t src_stride, double* out, std::size_t out_stride,
                    std::size_t height, std::size_t width, double shift_x, double shift_y) {
    add_translated_impl(src, src_stride, out, out_stride, height, width, shift_x, shift_y);
}

// --------------------------------------------------------------------------------------------
// peak

HeatPeak find_peak(const float* heat, std::size_t height, std::size_t width, const PeakExclusion& exclusion) {
    if (height == 0 || width == 0) throw std::invalid_argument("heat map must have at least one cell");
    if (exclusion.mask.size() != (2 * exclusion.rows + 1) * (2 * exclusion.cols + 1)) {
        throw std::invalid_argument("exclusion mask must be (2 rows + 1) x (2 cols + 1)");
    }
    const auto& k = detail::heat_kernels(active_simd_backend());
    const std::size_t n = height * width;
    HeatPeak result;
    if (!k.all_finite(heat, n)) {
        result.finite = false;
        return result;
    }
    k.max_min(heat, n, result.peak, result.floor);
    std::size_t cell = 0;
    while (heat[cell] != result.peak) ++cell;  // the first maximum (numpy.argmax)
    result.cell = cell;
    result.peak = heat[cell];
    const std::size_t pj = cell / width, pi = cell % width;
    const std::size_t j0 = pj >= exclusion.rows ? pj - exclusion.rows : 0;
    const std::size_t j1 = std::min(height, pj + exclusion.rows + 1);
    const std::size_t i0 = pi >= exclusion.cols ? pi - exclusion.cols : 0;
    const std::size_t i1 = std::min(width, pi + exclusion.cols + 1);
    const std::size_t mask_width = 2 * exclusion.cols + 1;
    float second = -std::numeric_limits<float>::infinity();
    bool any = false;
    auto take = [&](const float* values, std::size_t count) {
        if (count == 0) return;
        float lo, hi;
        k.max_min(values, count, hi, lo);
        second = any ? std::max(second, hi) : hi;
        any = true;
    };
    take(heat, j0 * width);                           // rows above the box
    take(heat + j1 * width, (height - j1) * width);   // rows below
    for (std::size_t j = j0; j < j1; ++j) {
        const float* row = heat + j * width;
        take(row, i0);                                // left of the box
        take(row + i1, width - i1);                   // right of the box
        const std::uint8_t* mask = exclusion.mask.data() + (j + exclusion.rows - pj) * mask_width;
        for (std::size_t i = i0; i < i1; ++i) {       // the box outside the disk
            if (!mask[i + exclusion.cols - pi]) take(row + i, 1);
        }
    }
    result.second = second;
    result.has_second = any;
    return result;
}

// --------------------------------------------------------------------------------------------
// sequence

HeatSequence::HeatSequence(std::shared_ptr<const HeatWeights> weights, std::size_t capacity)
    : weights_(std::move(weights)), capacity_(capacity) {
    if (!weights_) throw std::invalid_argument("heat weights are null");
    if (capacity == 0) throw std::invalid_argument("a sequence holds at least one frame");
    fills_.assign(capacity, 0.0);
    fused_.assign(weights_->cells(), 0.f);
}

void HeatSequence::push(const float* place_values, double fill) {
    if (place_values == nullptr) throw std::invalid_argument("place values are null");
    std::size_t target;
    if (count_ < capacity_) {
        target = slot(count_);
        ++count_;
    } else {  // full: overwrite the oldest
        target = first_;
        first_ = (first_ + 1) % capacity_;
    }
    if (maps_.size() <= target) maps_.resize(target + 1);
    maps_[target].resize(weights_->cells());
    weights_->interpolate(place_values, maps_[target].data());
    fills_[target] = fill;
}

void HeatSequence::clear() noexcept {
    first_ = 0;
    count_ = 0;
}

const float* HeatSequence::frame(std::size_t k) const {
    if (k >= count_) throw std::out_of_range("frame index beyond the sequence");
    return maps_[slot(k)].data();
}

double HeatSequence::fill(std::size_t k) const {
    if (k >= count_) throw std::out_of_range("frame index beyond the sequence");
    return fills_[slot(k)];
}

double HeatSequence::fuse(const double* offsets) {
    if (count_ == 0) throw std::logic_error("fuse needs at least one frame");
    const std::size_t h = weights_->height(), w = weights_->width();
    const std::vector<float>& newest = maps_[slot(count_ - 1)];
    std::copy(newest.begin(), newest.end(), fused_.begin());
    double fill_sum = fills_[slot(count_ - 1)];
    for (std::size_t k = 0; k + 1 < count_; ++k) {
        add_translated(maps_[slot(k)].data(), w, fused_.data(), w, h, w, offsets[2 * k], offsets[2 * k + 1]);
        fill_sum += fills_[slot(k)];
    }
    return fill_sum;
}

}  // namespace nightloc
