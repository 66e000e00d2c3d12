// The grid Bayes filter (see nightloc/grid_filter.hpp): checks, bookkeeping and the estimate; the
// loops over the belief run in grid_filter_kernels.cpp (one table per SIMD path).
#include "nightloc/grid_filter.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "localization/grid_filter_kernels.hpp"
#include "nightloc/sad.hpp"
#include "nightloc/simd.hpp"

namespace nightloc {
namespace {

constexpr double kTwoPi = 6.283185307179586476925286766559;
constexpr double kPi = 3.141592653589793238462643383280;
constexpr double kLog2e = 1.442695040888963407359924681002;
// The likelihood's floor: 2^-60 relative to the best place (no underflow, no denormals).
constexpr double kLowestLog2 = -60.0;
// Blurs whose composed kernel (three box passes: 6 r + 7 taps) is at most this long run as one
// explicit pass per axis (shift included), row by row; wider ones as running sums on a padded
// tile (O(1) per cell, but several passes, two transposes and a tile of up to twice the grid's
// area: slower than 121 explicit taps on the 100 x 100 grid, measured on AVX-512).
constexpr std::size_t kMaxComposedTaps = 127;
// Cells per chunk of the loops over all bins (a multiple of 16: the sums' lanes and blocks).
constexpr std::size_t kCellChunk = 256;
// Bins per measurement pass of a fused update (the kernel reads the weights once per pass).
constexpr std::size_t kFusedBins = detail::kGroupBins;
// Most places of a dense block of the measurement (see detail::UpdateArgs).
constexpr std::size_t kDensePlaces = 8;

void require(bool ok, const std::string& message) {
    if (!ok) throw std::invalid_argument(message);
}

// Extended box pass parameters for a pass variance s2 (cells^2), Gwosdek et al. 2011.
detail::BoxPass box_pass(double s2) {
    const double r_real = std::floor(0.5 * std::sqrt(12.0 * s2 + 1.0) - 0.5);
    const auto r = static_cast<std::size_t>(r_real);
    const double rr = static_cast<double>(r);
    double alpha = (2 * rr + 1) * (3 * s2 - rr * (rr + 1)) / (6 * ((rr + 1) * (rr + 1) - s2));
    alpha = std::min(std::max(alpha, 0.0), 1.0);
    return {r, alpha, 1.0 / (2 * rr + 1 + 2 * alpha)};
}

// A 1-D Gaussian of variance v along direction `angle`, as an axis-aligned one of variances
// v wx, v wy: shares proportional to |cos| and |sin| whose variance along the direction is v
// exactly (c^2 wx + s^2 wy = 1); along an axis it is exact, at 45 degrees isotropic.
void axis_shares(double angle, double& wx, double& wy) {
    const double c = std::fabs(std::cos(angle)), s = std::fabs(std::sin(angle));
    const double k = 1.0 / (c * c * c + s * s * s);
    wx = k * c;
    wy = k * s;
}

// The median of `values` by selection (the mean of the two middle values for an even count, in
// double); reorders them.
double median_of(std::vector<float>& values) {
    const std::size_t n = values.size();
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>(n / 2);
    std::nth_element(values.begin(), middle, values.end());
    double median = static_cast<double>(*middle);
    if (n % 2 == 0) {
        const float below = *std::max_element(values.begin(), middle);
        median = 0.5 * (static_cast<double>(below) + median);
    }
    return median;
}

// Wraps an angle to (-pi, pi].
double wrap(double angle) {
    double a = std::fmod(angle + kPi, kTwoPi);
    if (a <= 0) a += kTwoPi;
    return a - kPi;
}

}  // namespace

GridFilter::GridFilter(GridFilterMap map, GridFilterSettings settings) : map_(std::move(map)), settings_(settings) {
    require(map_.weights != nullptr, "grid filter: the interpolation weights are null");
    const HeatWeights& w = *map_.weights;
    height_ = w.height();
    width_ = w.width();
    cells_ = w.cells();
    places_ = w.places();
    index_places();
    set_learned(std::move(map_.learned));
    const bool full_shifts = check_shifts();
    validate(settings_);
    choose_heading_bins(full_shifts);
    const auto csr = w.csr();
    copy_weights_to_ell(csr);
    build_dense_blocks();
    order_place_rows();
    find_place_cells(csr);
    allocate_buffers();
    reset();
}

void GridFilter::index_places() {
    require(std::isfinite(map_.x0) && std::isfinite(map_.y0), "grid filter: the grid origin must be finite");
    require(std::isfinite(map_.dx) && map_.dx > 0 && std::isfinite(map_.dy) && map_.dy > 0,
            "grid filter: the cell spacing must be finite and positive");
    require(!map_.place_of_ref.empty(), "grid filter: the map has no references");
    std::vector<bool> has_ref(places_, false);
    for (std::int32_t p : map_.place_of_ref) {
        require(p >= 0 && static_cast<std::size_t>(p) < places_, "grid filter: a reference's place is out of range");
        has_ref[static_cast<std::size_t>(p)] = true;
    }
    for (std::size_t p = 0; p < places_; ++p)
        if (!has_ref[p]) empty_places_.push_back(static_cast<std::int32_t>(p));
    first_of_place_.assign(map_.place_of_ref.size(), 0);
    std::fill(has_ref.begin(), has_ref.end(), false);
    for (std::size_t i = 0; i < map_.place_of_ref.size(); ++i) {
        const auto p = static_cast<std::size_t>(map_.place_of_ref[i]);
        first_of_place_[i] = has_ref[p] ? 0 : 1;
        has_ref[p] = true;
    }
}

bool GridFilter::check_shifts() const {
    require(map_.ref_headings.empty() || map_.ref_headings.size() == map_.place_of_ref.size(),
            "grid filter: ref_headings must be empty or hold one heading per reference");
    for (double h : map_.ref_headings) require(std::isfinite(h), "grid filter: reference headings must be finite");
    require(map_.columns >= 1 && map_.columns <= 1 << 16, "grid filter: columns must be 1..65536");
    require(!map_.shifts.empty() && map_.shifts.size() <= map_.columns,
            "grid filter: the shift list must hold 1..columns shifts");
    std::vector<bool> seen(map_.columns, false);
    bool full = map_.shifts.size() == map_.columns;
    for (std::size_t k = 0; k < map_.shifts.size(); ++k) {
        const std::int32_t s = map_.shifts[k];
        require(s >= 0 && static_cast<std::size_t>(s) < map_.columns && !seen[static_cast<std::size_t>(s)],
                "grid filter: shifts must be distinct and in [0, columns)");
        seen[static_cast<std::size_t>(s)] = true;
        full = full && static_cast<std::size_t>(s) == k;
    }
    return full;
}

void GridFilter::choose_heading_bins(bool full_shifts) {
    if (settings_.heading_bins == 0) settings_.heading_bins = map_.columns;
    require(settings_.heading_bins <= 4096, "grid filter: heading_bins 0 means one per image column, and " +
                                                std::to_string(map_.columns) +
                                                " columns are more than 4096 bins; set heading_bins");
    const GridFilterSettings& s = settings_;
    // the score cap tempered by the map's look-alikes: places with references beyond lookalike_places
    const auto with_refs = static_cast<double>(places_ - empty_places_.size());
    cap_ = s.score_cap;
    if (s.lookalike_places > 0 && with_refs > s.lookalike_places)
        cap_ = s.score_cap * std::log(s.lookalike_places) / std::log(with_refs);

    const ShiftWindow& window = map_.window;
    require(window.columns < map_.columns && window.rows <= 1000,
            "grid filter: the window must hold fewer columns than the image and at most 1000 rows");
    if (window.columns > 0) {
        require(map_.shifts.size() == 1 && map_.shifts[0] == 0,
                "grid filter: a column window is a forward camera's: its shift list must be {0}");
        require(std::isfinite(map_.field_of_view) && map_.field_of_view >= 0 && map_.field_of_view <= kTwoPi,
                "grid filter: field_of_view must be in [0, 2 pi] radians");
        for (auto dx = -static_cast<std::int32_t>(window.columns); dx <= static_cast<std::int32_t>(window.columns);
             ++dx)
            candidates_.push_back(dx);
    } else {
        candidates_ = map_.shifts;
    }
    const bool forward_pose = window.columns > 0 && map_.field_of_view > 0;
    can_pose_ = s.heading_bins > 1 && !map_.ref_headings.empty() && (full_shifts || forward_pose);
    bins_ = can_pose_ ? s.heading_bins : 1;
    require(bins_ <= (std::size_t{1} << 28) / cells_, "grid filter: heading bins x cells is too large");
}

void GridFilter::copy_weights_to_ell(const HeatWeights::Csr& csr) {
    // slot k of cell c at k * cells + c; unused slots weigh 0 at place 0; a cell without weights
    // reads the bin's fill value, kept at index places_
    slots_ = 1;
    for (std::size_t c = 0; c < cells_; ++c) {
        slots_ = std::max(slots_, static_cast<std::size_t>(csr.indptr[c + 1] - csr.indptr[c]));
    }
    ell_data_.assign(slots_ * cells_, 0.f);
    ell_index_.assign(slots_ * cells_, 0);
    for (std::size_t c = 0; c < cells_; ++c) {
        if (csr.indptr[c + 1] == csr.indptr[c]) {
            ell_data_[c] = 1.f;
            ell_index_[c] = static_cast<std::int32_t>(places_);
            continue;
        }
        for (auto k = static_cast<std::size_t>(csr.indptr[c]); k < static_cast<std::size_t>(csr.indptr[c + 1]); ++k) {
            const std::size_t slot = k - static_cast<std::size_t>(csr.indptr[c]);
            ell_data_[slot * cells_ + c] = csr.data[k];
            ell_index_[slot * cells_ + c] = csr.indices[k];
        }
    }
}

void GridFilter::build_dense_blocks() {
    // per kBlock cells the places they use (ascending; places_: the fill of cells without
    // weights) and each cell's weight of each, when there are at most kDensePlaces; otherwise the
    // block reads its cells' ELL slots
    const std::size_t blocks = (cells_ + detail::kBlock - 1) / detail::kBlock;
    block_start_.assign(blocks + 1, 0);
    block_places_.clear();
    block_weights_.clear();
    for (std::size_t block = 0; block < blocks; ++block) {
        const std::size_t c0 = block * detail::kBlock, c1 = std::min(cells_, c0 + detail::kBlock);
        std::vector<std::int32_t> used;
        for (std::size_t c = c0; c < c1; ++c)
            for (std::size_t k = 0; k < slots_; ++k)
                if (ell_data_[k * cells_ + c] != 0.f) used.push_back(ell_index_[k * cells_ + c]);
        std::sort(used.begin(), used.end());
        used.erase(std::unique(used.begin(), used.end()), used.end());
        if (used.size() <= kDensePlaces) {
            for (std::int32_t place : used) {
                block_places_.push_back(place);
                for (std::size_t lane = 0; lane < detail::kBlock; ++lane) {
                    float weight = 0.f;
                    const std::size_t c = c0 + lane;
                    for (std::size_t k = 0; c < c1 && k < slots_; ++k)
                        if (ell_index_[k * cells_ + c] == place) weight += ell_data_[k * cells_ + c];
                    block_weights_.push_back(weight);
                }
            }
        }
        block_start_[block + 1] = static_cast<std::int32_t>(block_places_.size());
        has_sparse_blocks_ = has_sparse_blocks_ || block_start_[block + 1] == block_start_[block];
    }
}

void GridFilter::order_place_rows() {
    // The rows of the per-place arrays in the order the cells first use them (row-major): cells
    // that follow each other read neighbouring rows (a map's own place order, e.g. sorted by x,
    // would spread one row of cells over all of them). Only the indices change: every sum keeps
    // its order.
    const auto unused = static_cast<std::int32_t>(cells_);
    std::vector<std::int32_t> first(places_, unused);
    for (std::size_t c = 0; c < cells_; ++c)
        for (std::size_t k = 0; k < slots_; ++k) {
            const auto p = static_cast<std::size_t>(ell_index_[k * cells_ + c]);
            if (p < places_ && ell_data_[k * cells_ + c] != 0.f && first[p] == unused)
                first[p] = static_cast<std::int32_t>(c);
        }
    std::vector<std::int32_t> order(places_);
    for (std::size_t p = 0; p < places_; ++p) order[p] = static_cast<std::int32_t>(p);
    std::stable_sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) {
        return first[static_cast<std::size_t>(a)] < first[static_cast<std::size_t>(b)];
    });
    std::vector<std::int32_t> row_of(places_ + 1);
    for (std::size_t r = 0; r < places_; ++r) row_of[static_cast<std::size_t>(order[r])] = static_cast<std::int32_t>(r);
    row_of[places_] = static_cast<std::int32_t>(places_);  // the fill stays last
    for (std::int32_t& p : ell_index_) p = row_of[static_cast<std::size_t>(p)];
    for (std::int32_t& p : block_places_) p = row_of[static_cast<std::size_t>(p)];
    for (std::int32_t& p : empty_places_) p = row_of[static_cast<std::size_t>(p)];
    row_of_ref_.resize(map_.place_of_ref.size());
    for (std::size_t i = 0; i < row_of_ref_.size(); ++i)
        row_of_ref_[i] = row_of[static_cast<std::size_t>(map_.place_of_ref[i])];
}

