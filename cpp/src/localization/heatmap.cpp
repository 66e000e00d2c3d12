// Heat maps and 2D sequence matching (see nightloc/heatmap.hpp): checks and bookkeeping; the
// loops (interpolation, translation, peak search) are compiled for each SIMD path in
// heatmap_kernels.cpp, and every path does the same IEEE operations in the same order.
#include "nightloc/heatmap.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "localization/heatmap_kernels.hpp"
#include "nightloc/simd.hpp"

namespace nightloc {

// --------------------------------------------------------------------------------------------
// weights

HeatWeights::HeatWeights(std::size_t height, std::size_t width, std::size_t n_places, std::vector<std::int32_t> indptr,
                         std::vector<std::int32_t> indices, std::vector<float> data)
    : height_(height),
      width_(width),
      places_(n_places),
      indptr_(std::move(indptr)),
      indices_(std::move(indices)),
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
    // ELL copy: slot k of every cell in one array (k * cells + c), unused slots weigh 0 (adding
    // 0 * value leaves a float32 sum unchanged), so the product vectorizes over cells.
    const std::size_t n = cells();
    for (std::size_t c = 0; c < n; ++c) {
        slots_ = std::max(slots_, static_cast<std::size_t>(indptr_[c + 1] - indptr_[c]));
    }
    ell_data_.assign(slots_ * n, 0.f);
    ell_index_.assign(slots_ * n, 0);
    for (std::size_t c = 0; c < n; ++c) {
        for (auto k = static_cast<std::size_t>(indptr_[c]); k < static_cast<std::size_t>(indptr_[c + 1]); ++k) {
            const std::size_t slot = k - static_cast<std::size_t>(indptr_[c]);
            ell_data_[slot * n + c] = data_[k];
            ell_index_[slot * n + c] = indices_[k];
        }
    }
}

void HeatWeights::interpolate(const float* place_values, float* heat) const {
    for (std::size_t p = 0; p < places_; ++p) {
        if (!std::isfinite(place_values[p])) throw std::invalid_argument("place values must be finite");
    }
    detail::heat_kernels(active_simd_backend())
        .interpolate(ell_data_.data(), ell_index_.data(), slots_, cells(), place_values, heat);
}

// --------------------------------------------------------------------------------------------
// translation

namespace {

// Checks, resolves the shifts and runs the kernel; `scratch` holds 3 * (width + 1) elements.
template <class T>
void translate_into(const T* src, std::size_t src_stride, T* out, std::size_t out_stride, std::size_t height,
                    std::size_t width, double shift_x, double shift_y, T* scratch) {
    if (height == 0 || width == 0) throw std::invalid_argument("heat maps must have at least one cell");
    if (src_stride < width || out_stride < width) throw std::invalid_argument("row stride shorter than a row");
    if (!std::isfinite(shift_x) || !std::isfinite(shift_y)) throw std::invalid_argument("shifts must be finite");
    const auto w = static_cast<double>(width), h = static_cast<double>(height);
    // beyond these, everything lands outside the grid (and the integer parts could overflow)
    if (shift_x >= w || shift_x < -w - 1.0 || shift_y >= h || shift_y < -h - 1.0) return;
    const double floor_x = std::floor(shift_x), floor_y = std::floor(shift_y);
    const double fx = shift_x - floor_x, fy = shift_y - floor_y;
    const detail::Translation<T> t{static_cast<std::ptrdiff_t>(floor_x),
                                   static_cast<std::ptrdiff_t>(floor_y),
                                   static_cast<T>(1.0 - fx),
                                   static_cast<T>(fx),
                                   static_cast<T>(1.0 - fy),
                                   static_cast<T>(fy)};
    detail::heat_kernels(active_simd_backend())
        .translate<T>()
        .add(src, src_stride, out, out_stride, height, width, t, scratch);
}

template <class T>
void add_translated_impl(const T* src, std::size_t src_stride, T* out, std::size_t out_stride, std::size_t height,
                         std::size_t width, double shift_x, double shift_y) {
    std::vector<T> scratch(3 * (width + 1));
    translate_into(src, src_stride, out, out_stride, height, width, shift_x, shift_y, scratch.data());
}

}  // namespace

void add_translated(const float* src, std::size_t src_stride, float* out, std::size_t out_stride, std::size_t height,
                    std::size_t width, double shift_x, double shift_y) {
    add_translated_impl(src, src_stride, out, out_stride, height, width, shift_x, shift_y);
}

void add_translated(const double* src, std::size_t src_stride, double* out, std::size_t out_stride, std::size_t height,
                    std::size_t width, double shift_x, double shift_y) {
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
    const std::size_t cell = k.find_first(heat, n, result.peak);  // the first maximum (numpy.argmax)
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
    take(heat, j0 * width);                          // rows above the box
    take(heat + j1 * width, (height - j1) * width);  // rows below
    for (std::size_t j = j0; j < j1; ++j) {
        const float* row = heat + j * width;
        take(row, i0);               // left of the box
        take(row + i1, width - i1);  // right of the box
        const std::uint8_t* mask = exclusion.mask.data() + (j + exclusion.rows - pj) * mask_width;
        for (std::size_t i = i0; i < i1; ++i) {  // the box outside the disk
            if (!mask[i + exclusion.cols - pi]) {
                second = any ? std::max(second, row[i]) : row[i];
                any = true;
            }
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
    if (!std::isfinite(fill)) throw std::invalid_argument("fill value must be finite");
    float* target = next_slot();
    weights_->interpolate(place_values, target);  // checks the values before anything changes
    commit(fill);
}

void HeatSequence::push_map(const float* excess, double fill) {
    if (excess == nullptr) throw std::invalid_argument("excess map is null");
    if (!std::isfinite(fill)) throw std::invalid_argument("fill value must be finite");
    const std::size_t n = weights_->cells();
    for (std::size_t c = 0; c < n; ++c) {
        if (!std::isfinite(excess[c])) throw std::invalid_argument("excess map values must be finite");
    }
    std::copy(excess, excess + n, next_slot());
    commit(fill);
}

float* HeatSequence::next_slot() {
    const std::size_t target = count_ < capacity_ ? slot(count_) : first_;  // full: overwrite the oldest
    if (maps_.size() <= target) maps_.resize(target + 1);
    maps_[target].resize(weights_->cells());
    return maps_[target].data();
}

void HeatSequence::commit(double fill) {
    const std::size_t target = count_ < capacity_ ? slot(count_) : first_;
    fills_[target] = fill;
    if (count_ < capacity_) {
        ++count_;
    } else {
        first_ = (first_ + 1) % capacity_;
    }
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
    scratch_.resize(3 * (w + 1));
    for (std::size_t k = 0; k + 1 < count_; ++k) {
        translate_into(maps_[slot(k)].data(), w, fused_.data(), w, h, w, offsets[2 * k], offsets[2 * k + 1],
                       scratch_.data());
        fill_sum += fills_[slot(k)];
    }
    return fill_sum;
}

}  // namespace nightloc