void GridFilter::find_place_cells(const HeatWeights::Csr& csr) {
    // each place's cell: where its weight is largest (ties: the first cell), the recall's distances
    std::vector<float> largest(places_, -1.f);
    place_cell_.assign(places_, cells_ / 2);
    for (std::size_t c = 0; c < cells_; ++c)
        for (auto k = static_cast<std::size_t>(csr.indptr[c]); k < static_cast<std::size_t>(csr.indptr[c + 1]); ++k) {
            const auto p = static_cast<std::size_t>(csr.indices[k]);
            if (csr.data[k] > largest[p]) {
                largest[p] = csr.data[k];
                place_cell_[p] = c;
            }
        }
}

void GridFilter::allocate_buffers() {
    belief_.resize(bins_ * cells_);
    work_.resize(bins_ * cells_);
    marginal_.resize(cells_);
    const std::size_t side = std::max(height_, width_);
    sums_.resize(side);
    zeros_.assign(side, 0.f);
    padded_.assign(side + 4, 0.f);  // grown for wide tiles and long kernels
    table_.resize(n_refs() * n_shifts());
    mins_.resize(n_refs());
    best_shifts_.resize(n_refs());
    ref_c0_.resize(n_refs());
    ref_fraction_.resize(n_refs());
    bin_max_.resize(bins_);
    log_lik_.resize((bins_ + detail::kGroupBins - 1) / detail::kGroupBins * (places_ + 1) * detail::kGroupBins);
}

void GridFilter::reset() {
    pending_ = false;
    frames_ = 0;
    bin_max_valid_ = false;
    pose_ = can_pose_;
    offset_ = 0;
    lambda_ = 0;
    const std::size_t n = active_bins() * cells_;
    std::fill(belief_.begin(), belief_.begin() + static_cast<std::ptrdiff_t>(n), 1.f);
    scale_ = 1.0 / static_cast<double>(n);
    marginal_valid_ = false;
    recall_cell_ = height_ / 2 * width_ + width_ / 2;
}

void GridFilter::set_learned(std::vector<std::uint8_t> learned) {
    const std::size_t n = map_.place_of_ref.size();
    require(learned.empty() || learned.size() == n,
            "grid filter: learned must be empty or hold one flag per reference (" + std::to_string(n) + ")");
    std::size_t count = 0;
    for (const std::uint8_t flag : learned) {
        require(flag <= 1, "grid filter: learned flags must be 0 (day map) or 1 (learned on a night)");
        count += flag;
    }
    map_.learned = std::move(learned);
    two_kinds_ = count > 0 && count < n;
    headings_ = map_.ref_headings;
    proxy_.assign(two_kinds_ ? n : 0, -1);
    day_refs_ = n - count;
    recalled_.assign(n, 1);
    if (!two_kinds_) return;
    std::vector<std::vector<std::size_t>> day_refs(places_);
    for (std::size_t d = 0; d < n; ++d)
        if (map_.learned[d] == 0) day_refs[static_cast<std::size_t>(map_.place_of_ref[d])].push_back(d);
    for (std::size_t i = 0; i < n; ++i) {
        if (map_.learned[i] == 0) continue;
        // the day reference of the place nearest in heading (ties: the first)
        double nearest = std::numeric_limits<double>::infinity();
        for (const std::size_t d : day_refs[static_cast<std::size_t>(map_.place_of_ref[i])]) {
            const double gap = headings_.empty() ? 0.0 : std::fabs(wrap(map_.ref_headings[d] - map_.ref_headings[i]));
            if (gap < nearest) {
                nearest = gap;
                proxy_[i] = static_cast<std::int32_t>(d);
            }
        }
        if (proxy_[i] >= 0 && !headings_.empty()) headings_[i] = map_.ref_headings[static_cast<std::size_t>(proxy_[i])];
    }
}

void GridFilter::choose_recall() {
    // at most as many learned references with a day reference as the day references
    // (GridFilterMap::learned): half the budget nearest the last belief's peak, the rest in turn
    const std::size_t n = n_refs();
    recall_order_.clear();
    for (std::size_t i = 0; i < n; ++i) {
        recalled_[i] = 1;
        if (map_.learned[i] != 0 && proxy_[i] >= 0) recall_order_.push_back(i);
    }
    if (recall_order_.size() <= day_refs_) return;
    for (const std::size_t i : recall_order_) recalled_[i] = 0;
    const double cx = static_cast<double>(recall_cell_ % width_), cy = static_cast<double>(recall_cell_ / width_);
    auto d2 = [&](std::size_t i) {
        const std::size_t c = place_cell_[static_cast<std::size_t>(map_.place_of_ref[i])];
        const double ex = map_.dx * (static_cast<double>(c % width_) - cx);
        const double ey = map_.dy * (static_cast<double>(c / width_) - cy);
        return ex * ex + ey * ey;
    };
    const auto nearer = [&](std::size_t a, std::size_t b) {
        const double da = d2(a), db = d2(b);
        return da < db || (da == db && a < b);
    };
    const std::size_t near = day_refs_ / 2, turn = day_refs_ - near;
    matched_.assign(recall_order_.begin(), recall_order_.end());  // scratch: nearest first
    std::nth_element(matched_.begin(), matched_.begin() + static_cast<std::ptrdiff_t>(near), matched_.end(), nearer);
    for (std::size_t k = 0; k < near; ++k) recalled_[matched_[k]] = 1;
    // the others in index order, a window of them moving on by `turn` every frame (a lost robot
    // meets every look within a few frames)
    matched_.clear();
    for (const std::size_t i : recall_order_)
        if (recalled_[i] == 0) matched_.push_back(i);
    const std::size_t start = frames_ * turn % matched_.size();
    for (std::size_t k = 0; k < turn; ++k) recalled_[matched_[(start + k) % matched_.size()]] = 1;
}

void GridFilter::scale_learned() {
    // the frame's recalled learned references as evidence about their day references
    // (GridFilterMap::learned); table_, mins_ and best_shifts_ hold the frame's scores
    const std::size_t n = n_refs(), S = n_shifts();
    sorted_.clear();
    for (std::size_t i = 0; i < n; ++i)
        if (map_.learned[i] == 0) sorted_.push_back(mins_[i]);
    const double day = median_of(sorted_);
    sorted_.clear();
    for (std::size_t i = 0; i < n; ++i)
        if (map_.learned[i] != 0 && recalled_[i] != 0) sorted_.push_back(mins_[i]);
    const double night = median_of(sorted_);
    const bool scaled = day > 0 && night > 0;  // else a frame that equals references: no scale to bring
    const double ratio = scaled ? day / night : 1.0;
    // (1) on the day scale; a learned reference's best minimum to its day reference
    const float inf = std::numeric_limits<float>::infinity();
    evidence_.assign(n, inf);
    for (std::size_t i = 0; scaled && i < n; ++i) {
        if (map_.learned[i] == 0 || recalled_[i] == 0) continue;
        const auto on_day = static_cast<float>(static_cast<double>(mins_[i]) * ratio);
        if (proxy_[i] >= 0) {
            float& best = evidence_[static_cast<std::size_t>(proxy_[i])];
            best = std::min(best, on_day);
            continue;
        }
        float* row = table_.data() + i * S;  // a place learned in a gap: scaled only
        for (std::size_t j = 0; j < S; ++j) row[j] = static_cast<float>(static_cast<double>(row[j]) * ratio);
        mins_[i] = on_day;
    }
    // (2) each day reference with learned ones moved by their evidence against the typical one's
    sorted_.clear();
    for (std::size_t d = 0; d < n; ++d)
        if (evidence_[d] < inf) sorted_.push_back(evidence_[d]);
    const double neutral = sorted_.empty() ? 0.0 : median_of(sorted_);
    for (std::size_t d = 0; d < n; ++d) {
        if (!(evidence_[d] < inf)) continue;
        const double move = static_cast<double>(evidence_[d]) - neutral;
        float* row = table_.data() + d * S;
        for (std::size_t j = 0; j < S; ++j) row[j] = static_cast<float>(static_cast<double>(row[j]) + move);
        mins_[d] = static_cast<float>(static_cast<double>(mins_[d]) + move);
    }
    // (3) a learned reference scores as its day reference (recalled or not)
    for (std::size_t i = 0; i < n; ++i) {
        if (map_.learned[i] == 0 || proxy_[i] < 0) continue;
        const auto d = static_cast<std::size_t>(proxy_[i]);
        std::copy(table_.begin() + static_cast<std::ptrdiff_t>(d * S),
                  table_.begin() + static_cast<std::ptrdiff_t>((d + 1) * S),
                  table_.begin() + static_cast<std::ptrdiff_t>(i * S));
        mins_[i] = mins_[d];
        best_shifts_[i] = best_shifts_[d];
    }
}

void GridFilter::set_noise(double distance_std, double heading_std, double distance_per_metre,
                           double heading_per_radian) {
    GridFilterSettings next = settings_;
    next.distance_std = distance_std;
    next.heading_std = heading_std;
    next.distance_per_metre = distance_per_metre;
    next.heading_per_radian = heading_per_radian;
    validate(next);  // the settings' one range check; the filter is unchanged when it throws
    settings_ = next;
}

// ---------------------------------------------------------------------------------------------
// prediction

namespace {

// Taps of the composed kernel below this share of its peak are left out (symmetric, from the ends).
constexpr double kKernelCut = 1e-4;

std::vector<double> composed_box_kernel(double sigma) {
    // three extended-box passes of variance sigma^2 / 3 each, convolved: taps -R..R, R = 3 (r + 1)
    const detail::BoxPass pass = box_pass(sigma * sigma / 3.0);
    std::vector<double> box(2 * pass.r + 3, pass.inv_w);
    box.front() = box.back() = pass.alpha * pass.inv_w;
    std::vector<double> kernel{1.0};
    for (int p = 0; p < 3; ++p) {
        std::vector<double> next(kernel.size() + box.size() - 1, 0.0);
        for (std::size_t a = 0; a < kernel.size(); ++a)
            for (std::size_t b = 0; b < box.size(); ++b) next[a + b] += kernel[a] * box[b];
        kernel.swap(next);
    }
    // the ends below 1e-4 of the peak (the passes' alpha^2, alpha^3 corners) are left out
    const double peak = *std::max_element(kernel.begin(), kernel.end());
    std::size_t cut = 0;
    while (2 * cut + 1 < kernel.size() && kernel[cut] < kKernelCut * peak) ++cut;
    return std::vector<double>(kernel.begin() + static_cast<std::ptrdiff_t>(cut),
                               kernel.end() - static_cast<std::ptrdiff_t>(cut));
}

// The taps of one axis: the bilinear shift by `shift` cells convolved with the blur `kernel`
// (centred), as conv_rows/conv_cols take them (taps[t] weighs source index j + t - offset).
void shift_blur_taps(double shift, const std::vector<double>& kernel, std::vector<float>& taps,
                     std::ptrdiff_t& offset) {
    const double whole = std::floor(shift);
    const double frac = shift - whole;
    const auto R = static_cast<std::ptrdiff_t>(kernel.size() / 2);
    const auto base = static_cast<std::ptrdiff_t>(whole);
    // H_v for v = base - R .. base + 1 + R: out[j] = sum_v H_v in[j - v]
    std::vector<double> h(kernel.size() + 1, 0.0);
    for (std::size_t u = 0; u < kernel.size(); ++u) {
        h[u] += kernel[u] * (1.0 - frac);
        h[u + 1] += kernel[u] * frac;
    }
    // h[q] is H_{base - R + q}; taps[t] = H_{v_max - t}
    std::size_t last = h.size();
    while (last > 1 && h[last - 1] == 0.0) --last;  // an integral shift: no zero tap at the end
    const std::ptrdiff_t v_max = base - R + static_cast<std::ptrdiff_t>(last) - 1;
    taps.resize(last);
    for (std::size_t t = 0; t < last; ++t) taps[t] = static_cast<float>(h[last - 1 - t]);
    offset = v_max;
}

}  // namespace

void GridFilter::translate_blur_slice(const float* src, float* dst, const SliceMotion& m) const {
    const auto& k = detail::filter_kernels(active_simd_backend());
    const double shift_x = m.shift_x, shift_y = m.shift_y, sigma_x = m.sigma_x, sigma_y = m.sigma_y;
    const double limit = 4.0 * static_cast<double>(height_ + width_) + 16.0;
    if (std::fabs(shift_x) > limit + 8 * sigma_x || std::fabs(shift_y) > limit + 8 * sigma_y) {
        std::fill(dst, dst + cells_, 0.f);  // everything lands beyond the grid
        return;
    }
    // Per axis one operator: the bilinear shift convolved with the three box passes. Kernels up
    // to kMaxComposedTaps run as one explicit pass per axis (composed taps), row by row; wider
    // ones as the shift's two taps, then running sums (O(1) per cell) on a tile with room for
    // everything that spreads beyond the grid and may come back (the passes' intermediate
    // results included).
    const detail::BoxPass pass_x = box_pass(sigma_x * sigma_x / 3.0), pass_y = box_pass(sigma_y * sigma_y / 3.0);
    const bool wide_x = sigma_x > 0 && 6 * pass_x.r + 7 > kMaxComposedTaps;
    const bool wide_y = sigma_y > 0 && 6 * pass_y.r + 7 > kMaxComposedTaps;
    static const std::vector<double> identity{1.0};
    std::ptrdiff_t off_x = 0, off_y = 0;
    shift_blur_taps(shift_y, wide_y || !(sigma_y > 0) ? identity : composed_box_kernel(sigma_y), taps_y_, off_y);
    shift_blur_taps(shift_x, wide_x || !(sigma_x > 0) ? identity : composed_box_kernel(sigma_x), taps_x_, off_x);
    if (!wide_x && !wide_y) {  // the common case: two explicit passes, row by row, grid to grid
        shift_blur_rows(src, dst, off_x, off_y);
        return;
    }
    const std::size_t my =
        wide_y ? static_cast<std::size_t>(std::fabs(std::floor(shift_y))) + 2 + 3 * (pass_y.r + 1) : 0;
    const std::size_t mx =
        wide_x ? static_cast<std::size_t>(std::fabs(std::floor(shift_x))) + 2 + 3 * (pass_x.r + 1) : 0;
    const std::size_t th = height_ + 2 * my, tw = width_ + 2 * mx, tn = th * tw;
    wide_a_.assign(tn, 0.f);
    wide_b_.resize(tn);
    for (std::size_t j = 0; j < height_; ++j) {
        std::copy(src + j * width_, src + (j + 1) * width_, wide_a_.data() + (j + my) * tw + mx);
    }
    const std::size_t side = std::max(th, tw);
    if (sums_.size() < side) sums_.resize(side);
    if (zeros_.size() < side) zeros_.resize(side, 0.f);
    if (padded_.size() < side + taps_x_.size()) padded_.resize(side + taps_x_.size(), 0.f);
    float* current = wide_a_.data();
    float* other = wide_b_.data();
    // y: the composed pass, or the shift then three running passes across rows
    k.conv_rows(current, other, th, tw, taps_y_.data(), taps_y_.size(), off_y, zeros_.data());
    std::swap(current, other);
    if (wide_y) {
        for (int p = 0; p < 3; ++p) {
            k.box_rows(current, other, th, tw, pass_y, sums_.data(), zeros_.data());
            std::swap(current, other);
        }
    }
    // x: the composed pass, or the shift then three running passes across the transpose's rows
    k.conv_cols(current, other, th, tw, taps_x_.data(), taps_x_.size(), off_x, padded_.data());
    std::swap(current, other);
    if (wide_x) {
        k.transpose(current, other, th, tw);  // now tw rows of th
        std::swap(current, other);
        for (int p = 0; p < 3; ++p) {
            k.box_rows(current, other, tw, th, pass_x, sums_.data(), zeros_.data());
            std::swap(current, other);
        }
        k.transpose(current, other, tw, th);
        std::swap(current, other);
    }
    for (std::size_t j = 0; j < height_; ++j) {
        std::copy(current + (j + my) * tw + mx, current + (j + my) * tw + mx + width_, dst + j * width_);
    }
}

void GridFilter::shift_blur_rows(const float* src, float* dst, std::ptrdiff_t off_x, std::ptrdiff_t off_y) const {
    // the composed taps (taps_x_, taps_y_) as two explicit passes, row by row, grid to grid
    const auto& k = detail::filter_kernels(active_simd_backend());
    const auto n_x = static_cast<std::ptrdiff_t>(taps_x_.size());
    // the rows' margin: a whole number of cache lines (the row pass's stores are aligned)
    const auto reach = static_cast<std::size_t>(std::max<std::ptrdiff_t>({off_x, n_x - 1 - off_x, 0}));
    const std::size_t pad = (reach + 15) / 16 * 16;
    const std::size_t span = (width_ + 2 * pad + 15) / 16 * 16;
    if (row_buf_.size() < 2 * span) row_buf_.resize(2 * span);
    std::fill(row_buf_.begin(), row_buf_.begin() + static_cast<std::ptrdiff_t>(2 * span), 0.f);
    const detail::ShiftBlurArgs args{src,
                                     dst,
                                     height_,
                                     width_,
                                     taps_y_.data(),
                                     taps_y_.size(),
                                     off_y,
                                     taps_x_.data(),
                                     taps_x_.size(),
                                     off_x,
                                     row_buf_.data(),
                                     pad,
                                     zeros_.data()};
    k.shift_blur(args);
}

void GridFilter::to_position() {
    if (!pose_) return;
    bin_max_valid_ = false;
    materialize();
    const auto& k = detail::filter_kernels(active_simd_backend());
    k.sum_slices(belief_.data(), bins_, cells_, work_.data());
    std::copy(work_.begin(), work_.begin() + static_cast<std::ptrdiff_t>(cells_), belief_.begin());
    pose_ = false;  // the same total: the scale holds
}

void GridFilter::to_pose() {
    if (pose_ || !can_pose_) return;
    bin_max_valid_ = false;
    materialize();
    for (std::size_t b = 1; b < bins_; ++b) {
        std::copy(belief_.begin(), belief_.begin() + static_cast<std::ptrdiff_t>(cells_),
                  belief_.begin() + static_cast<std::ptrdiff_t>(b * cells_));
    }
    scale_ /= static_cast<double>(bins_);  // bins copies of the same total
    pose_ = true;
}

void GridFilter::begin_prediction(std::vector<float> taps, std::vector<std::size_t> offsets) {
    // The prediction is pending: the next update runs it fused with the measurement (slice by
    // slice, while they are in cache), materialize() on its own. The prior of a cell is
    // (1 - floor) (its predicted mass) / (the belief's total before the prediction) + floor /
    // cells: mass that leaves the grid is gone, not given back to the cells that stay.
    const std::size_t n = active_bins() * cells_;
    const double eps = settings_.uniform_floor;
    pending_taps_ = std::move(taps);
    pending_offsets_ = std::move(offsets);
    pending_a_ = static_cast<float>((1.0 - eps) * scale_);
    pending_f_ = static_cast<float>(eps / static_cast<double>(n));
    pending_ = true;
    marginal_valid_ = false;
}

void GridFilter::materialize() const {
    if (!pending_) return;
    bin_max_valid_ = false;
    const auto& k = detail::filter_kernels(active_simd_backend());
    const std::size_t B = active_bins();
    for (std::size_t d = 0; d < B; ++d) {
        const SliceMotion& m = pending_motion_[d];
        translate_blur_slice(belief_.data() + m.source * cells_, work_.data() + d * cells_, m);
    }
    for (std::size_t c0 = 0; c0 < cells_; c0 += kCellChunk) {  // all bins of a chunk of cells: L2-resident
        k.heading_conv(work_.data(), B, cells_, c0, std::min(kCellChunk, cells_ - c0), pending_taps_.data(),
                       pending_offsets_.data(), pending_taps_.size(), pending_a_, pending_f_, belief_.data());
    }
    pending_ = false;
    double lanes[detail::kSumLanes] = {};
    k.sum(belief_.data(), B * cells_, lanes);
    const double total = detail::lane_total(lanes);
    if (!(total > 0) || !std::isfinite(total)) {  // nothing left on the grid and no floor: start again, uniform
        std::fill(belief_.begin(), belief_.begin() + static_cast<std::ptrdiff_t>(B * cells_), 1.f);
        scale_ = 1.0 / static_cast<double>(B * cells_);
    } else {
        scale_ = 1.0 / total;
    }
}

void GridFilter::predict_robot(double forward, double left, double turn) {
    if (!std::isfinite(forward) || !std::isfinite(left) || !std::isfinite(turn)) {
        throw std::invalid_argument("grid filter: robot motion must be finite");
    }
    if (!can_pose_) {
        throw std::logic_error(
            "grid filter: robot-frame motion needs heading bins, and this filter has none (no reference headings, "
            "a forward camera or heading_bins = 1); pass map-frame motion");
    }
    to_pose();
    materialize();
    const GridFilterSettings& s = settings_;
    const double step = kTwoPi / static_cast<double>(bins_);
    // the odometry's distance noise lies along the motion: its direction in the robot frame
    const double along = std::hypot(forward, left) > 0 ? std::atan2(left, forward) : 0.0;
    const double scaled_distance = s.distance_per_metre * std::hypot(forward, left);
    const double pf2 = s.position_floor * s.position_floor,
                 sd2 = s.distance_std * s.distance_std + scaled_distance * scaled_distance;
    const double turned = (offset_ + turn) / step;
    const double whole = std::floor(turned);
    double new_offset = (turned - whole) * step;
    long long roll = static_cast<long long>(whole);
    if (new_offset >= step) {  // rounding at the top of the range
        new_offset -= step;
        ++roll;
    }
    if (new_offset < 0) new_offset = 0;
    const auto B = static_cast<long long>(bins_);
    const auto k_roll = static_cast<std::size_t>(((roll % B) + B) % B);
    // negligible bins (see grid_filter.hpp): shifted, not blurred
    float negligible_below = 0.f;
    if (bin_max_valid_ && s.negligible > 0) {
        negligible_below = static_cast<float>(s.negligible * *std::max_element(bin_max_.begin(), bin_max_.end()));
    }
    pending_motion_.resize(bins_);
    for (std::size_t b = 0; b < bins_; ++b) {
        const double theta = offset_ + step * static_cast<double>(b);
        const double c = std::cos(theta), sn = std::sin(theta);
        const double mx = c * forward - sn * left, my = sn * forward + c * left;
        double wx, wy;
        axis_shares(theta + along, wx, wy);
        const bool blur = !(bin_max_[b] < negligible_below);
        const double sigma_x = blur ? std::sqrt(sd2 * wx + pf2) : 0.0, sigma_y = blur ? std::sqrt(sd2 * wy + pf2) : 0.0;
        pending_motion_[(b + k_roll) % bins_] = {b, mx / map_.dx, my / map_.dy, sigma_x / map_.dx, sigma_y / map_.dy};
    }
    offset_ = new_offset;
    // the heading blur: a circular Gaussian over the bins, taps within 3 std, folded and normalized
    const double sigma_bins =
        std::hypot(std::hypot(s.heading_std, s.heading_per_radian * turn), s.heading_floor) / step;
    std::vector<double> taps(bins_, 0.0);
    if (sigma_bins < 1e-6) {
        taps[0] = 1.0;
    } else {
        const auto reach = static_cast<long long>(std::ceil(3.0 * sigma_bins));
        for (long long t = -reach; t <= reach; ++t) {
            const double v = std::exp(-0.5 * static_cast<double>(t * t) / (sigma_bins * sigma_bins));
            taps[static_cast<std::size_t>(((t % B) + B) % B)] += v;
        }
        double sum = 0, peak = 0;
        for (double v : taps) {
            sum += v;
            peak = std::max(peak, v);
        }
        for (double& v : taps) v = v < kKernelCut * peak ? 0.0 : v / sum;  // taps below 1e-4 of the peak: none
    }
    std::vector<float> tap_values;
    std::vector<std::size_t> tap_offsets;
    for (std::size_t d = 0; d < bins_; ++d) {
        const auto v = static_cast<float>(taps[d]);
        if (v > 0) {
            tap_values.push_back(v);
            tap_offsets.push_back(d);
        }
    }
    begin_prediction(std::move(tap_values), std::move(tap_offsets));
}

void GridFilter::predict_map(double dx, double dy) {
    if (!std::isfinite(dx) || !std::isfinite(dy)) throw std::invalid_argument("grid filter: map motion must be finite");
    to_position();
    materialize();
    const GridFilterSettings& s = settings_;
    // noise on the step's length (along it) and direction (across it, |d| heading_std): the
    // covariance without its off-diagonal term, plus the floor
    const double d = std::hypot(dx, dy);
    const double direction = d > 0 ? std::atan2(dy, dx) : 0.0;
    const double along2 = s.distance_std * s.distance_std, across2 = d * s.heading_std * d * s.heading_std;
    const double pf2 = s.position_floor * s.position_floor;
    double ax, ay, cx, cy;
    axis_shares(direction, ax, ay);
    axis_shares(direction + 0.5 * kPi, cx, cy);
    const double sigma_x = std::sqrt(along2 * ax + across2 * cx + pf2);
    const double sigma_y = std::sqrt(along2 * ay + across2 * cy + pf2);
    pending_motion_.assign(1, {0, dx / map_.dx, dy / map_.dy, sigma_x / map_.dx, sigma_y / map_.dy});
    begin_prediction({1.f}, {0});
}

void GridFilter::predict_unknown() {
    to_position();
    materialize();
    const double sigma = settings_.unknown_spread;
    pending_motion_.assign(1, {0, 0.0, 0.0, sigma / map_.dx, sigma / map_.dy});
    begin_prediction({1.f}, {0});
}

// ---------------------------------------------------------------------------------------------
// update

void GridFilter::update_image(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs_in,
                              std::size_t image_height, int threads) {
    if (query == nullptr || refs == nullptr) throw std::invalid_argument("grid filter: null image");
    require(n_refs_in == n_refs(), "grid filter: the reference stack has " + std::to_string(n_refs_in) +
                                       " images but the map has " + std::to_string(n_refs()));
    // the sums into a buffer kept between frames (no 4 bytes per entry allocated, zeroed and
    // faulted in per frame), then rotational_sad's scores: float(double(sum) / pixels)
    if (map_.window.columns > 0 || map_.window.rows > 0) {  // the translation window: means over the overlap
        rotational_sad(query, refs, n_refs_in, image_height, map_.columns, map_.shifts.data(), map_.shifts.size(),
                       map_.window, table_.data(), nullptr, threads);
        update(table_.data());
        return;
    }
    if (two_kinds_) choose_recall();
    matched_.clear();
    for (std::size_t i = 0; two_kinds_ && i < n_refs_in; ++i)
        if (recalled_[i] != 0) matched_.push_back(i);
    sums_table_.resize(table_.size());
    const double pixels = static_cast<double>(image_height * map_.columns);
    const auto& kernels = detail::filter_kernels(active_simd_backend());
    if (!two_kinds_ || matched_.size() == n_refs_in) {
        rotational_sad_sums(query, refs, n_refs_in, image_height, map_.columns, map_.shifts.data(), map_.shifts.size(),
                            sums_table_.data(), threads);
        kernels.scale_sums(sums_table_.data(), table_.size(), pixels, table_.data());
    } else {  // the recalled references only, gathered (the others score as their day references)
        const std::size_t image = image_height * map_.columns, S = n_shifts();
        gathered_.resize(matched_.size() * image);
        for (std::size_t k = 0; k < matched_.size(); ++k)
            std::copy(refs + matched_[k] * image, refs + (matched_[k] + 1) * image, gathered_.begin() + k * image);
        rotational_sad_sums(query, gathered_.data(), matched_.size(), image_height, map_.columns, map_.shifts.data(),
                            map_.shifts.size(), sums_table_.data(), threads);
        std::fill(table_.begin(), table_.end(), 0.f);
        for (std::size_t k = 0; k < matched_.size(); ++k)
            kernels.scale_sums(sums_table_.data() + k * S, S, pixels, table_.data() + matched_[k] * S);
    }
    update_recalled(table_.data());
}

double GridFilter::shift_of_bin0(std::size_t i, double W) const {
    // the fractional column shift of heading bin 0 for reference i, reduced to [0, W)
    double c = (offset_ - headings_[i]) * W / kTwoPi;
    c -= W * std::floor(c / W);
    if (!(c < W) || c < 0) c = 0.0;  // rounding at the ends of the range
    return c;
}

void GridFilter::update(const float* table) {
    if (two_kinds_) choose_recall();
    update_recalled(table);
}

void GridFilter::update_recalled(const float* table) {
    table = take_scores(table);
    const LikelihoodScale scale = likelihood_scale();
    if (pose_ && !forward() && bins_ == map_.columns) {
        log_lik_by_columns(table, scale);
    } else {
        log_lik_by_places(table, scale);
    }
    measure_all_bins();
}

const float* GridFilter::take_scores(const float* table) {
    if (table == nullptr) throw std::invalid_argument("grid filter: null table");
    const std::size_t n = n_refs(), S = n_shifts();
    const auto& k = detail::filter_kernels(active_simd_backend());
    if (k.row_minima(table, n, S, mins_.data(), best_shifts_.data())) {
        for (std::size_t i = 0; i < n * S; ++i) {
            if (!std::isfinite(table[i])) {
                throw std::invalid_argument("grid filter: the score table holds NaN or infinity (reference " +
                                            std::to_string(i / S) + ")");
            }
        }
    }
    if (table != table_.data()) std::copy(table, table + n * S, table_.begin());
    for (std::size_t i = 0; i < n; ++i) best_shifts_[i] = candidates_[static_cast<std::size_t>(best_shifts_[i])];
    if (two_kinds_) {
        scale_learned();
        table = table_.data();
    }
    return table;
}

GridFilter::LikelihoodScale GridFilter::likelihood_scale() {
    // the median by selection (the two middle values for an even count), not a full sort
    sorted_.assign(mins_.begin(), mins_.end());
    LikelihoodScale scale;
    scale.median = median_of(sorted_);
    scale.s_min = *std::min_element(mins_.begin(), mins_.end());
    const double spread = scale.median - scale.s_min;
    // the first frames since reset() tempered: frame k (from 0) at (k + 1) / settle_frames of the
    // gain, so that a few frames that agree on a look-alike cannot make the belief certain of it
    const double temper =
        settings_.settle_frames > 1
            ? std::min(1.0, static_cast<double>(frames_ + 1) / static_cast<double>(settings_.settle_frames))
            : 1.0;
    lambda_ = spread > 0 ? temper * settings_.likelihood_gain / spread : 0.0;
    ++frames_;
    // the outlier-robust likelihood: a score above s_min + score_cap spread counts as that one, so
    // a frame that matches a look-alike cannot erase the place the prior holds (log2 units)
    scale.lowest = cap_ > 0 ? std::max(kLowestLog2, -temper * settings_.likelihood_gain * cap_ * kLog2e) : kLowestLog2;
    scale.gain = -lambda_ * kLog2e;
    return scale;
}

// log_lik_ holds per place and bin the log2-likelihood y = max(-lambda log2(e) (score - s_min), -60)
// of the place's lowest score (of its references), in groups of kGroupBins bins (a pass of the
// measurement reads one group: places_ + 1 rows); row places_: the fill, the y of the bin's
// highest place score (cells without weights; places without references take it too: never
// preferred). y falls with the score: the lowest score's y is the highest y.

void GridFilter::set_place_row(std::size_t p, float value) {
    const std::size_t B = active_bins(), group_rows = places_ + 1;
    for (std::size_t b = 0; b < B; ++b)
        log_lik_[(b / detail::kGroupBins * group_rows + p) * detail::kGroupBins + b % detail::kGroupBins] = value;
}

void GridFilter::set_fill_rows(const float* fill) {
    const std::size_t B = active_bins(), group_rows = places_ + 1;
    for (std::size_t b = 0; b < B; ++b) {
        for (std::int32_t p : empty_places_) {
            log_lik_[(b / detail::kGroupBins * group_rows + static_cast<std::size_t>(p)) * detail::kGroupBins +
                     b % detail::kGroupBins] = fill[b];
        }
        log_lik_[(b / detail::kGroupBins * group_rows + places_) * detail::kGroupBins + b % detail::kGroupBins] =
            fill[b];
    }
}

void GridFilter::log_lik_by_columns(const float* table, const LikelihoodScale& scale) {
    // bin b is shift c0 + b: one fraction per reference
    const auto& k = detail::filter_kernels(active_simd_backend());
    const std::size_t n = n_refs(), B = active_bins();
    const float inf = std::numeric_limits<float>::infinity();
    const auto W = static_cast<double>(map_.columns);
    for (std::size_t i = 0; i < n; ++i) {
        const double c = shift_of_bin0(i, W);
        ref_c0_[i] = static_cast<std::int32_t>(c);
        ref_fraction_[i] = c - static_cast<double>(ref_c0_[i]);
    }
    for (std::int32_t p : empty_places_) set_place_row(static_cast<std::size_t>(p), inf);
    row_y_.resize(map_.columns);
    k.lerp_log_lik(table, n, map_.columns, row_of_ref_.data(), first_of_place_.data(), ref_c0_.data(),
                   ref_fraction_.data(), scale.gain, scale.s_min, scale.lowest, log_lik_.data(), places_ + 1,
                   row_y_.data());
    bin_high_.assign(B, inf);  // here the bins' lowest y
    k.group_min(log_lik_.data(), places_, B, places_ + 1, bin_high_.data());
    set_fill_rows(bin_high_.data());
}

void GridFilter::log_lik_by_places(const float* table, const LikelihoodScale& scale) {
    // per place and bin the lowest score of its references; place p's bins at p * B (made here
    // only: log_lik_by_columns needs none)
    const auto& k = detail::filter_kernels(active_simd_backend());
    const std::size_t B = active_bins();
    const float inf = std::numeric_limits<float>::infinity();
    place_scores_.assign(B * places_, inf);
    if (pose_ && forward()) {
        place_scores_forward(table, scale.median);
    } else if (pose_) {
        place_scores_panoramic(table);
    } else {
        for (std::size_t i = 0; i < n_refs(); ++i) {
            float& slot = place_scores_[static_cast<std::size_t>(row_of_ref_[i])];
            slot = std::min(slot, mins_[i]);
        }
    }
    for (std::int32_t p : empty_places_) {
        std::fill_n(place_scores_.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(p) * B), B, -inf);
    }
    bin_high_.assign(B, -inf);
    k.column_max(place_scores_.data(), places_, B, bin_high_.data());
    k.log_lik(place_scores_.data(), places_, B, scale.gain, scale.s_min, scale.lowest, log_lik_.data(), places_ + 1, 0);
    std::vector<float>& fill = row_y_;
    fill.resize(B);
    k.log_lik(bin_high_.data(), 1, B, scale.gain, scale.s_min, scale.lowest, fill.data(), 1, 0);
    // fill is grouped with one row: bin b at (b / 4) * 4 + b % 4 = b
    set_fill_rows(fill.data());
}

void GridFilter::place_scores_forward(const float* table, double median) {
    // a forward camera: each reference only in the bins whose heading sees it within the window
    // (column offset dx = wrap(theta_b - heading_i) columns / field_of_view); a bin spans step
    // radians, half_span columns each side of its centre: its score is the best of the columns it
    // spans (and of the interpolated centre)
    const std::size_t n = n_refs(), S = n_shifts(), B = active_bins();
    const float inf = std::numeric_limits<float>::infinity();
    const double per_radian = static_cast<double>(map_.columns) / map_.field_of_view;
    const auto c = static_cast<double>(map_.window.columns);
    const double step = kTwoPi / static_cast<double>(bins_);
    const double half_span = 0.5 * step * per_radian;
    const std::size_t last = 2 * map_.window.columns;
    for (std::size_t i = 0; i < n; ++i) {
        const float* row = table + i * S;
        float* ps = place_scores_.data() + static_cast<std::size_t>(row_of_ref_[i]) * B;
        for (std::size_t b = 0; b < bins_; ++b) {
            const double dx = wrap(offset_ + step * static_cast<double>(b) - headings_[i]) * per_radian;
            if (!(std::fabs(dx) <= c)) continue;  // not in view from this heading
            const double x = dx + c;              // in [0, 2 c]
            const auto j0 = std::min(static_cast<std::size_t>(x), last);
            const std::size_t j1 = std::min(j0 + 1, last);
            const double a = x - static_cast<double>(j0);
            auto v = static_cast<float>((1.0 - a) * row[j0] + a * row[j1]);
            const double lo = std::max(std::ceil(x - half_span), 0.0);
            const double hi = std::min(std::floor(x + half_span), static_cast<double>(last));
            for (auto j = static_cast<std::size_t>(lo); static_cast<double>(j) <= hi; ++j) v = std::min(v, row[j]);
            ps[b] = std::min(ps[b], v);
        }
    }
    // a place none of whose references is in view: the frame's median (no evidence)
    for (float& v : place_scores_)
        if (v == inf) v = static_cast<float>(median);
}

void GridFilter::place_scores_panoramic(const float* table) {
    // bin b of reference i reads the shift per_bin b + c, interpolated between its two columns
    const std::size_t n = n_refs(), S = n_shifts(), B = active_bins();
    const auto W = static_cast<double>(map_.columns);
    const auto columns = static_cast<std::int32_t>(map_.columns);
    const double per_bin = W / static_cast<double>(bins_);
    for (std::size_t i = 0; i < n; ++i) {
        const float* row = table + i * S;
        const double c = shift_of_bin0(i, W);  // bin b's shift: per_bin b + c in [0, 2 W)
        float* ps = place_scores_.data() + static_cast<std::size_t>(row_of_ref_[i]) * B;
        for (std::size_t b = 0; b < bins_; ++b) {
            const double shift = per_bin * static_cast<double>(b) + c;
            const auto kf = static_cast<std::int32_t>(shift);  // shift >= 0: truncation is the floor
            const double a = shift - static_cast<double>(kf);
            const std::int32_t k0 = kf >= columns ? kf - columns : kf;
            const std::int32_t k1 = k0 + 1 == columns ? 0 : k0 + 1;
            const auto v = static_cast<float>((1.0 - a) * row[k0] + a * row[k1]);
            ps[b] = std::min(ps[b], v);
        }
    }
}

void GridFilter::measure_all_bins() {
    // the prior (the belief itself, in place, or the pending prediction) times the likelihood in
    // log_lik_, normalized; a prior with nothing left: the likelihood alone
    const auto& k = detail::filter_kernels(active_simd_backend());
    const std::size_t B = active_bins();
    const float one = 1.f;
    detail::UpdateArgs args{block_start_.data(),
                            block_places_.data(),
                            block_weights_.data(),
                            ell_data_.data(),
                            ell_index_.data(),
                            slots_,
                            cells_,
                            log_lik_.data(),
                            detail::kGroupBins,
                            0,
                            &one,
                            1,
                            1.f,
                            0.f,
                            belief_.data(),
                            marginal_.data()};
    if (has_sparse_blocks_) sparse_y_.resize(detail::kGroupBins * cells_);
    // the prior is the belief itself (in place), one slice per bin
    slices_.resize(B);
    for (std::size_t b = 0; b < B; ++b) slices_[b] = belief_.data() + b * cells_;
    if (pending_) {
        measure_predicted(args);
    } else {
        for (std::size_t d0 = 0; d0 < B; d0 += kFusedBins) measure_group(args, d0, std::min(B, d0 + kFusedBins), d0);
    }
    double lanes[detail::kSumLanes] = {};
    k.sum(marginal_.data(), cells_, lanes);
    double total = detail::lane_total(lanes);
    if (!(total > 0) || !std::isfinite(total)) {  // nothing of the prior survived: the likelihood alone
        std::fill(belief_.begin(), belief_.begin() + static_cast<std::ptrdiff_t>(B * cells_), 1.f);
        args.taps = &one;
        args.n_taps = 1;
        args.a = 1.f;
        args.f = 0.f;
        for (std::size_t b = 0; b < B; ++b) slices_[b] = belief_.data() + b * cells_;
        for (std::size_t d0 = 0; d0 < B; d0 += kFusedBins) measure_group(args, d0, std::min(B, d0 + kFusedBins), d0);
        std::fill(std::begin(lanes), std::end(lanes), 0.0);
        k.sum(marginal_.data(), cells_, lanes);
        total = detail::lane_total(lanes);  // >= 2^-60 per cell: positive
    }
    scale_ = 1.0 / total;
    marginal_valid_ = true;
    bin_max_valid_ = pose_;
    // the next frame's recall centre: the first maximum of this belief
    recall_cell_ = static_cast<std::size_t>(
        std::max_element(marginal_.begin(), marginal_.begin() + static_cast<std::ptrdiff_t>(cells_)) -
        marginal_.begin());
}

void GridFilter::measure_group(detail::UpdateArgs& args, std::size_t d0, std::size_t d1, std::size_t first_slice) {
    const auto& k = detail::filter_kernels(active_simd_backend());
    args.log_lik = log_lik_.data() + d0 / detail::kGroupBins * (places_ + 1) * detail::kGroupBins;
    args.group_b0 = d0;
    if (has_sparse_blocks_) {  // the cells of blocks with many places: interpolated for these bins first
        args.sparse_y = sparse_y_.data();
        k.interpolate(args, d1 - d0, sparse_y_.data());
    }
    args.bin_max = bin_max_.data();
    k.measure(args, d0, d1 - d0, slices_.data() + first_slice * args.n_taps, 0, cells_);
}

void GridFilter::measure_predicted(detail::UpdateArgs& args) {
    // The pending prediction fused with the measurement, bin by bin in order: a bin's predicted
    // slice (translation and blur of its source bin) is made when a bin's prior first needs it,
    // in a free slice of work_ (the most recently freed: cache-hot), and freed after the last bin
    // that needs it; the posterior of bin d overwrites belief_[d] once the prediction that reads
    // it is made.
    const std::size_t B = active_bins();
    const std::size_t n_taps = pending_taps_.size();
    args.taps = pending_taps_.data();
    args.n_taps = n_taps;
    args.a = pending_a_;
    args.f = pending_f_;
    slot_of_.assign(B, -1);
    free_slots_.clear();
    for (std::size_t s = B; s-- > 0;) free_slots_.push_back(static_cast<std::int32_t>(s));
    std::vector<std::size_t>& last_use = last_use_;  // the last bin whose prior reads bin e's prediction
    std::vector<std::size_t>& dest_of_source = dest_of_source_;
    last_use.assign(B, 0);
    dest_of_source.assign(B, 0);
    for (std::size_t e = 0; e < B; ++e) {
        for (std::size_t t = 0; t < n_taps; ++t) last_use[e] = std::max(last_use[e], (e + pending_offsets_[t]) % B);
        dest_of_source[pending_motion_[e].source] = e;
    }
    auto predict = [&](std::size_t e) {
        if (slot_of_[e] >= 0) return;
        const std::int32_t slot = free_slots_.back();
        free_slots_.pop_back();
        const SliceMotion& m = pending_motion_[e];
        translate_blur_slice(belief_.data() + m.source * cells_, work_.data() + static_cast<std::size_t>(slot) * cells_,
                             m);
        slot_of_[e] = slot;
    };
    // kFusedBins bins at a time: the kernel reads the map's weights once for all of them
    slices_.resize(kFusedBins * n_taps);
    for (std::size_t d0 = 0; d0 < B; d0 += kFusedBins) {
        const std::size_t d1 = std::min(B, d0 + kFusedBins);
        for (std::size_t d = d0; d < d1; ++d) {
            for (std::size_t t = 0; t < n_taps; ++t) predict((d + B - pending_offsets_[t]) % B);
            predict(dest_of_source[d]);  // belief_[d] is read before it is overwritten
        }
        for (std::size_t d = d0; d < d1; ++d) {
            for (std::size_t t = 0; t < n_taps; ++t) {
                const auto slot = static_cast<std::size_t>(slot_of_[(d + B - pending_offsets_[t]) % B]);
                slices_[(d - d0) * n_taps + t] = work_.data() + slot * cells_;
            }
        }
        measure_group(args, d0, d1, 0);
        for (std::size_t d = d0; d < d1; ++d) {
            for (std::size_t t = 0; t < n_taps; ++t) {
                const std::size_t e = (d + B - pending_offsets_[t]) % B;
                if (last_use[e] == d && slot_of_[e] >= 0) {
                    free_slots_.push_back(slot_of_[e]);
                    slot_of_[e] = -1;
                }
            }
        }
    }
    pending_ = false;
}

// ---------------------------------------------------------------------------------------------
// estimate

const float* GridFilter::belief() const {
    materialize();
    return belief_.data();
}

double GridFilter::scale() const {
    materialize();
    return scale_;
}

void GridFilter::compute_marginal() const {
    if (marginal_valid_) return;
    materialize();
    detail::filter_kernels(active_simd_backend()).sum_slices(belief_.data(), active_bins(), cells_, marginal_.data());
    marginal_valid_ = true;
}

const float* GridFilter::marginal() const {
    compute_marginal();
    return marginal_.data();
}

GridEstimate GridFilter::estimate() const {
    compute_marginal();
    materialize();
    const float* M = marginal_.data();
    GridEstimate e;
    const MarginalMoments moments = marginal_moments();
    std::size_t peak = 0;  // the first maximum
    while (M[peak] != moments.hi) ++peak;
    e.cell = peak;
    const double mx = moments.sx / moments.total, my = moments.sy / moments.total;  // relative to (ox, oy)
    e.cov_xx = moments.sxx / moments.total - mx * mx;
    e.cov_xy = moments.sxy / moments.total - mx * my;
    e.cov_yy = moments.syy / moments.total - my * my;

    const std::size_t pj = peak / width_, pi = peak % width_, w = settings_.estimate_window;
    CellWindow around;
    around.j0 = pj >= w ? pj - w : 0, around.j1 = std::min(height_, pj + w + 1);
    around.i0 = pi >= w ? pi - w : 0, around.i1 = std::min(width_, pi + w + 1);
    if (moments.hi <= moments.lo) {
        e.flat = true;
        e.x = mx + moments.ox;
        e.y = my + moments.oy;
    } else {
        double m = 0, wx = 0, wy = 0;
        for (std::size_t j = around.j0; j < around.j1; ++j)
            for (std::size_t i = around.i0; i < around.i1; ++i) {
                const double v = M[j * width_ + i];
                m += v;
                wx += v * cell_x(i);
                wy += v * cell_y(j);
            }
        e.x = wx / m;
        e.y = wy / m;
    }
    credible_region(e, moments.total);
    if (!pose_) {
        e.heading = std::numeric_limits<double>::quiet_NaN();
        e.heading_var = std::numeric_limits<double>::quiet_NaN();
    } else {
        e.heading = peak_heading(around);
        e.heading_var = heading_variance();
    }
    return e;
}

GridFilter::MarginalMoments GridFilter::marginal_moments() const {
    // one pass: the maximum, the minimum and the raw moments of the marginal (per row in double,
    // offsets from the grid's centre: the covariance about the mean loses no digits)
    const float* M = marginal_.data();
    MarginalMoments s;
    s.ox = cell_x(width_ / 2), s.oy = cell_y(height_ / 2);
    xs_.resize(width_);
    for (std::size_t i = 0; i < width_; ++i) xs_[i] = cell_x(i) - s.ox;
    s.hi = s.lo = M[0];
    constexpr std::size_t kLanes = 4;  // independent sums (a fixed order: the same on every path)
    for (std::size_t j = 0; j < height_; ++j) {
        const float* row = M + j * width_;
        double rt[kLanes] = {}, rx[kLanes] = {}, rxx[kLanes] = {};
        float rh[kLanes], rl[kLanes];
        for (std::size_t l = 0; l < kLanes; ++l) rh[l] = rl[l] = row[0];
        std::size_t i = 0;
        for (; i + kLanes <= width_; i += kLanes) {
            for (std::size_t l = 0; l < kLanes; ++l) {
                const double v = row[i + l], x = xs_[i + l];
                rt[l] += v;
                rx[l] += v * x;
                rxx[l] += v * x * x;
                rh[l] = std::max(rh[l], row[i + l]);
                rl[l] = std::min(rl[l], row[i + l]);
            }
        }
        for (; i < width_; ++i) {
            const double v = row[i], x = xs_[i];
            rt[0] += v;
            rx[0] += v * x;
            rxx[0] += v * x * x;
            rh[0] = std::max(rh[0], row[i]);
            rl[0] = std::min(rl[0], row[i]);
        }
        double t = 0, tx = 0, txx = 0;
        for (std::size_t l = 0; l < kLanes; ++l) {
            t += rt[l];
            tx += rx[l];
            txx += rxx[l];
            s.hi = std::max(s.hi, rh[l]);
            s.lo = std::min(s.lo, rl[l]);
        }
        const double y = cell_y(j) - s.oy;
        s.total += t;
        s.sx += tx;
        s.sy += t * y;
        s.sxx += txx;
        s.sxy += tx * y;
        s.syy += t * y * y;
    }
    return s;
}

void GridFilter::credible_region(GridEstimate& e, double total) const {
    // credible radius (cells by their centres) and confidence, on squared distances: a histogram
    // of the mass over 1024 equal bins of d^2 up to the farthest corner's, the bin where the mass
    // reaches credibility, its cells sorted by distance
    const float* M = marginal_.data();
    const GridFilterSettings& s = settings_;
    dx2_.resize(width_);
    for (std::size_t i = 0; i < width_; ++i) {
        const double ex = cell_x(i) - e.x;
        dx2_[i] = ex * ex;
    }
    double far2 = 0;
    for (double corner_x : {cell_x(0), cell_x(width_ - 1)})
        for (double corner_y : {cell_y(0), cell_y(height_ - 1)}) {
            const double ex = corner_x - e.x, ey = corner_y - e.y;
            far2 = std::max(far2, ex * ex + ey * ey);
        }
    constexpr std::size_t kBins = 1024, kCopies = 4;  // copies: column i adds to copy i % 4 (no chain of
                                                      // adds to one bin through memory)
    hist_.assign(kCopies * kBins, 0.0);
    const double per = far2 > 0 ? static_cast<double>(kBins) / far2 : 0.0;
    const double r2 = s.confidence_radius * s.confidence_radius;
    double within = 0;
    for (std::size_t j = 0; j < height_; ++j) {
        const double ey = cell_y(j) - e.y, ey2 = ey * ey;
        const float* row = M + j * width_;
        for (std::size_t i = 0; i < width_; ++i) {
            const double d2 = ey2 + dx2_[i];
            hist_[(i % kCopies) * kBins + std::min(kBins - 1, static_cast<std::size_t>(d2 * per))] += row[i];
            if (d2 <= r2) within += row[i];
        }
    }
    e.confidence = std::min(std::max(within / total, 0.0), 1.0);
    const double target = s.credibility * total;
    double below = 0;
    std::size_t crossing = kBins - 1;
    for (std::size_t b = 0; b < kBins; ++b) {
        double mass = hist_[b];
        for (std::size_t k = 1; k < kCopies; ++k) mass += hist_[k * kBins + b];
        if (below + mass >= target) {
            crossing = b;
            break;
        }
        below += mass;
    }
    ring_.clear();  // the crossing bin's cells (bins start at d^2 = crossing / per)
    const double ring_start = per > 0 ? static_cast<double>(crossing) / per : 0.0;
    for (std::size_t j = 0; j < height_; ++j) {
        const double ey = cell_y(j) - e.y, ey2 = ey * ey;
        if (per > 0 && crossing + 1 < kBins && ey2 > static_cast<double>(crossing + 1) / per) continue;
        const float* row = M + j * width_;
        for (std::size_t i = 0; i < width_; ++i) {
            const double d2 = ey2 + dx2_[i];
            if (d2 + 1e-9 * far2 < ring_start) continue;
            if (std::min(kBins - 1, static_cast<std::size_t>(d2 * per)) == crossing) {
                ring_.push_back({d2, static_cast<double>(row[i])});
            }
        }
    }
    std::sort(ring_.begin(), ring_.end(), [](const RingCell& a, const RingCell& b) { return a.d2 < b.d2; });
    e.credible_radius = ring_.empty() ? std::sqrt(far2) : std::sqrt(ring_.back().d2);
    for (const RingCell& cell : ring_) {
        below += cell.mass;
        if (below >= target) {
            e.credible_radius = std::sqrt(cell.d2);
            break;
        }
    }
}

double GridFilter::peak_heading(const CellWindow& around) const {
    // the circular mean of the heading histogram over the cells around the peak, over its top bin
    // and two bins on each side (all bins when there are at most 5)
    std::vector<double> h(bins_, 0.0);
    for (std::size_t b = 0; b < bins_; ++b) {
        const float* slice = belief_.data() + b * cells_;
        double v = 0;
        for (std::size_t j = around.j0; j < around.j1; ++j)
            for (std::size_t i = around.i0; i < around.i1; ++i) v += slice[j * width_ + i];
        h[b] = v;
    }
    std::size_t top = 0;
    for (std::size_t b = 1; b < bins_; ++b)
        if (h[b] > h[top]) top = b;
    const double step = kTwoPi / static_cast<double>(bins_);
    double ss = 0, cc = 0;
    const std::size_t reach = bins_ <= 5 ? bins_ : 5;
    for (std::size_t t = 0; t < reach; ++t) {
        const std::size_t b = bins_ <= 5 ? t : (top + bins_ - 2 + t) % bins_;
        const double theta = offset_ + step * static_cast<double>(b);
        ss += h[b] * std::sin(theta);
        cc += h[b] * std::cos(theta);
    }
    return wrap(std::atan2(ss, cc));
}

double GridFilter::heading_variance() const {
    const auto& k = detail::filter_kernels(active_simd_backend());
    const double step = kTwoPi / static_cast<double>(bins_);
    double total = 0, ss = 0, cc = 0;
    bin_mass_.resize(bins_);
    for (std::size_t b = 0; b < bins_; ++b) {
        double lanes[detail::kSumLanes] = {};
        k.sum(belief_.data() + b * cells_, cells_, lanes);
        const double mass = detail::lane_total(lanes), theta = offset_ + step * static_cast<double>(b);
        bin_mass_[b] = mass;
        total += mass;
        ss += mass * std::sin(theta);
        cc += mass * std::cos(theta);
    }
    const double mean = std::atan2(ss, cc);
    double spread = 0;
    for (std::size_t b = 0; b < bins_; ++b) {
        const double d = wrap(offset_ + step * static_cast<double>(b) - mean);
        spread += bin_mass_[b] * d * d;
    }
    return spread / total;
}

std::size_t GridFilter::sparse_blocks() const noexcept {
    std::size_t count = 0;
    for (std::size_t block = 0; block + 1 < block_start_.size(); ++block)
        count += block_start_[block + 1] == block_start_[block];
    return count;
}

std::size_t GridFilter::memory_bytes() const noexcept {
    std::size_t bytes = sizeof(*this);
    auto add = [&](const auto& v) { bytes += v.capacity() * sizeof(v[0]); };
    add(pending_motion_), add(pending_taps_), add(pending_offsets_), add(ell_data_), add(ell_index_);
    add(block_start_), add(block_places_), add(block_weights_), add(sparse_y_), add(belief_), add(work_);
    add(slot_of_), add(free_slots_), add(slices_), add(last_use_), add(dest_of_source_), add(marginal_);
    add(row_buf_), add(zeros_), add(padded_), add(wide_a_), add(wide_b_), add(taps_x_), add(taps_y_), add(sums_);
    add(sums_table_), add(table_), add(mins_), add(sorted_), add(bin_high_), add(place_scores_), add(log_lik_);
    add(row_of_ref_), add(ref_c0_), add(ref_fraction_), add(row_y_), add(first_of_place_);
    add(empty_places_), add(bin_max_), add(bin_mass_), add(best_shifts_), add(xs_), add(dx2_), add(hist_), add(ring_);
    add(map_.place_of_ref), add(map_.ref_headings), add(map_.shifts), add(map_.learned), add(proxy_), add(headings_),
        add(evidence_), add(place_cell_), add(recalled_), add(recall_order_), add(matched_), add(gathered_);
    return bytes;
}

void GridFilter::set_belief(const float* belief, bool pose, double offset) {
    if (belief == nullptr) throw std::invalid_argument("grid filter: null belief");
    require(!pose || can_pose_, "grid filter: this filter has no pose mode");
    const double step = kTwoPi / static_cast<double>(bins_);
    require(std::isfinite(offset) && offset >= 0 && (offset < step || (!pose && offset == 0)),
            "grid filter: the heading offset must be in [0, 2 pi / bins)");
    const std::size_t n = (pose ? bins_ : 1) * cells_;
    double total = 0;
    for (std::size_t c = 0; c < n; ++c) {
        require(std::isfinite(belief[c]) && belief[c] >= 0, "grid filter: a belief must be finite and >= 0");
        total += belief[c];
    }
    require(total > 0, "grid filter: a belief must have a positive sum");
    std::copy(belief, belief + n, belief_.begin());
    pending_ = false;
    bin_max_valid_ = false;
    pose_ = pose;
    offset_ = offset;
    scale_ = 1.0 / total;
    marginal_valid_ = false;
}

}  // namespace nightloc
