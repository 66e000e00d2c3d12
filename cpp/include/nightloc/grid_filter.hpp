// A recursive grid Bayes filter (histogram filter, Markov localization) over position x heading
// for robot firmware that links nightloc::core: the robot's 2D localizer beyond the paper's sum of
// shifted heat maps (docs/localization.md; python/nightloc/localization/grid_filter.py is its Python
// face and documents the model; the numpy oracle in tests/ does the same arithmetic in float64).
//
//   nightloc::GridFilterMap map{weights, x0, y0, dx, dy, place_of_ref, ref_headings, 48, shifts};
//   nightloc::GridFilter filter(map, settings);
//   per frame:
//     filter.predict_robot(forward, left, turn);     // or predict_map(dx, dy) / predict_unknown()
//     filter.update_image(query, refs, n_refs);      // or update(table): the whole rotational SAD table
//     nightloc::GridEstimate e = filter.estimate();
//
// The belief. B heading bins x H x W cells (row-major, row 0 = lowest y), float32. Heading bin b
// is centred on offset() + 2*pi*b/B radians (counter-clockwise from +x); offset() in
// [0, 2*pi/B) follows the turns exactly (a turn rolls whole bins and moves the offset by the
// rest: no smearing by interpolation). Pose mode (B > 1) needs reference headings and a full
// panorama (shift list 0..columns-1) or a forward camera searched over a column window (its
// field of view given); otherwise, and while the odometry is map-frame or unknown
// (which carries no turn: heading bins would go stale), the belief is position-only (one slice,
// the heading marginalized); a robot-frame motion expands it again, uniform over heading.
//
// Prediction (robot motion f, l, t in the robot frame at the previous frame):
//   1. every bin b moves by R(theta_b) (f, l) metres (bilinear, sub-cell) and lands in bin b + k
//      where k whole bins of the turn (offset + t = offset' + 2*pi*k/B);
//   2. position blur (not for a negligible bin: one whose largest value after the last measurement
//      is below `negligible` of the belief's largest: it moves by the shift alone, each of its
//      cells off by at most that share of the peak): a Gaussian along the motion of std sqrt(distance_std^2 +
//      (distance_per_metre |(f, l)|)^2) (on the axes by its shares), plus position_floor per axis, as three
//      extended-box passes per axis (Gwosdek et al. 2011: the exact variance). Shift and blur act on the plane (the
//      belief is zero beyond the grid) and the result is cut to the grid: mass that leaves the grid is dropped. Per
//      axis one linear operator, y first: short kernels (<= 13 taps: box radius <= 1 cell) composed with the shift and
//      applied as one explicit pass; wider ones as the shift's two taps then running float sums (O(1) per cell) over a
//      tile that holds everything the passes spread beyond the grid;
//   3. heading blur: a circular Gaussian of std sqrt(heading_std^2 + (heading_per_radian t)^2 +
//      heading_floor^2) radians
//      over the bins (taps within 3 std, those below 1e-4 of the peak left out);
//   4. a uniform floor: p = (1 - uniform_floor) p / total + uniform_floor / cells, where total is
//      the belief's mass before the prediction (mass that left the grid is gone, not given back
//      to the cells that stay; a kidnapped robot is found again; an empty grid becomes uniform).
//   The prediction is pending until the next update, which runs it fused with the measurement,
//   slice by slice while the slices are in cache (or until the belief is read).
// Map-frame motion (dx, dy): one shift, blur std sqrt(distance_std^2 + (|d| heading_std)^2 +
// position_floor^2). Unknown motion: blur std unknown_spread, heading forgotten.
//
// Update (a frame's table T, n_refs x n_shifts mean absolute differences, lower = better):
//   m_i = min_k T[i, k], s_min = min_i m_i, spread = median_i m_i - s_min,
//   lambda = t likelihood_gain / spread (0 when spread is 0: a frame of ties carries no position),
//   t = min(1, (k + 1) / settle_frames) for the k-th frame since reset() (k from 0), else 1;
//   an outlier-robust likelihood: scores above s_min + c spread count as that (when score_cap > 0),
//   so one frame weighs against a place by at most exp(-t likelihood_gain c), where c = score_cap,
//   tempered by the map's look-alikes: c = score_cap ln(lookalike_places) / ln(P) for a map of P
//   places with references when P > lookalike_places (a frame's best of many places is more often a
//   look-alike: its evidence against the place the odometry carries must weigh less);
//   pose mode: the score of reference i in bin b is T linearly interpolated at the fractional
//   shift k = (theta_b - heading_i) * columns / (2 pi) (circular); position mode: m_i;
//   a forward camera: the score of reference i in bin b is T linearly interpolated at the column
//   offset dx = wrap(theta_b - heading_i) columns / field_of_view, for the references with
//   |dx| <= window.columns only (those within the camera's view of theta_b); a place none of
//   whose references is in view takes the frame's median score (no evidence either way);
//   per place (references at one position) the lowest; per bin the place scores are interpolated
//   onto the cells with the map's weights (cells without weights take the bin's highest place
//   score: never preferred); likelihood = exp(-lambda (score - s_min)), at least that cap (and
//   2^-60); belief *= likelihood, normalized (when nothing is left, the likelihood alone).
//
// Estimate: the marginal over heading M; its first maximum, refined to the M-weighted mean of
// the (2 window + 1)^2 cells around it; covariance of M about its mean (m^2); credible_radius:
// the distance from the estimate to the nearest cell centre at which the mass of the cells
// (counted by their centres) no farther than it reaches `credibility`; confidence: the mass
// within confidence_radius metres. Heading (pose mode): over the window's cells, the heading
// histogram's first maximum bin, refined to the circular mean of the bins within 2 of it; NaN in
// position mode. Heading variance (pose mode): of the whole belief's heading histogram (each bin's
// mass at its centre) about its circular mean, sum m_b wrap(theta_b - mean)^2 / sum m_b (rad^2, at
// most pi^2; NaN in position mode). A flat marginal has no peak: the estimate is then the mean
// position.
//
// Every SIMD path gives the same values: element-wise IEEE operations in a fixed order, no FMA,
// sums in double with a fixed number of lanes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "nightloc/heatmap.hpp"
#include "nightloc/sad.hpp"
#include "nightloc/settings.hpp"

namespace nightloc {
namespace detail {
struct UpdateArgs;

/// Allocates on 64-byte boundaries (a cache line, an AVX-512 register): the filter's vector
/// loops read whole lines instead of pairs of them.
template <class T>
struct LineAllocator {
    using value_type = T;
    LineAllocator() noexcept = default;
    template <class U>
    LineAllocator(const LineAllocator<U>&) noexcept {}
    T* allocate(std::size_t n) {
        if (n > static_cast<std::size_t>(-1) / sizeof(T) - 64) throw std::bad_alloc();
        return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t{64}));
    }
    void deallocate(T* p, std::size_t) noexcept { ::operator delete(p, std::align_val_t{64}); }
    template <class U>
    bool operator==(const LineAllocator<U>&) const noexcept {
        return true;
    }
    template <class U>
    bool operator!=(const LineAllocator<U>&) const noexcept {
        return false;
    }
};
template <class T>
using LineVector = std::vector<T, LineAllocator<T>>;
}  // namespace detail

/// The filter's tunables (python: nightloc.localization.FilterParams, where they are documented,
/// takes its defaults from here). Every field has its row in setting_fields<GridFilterSettings>()
/// (name, unit, range, doc; cpp/src/localization/grid_filter_settings.cpp); validate() checks the
/// ranges.
struct GridFilterSettings {
    std::size_t heading_bins = 0;     ///< B; 0 = one per image column (map.columns); 1 = position only
    double likelihood_gain = 3.0;     ///< kappa: lambda = kappa / (median - min of the frame's scores)
    double distance_std = 0.0;        ///< odometry noise per step, metres
    double heading_std = 0.0;         ///< odometry noise per step, radians
    double distance_per_metre = 0.0;  ///< robot-frame odometry: distance noise per metre of the step (in quadrature)
    double heading_per_radian = 0.0;  ///< robot-frame odometry: heading noise per radian turned (in quadrature)
    double position_floor = 0.05;     ///< metres of blur per step added in quadrature (model error)
    double heading_floor = 0.06;      ///< radians of heading blur per step added in quadrature
    double uniform_floor = 1.5e-2;    ///< share of the belief spread uniformly per prediction
    double unknown_spread = 2.0;      ///< metres of blur when the motion is unknown
    double credibility = 0.9;         ///< mass of the credible disk
    double confidence_radius = 1.0;   ///< metres: confidence = mass within this of the estimate
    std::size_t estimate_window = 2;  ///< cells around the peak averaged into the estimate
    double negligible = 1e-3;         ///< a bin whose largest value is below this share of the belief's
                                      ///< largest moves without the position blur (0: every bin is blurred)
    std::size_t settle_frames = 12;   ///< frame k after reset() (k from 0) weighs (k + 1) / settle_frames
                                      ///< of the likelihood gain until it reaches it (0 or 1: no tempering)
    double score_cap = 1.45;          ///< scores above s_min + score_cap spread count as that (0: no cap)
    double lookalike_places = 64;     ///< a map of P places with references, more than this, caps at
                                      ///< score_cap ln(lookalike_places) / ln(P) (0: never tempered)
};

/// What the filter knows of the map (python: built from the HeatMapper of the localizer).
struct GridFilterMap {
    std::shared_ptr<const HeatWeights> weights;  ///< cells x places interpolation weights
    double x0 = 0, y0 = 0;                       ///< centre of cell (0, 0), metres
    double dx = 1, dy = 1;                       ///< cell spacing, metres
    std::vector<std::int32_t> place_of_ref;      ///< n_refs: the place of each reference
    std::vector<double> ref_headings;            ///< n_refs radians, or empty (no headings)
    std::size_t columns = 48;                    ///< image columns (a panorama: columns per 360 degrees)
    std::vector<std::int32_t> shifts;            ///< the table's column shifts (n_shifts)
    /// The search's translation window: a forward camera (shifts {0}) compares at column offsets
    /// dx = -window.columns .. window.columns (the table's columns, in that order); rows: row
    /// offsets (a tilting robot), for either camera. update_image searches with it.
    ShiftWindow window{};
    /// A forward camera's horizontal field of view, radians (0: a panorama). With window.columns
    /// > 0 and reference headings, the filter keeps heading bins: heading theta sees reference i
    /// at column offset dx = wrap(theta - heading_i) columns / field_of_view.
    double field_of_view = 0;
    /// n_refs: 1 for a reference learned on a night (an experience map's appearance), 0 for the
    /// day map's; or empty (a day map). A learned reference is evidence about its day reference,
    /// the day reference of its place nearest in heading (none: a place learned in a gap). When
    /// both kinds are present, per frame and before the per-place minimum: (1) the learned
    /// scores are multiplied by median(day minimum scores) / median(learned minimum scores) of
    /// the frame (night frames score lower against any night image than against a day image);
    /// (2) each day reference with learned ones is moved by how far their best minimum lies from
    /// the median of that over the day references with learned ones (a place whose night look
    /// matches better than the typical place's scores lower, one that matches worse higher); (3)
    /// a learned reference then scores as its day reference, at that reference's heading (the day
    /// images keep the geometry between places and the headings; a night look taken at one pose
    /// with a heading the learning night estimated cannot pull the estimate); a learned reference
    /// in a gap keeps (1). Recall: per frame at most as many learned references with a day
    /// reference as the map has day references are matched and bring evidence: half of them those
    /// whose place lies nearest the peak of the last frame's belief (the grid's centre after
    /// reset(); ties: the first), the other half in turn (in index order, a window moving on
    /// every frame, so a lost robot meets every look within a few frames); the others score as
    /// their day references too, and update_image does not match them (the time per frame stays
    /// within about twice the day map's however many looks the map holds).
    std::vector<std::uint8_t> learned;
};

/// One estimate of the filter.
struct GridEstimate {
    double x = 0, y = 0;                        ///< metres
    double heading = 0;                         ///< radians in (-pi, pi]; NaN in position mode
    double heading_var = 0;                     ///< rad^2, the belief's about its circular mean; NaN in position mode
    double cov_xx = 0, cov_xy = 0, cov_yy = 0;  ///< covariance of the marginal, m^2
    double credible_radius = 0;                 ///< metres
    double confidence = 0;                      ///< mass within confidence_radius of (x, y), 0..1
    std::size_t cell = 0;                       ///< the marginal's first maximum (row-major)
    bool flat = false;                          ///< the marginal had no peak (x, y is its mean)
};

class GridFilter {
public:
    /// Throws std::invalid_argument for inconsistent map data or settings out of range
    /// (validate()). heading_bins 0 becomes map.columns (settings() holds the value used).
    GridFilter(GridFilterMap map, GridFilterSettings settings);

    /// Uniform belief (pose mode where possible), heading offset 0.
    void reset();

    /// Replaces the odometry noise (metres, radians per step; per metre of a robot-frame step and
    /// per radian of its turn; finite, >= 0).
    void set_noise(double distance_std, double heading_std, double distance_per_metre = 0.0,
                   double heading_per_radian = 0.0);
    /// Replaces GridFilterMap::learned (empty, or n_refs values 0 or 1).
    void set_learned(std::vector<std::uint8_t> learned);

    /// Motion in the robot's frame at the previous frame: metres ahead, metres left, radians
    /// turned counter-clockwise. Position mode cannot use it without headings: throws
    /// std::logic_error when the filter has no pose mode.
    void predict_robot(double forward, double left, double turn);
    /// Motion in the map frame, metres (position mode).
    void predict_map(double dx, double dy);
    /// Unknown motion: blur by unknown_spread (position mode).
    void predict_unknown();

    /// Measurement from a table (n_refs x n_shifts float32, row-major). Throws
    /// std::invalid_argument, the belief unchanged, when a score is NaN or infinite.
    void update(const float* table);
    /// Measurement from a prepared image: its rotational SAD table against `refs` (n_refs
    /// images of the query's size, height x columns pixels) on up to `threads` threads, then
    /// update(table).
    void update_image(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                      int threads = 1);

    GridEstimate estimate() const;

    bool can_pose() const noexcept { return can_pose_; }
    bool pose_mode() const noexcept { return pose_; }
    std::size_t heading_bins() const noexcept { return bins_; }
    std::size_t active_bins() const noexcept { return pose_ ? bins_ : 1; }
    double offset() const noexcept { return offset_; }
    std::size_t height() const noexcept { return height_; }
    std::size_t width() const noexcept { return width_; }
    std::size_t n_refs() const noexcept { return map_.place_of_ref.size(); }
    /// The table's columns: the shifts, or a forward camera's column offsets (2 window.columns + 1).
    std::size_t n_shifts() const noexcept { return candidates_.size(); }
    /// Whether the filter is a forward camera's (heading bins from its column offsets).
    bool forward() const noexcept { return map_.window.columns > 0; }
    const GridFilterSettings& settings() const noexcept { return settings_; }

    /// The belief, active_bins() x height x width, multiplied by scale() (sums to 1).
    const float* belief() const;
    double scale() const;
    /// The marginal over heading (height x width), times scale() (sums to 1).
    const float* marginal() const;
    /// The last table's per-reference minimum scores (the learned ones on the day scale, see
    /// GridFilterMap::learned) and the shifts attaining them (first).
    const std::vector<float>& min_scores() const noexcept { return mins_; }
    const std::vector<std::int32_t>& best_shifts() const noexcept { return best_shifts_; }
    /// The likelihood sharpness lambda of the last update (1 / score units).
    double lambda() const noexcept { return lambda_; }
    /// The score cap in use: score_cap tempered by the map's look-alikes (see the model above).
    double score_cap() const noexcept { return cap_; }
    /// Frames measured since reset() (the tempering's count).
    std::size_t frames() const noexcept { return frames_; }
    /// The table of the last update_image (n_refs x n_shifts).
    const std::vector<float>& table() const noexcept { return table_; }

    /// Blocks of kBlock cells whose cells use more places than a dense block holds (their
    /// likelihoods are interpolated once per pass of bins).
    std::size_t sparse_blocks() const noexcept;
    /// Bytes this filter holds (its buffers' capacities; the map's shared weights not counted):
    /// about 4 (2 B C + (2 slots + 6) C + 2 N S + 8 N + B (P + 1)) for B bins, C cells, N
    /// references, S shifts, P places, `slots` the most weights of a cell (3 for a triangulation).
    std::size_t memory_bytes() const noexcept;

    /// Restores a belief (active bins x height x width, finite, >= 0, positive sum) with its
    /// mode and heading offset, e.g. one saved from belief().
    void set_belief(const float* belief, bool pose, double offset);

private:
    // Construction, in order: the references' places, the shift list (whether it is every
    // column), the heading bins and the table's candidates, the weights as ELL slots and dense
    // blocks, the per-place rows in the order the cells use them, each place's cell, the buffers.
    void index_places();
    bool check_shifts() const;
    void choose_heading_bins(bool full_shifts);
    void copy_weights_to_ell(const HeatWeights::Csr& csr);
    void build_dense_blocks();
    void order_place_rows();
    void find_place_cells(const HeatWeights::Csr& csr);
    void allocate_buffers();

    /// The likelihood's scale for one frame: the median and lowest of the per-reference minimum
    /// scores, the gain -lambda log2(e) (log2 units per score unit) and the lowest log2-likelihood.
    struct LikelihoodScale {
        double median = 0, s_min = 0, gain = 0, lowest = 0;
    };
    // The measurement, in order: the table checked and kept (its minima, the learned references
    // scaled: returns the table to read), the scale (lambda_, frames_), the log2-likelihoods per
    // place row and bin (log_lik_), the prior times the likelihood over all bins.
    const float* take_scores(const float* table);
    LikelihoodScale likelihood_scale();
    void log_lik_by_columns(const float* table, const LikelihoodScale& scale);
    void log_lik_by_places(const float* table, const LikelihoodScale& scale);
    void place_scores_forward(const float* table, double median);
    void place_scores_panoramic(const float* table);
    void set_place_row(std::size_t place_row, float value);
    void set_fill_rows(const float* fill);
    void measure_all_bins();

    /// Cell centres, metres.
    double cell_x(std::size_t i) const noexcept { return map_.x0 + map_.dx * static_cast<double>(i); }
    double cell_y(std::size_t j) const noexcept { return map_.y0 + map_.dy * static_cast<double>(j); }
    /// The marginal's mass, raw moments about the grid's centre (ox, oy) in metres, and its range.
    struct MarginalMoments {
        double total = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
        double ox = 0, oy = 0;
        float hi = 0, lo = 0;
    };
    /// Rows [j0, j1) and columns [i0, i1) of the grid.
    struct CellWindow {
        std::size_t j0 = 0, j1 = 0, i0 = 0, i1 = 0;
    };
    MarginalMoments marginal_moments() const;
    /// e.confidence and e.credible_radius about (e.x, e.y); `total` the marginal's mass.
    void credible_region(GridEstimate& e, double total) const;
    /// The heading of the belief in `around` (radians in (-pi, pi]; pose mode).
    double peak_heading(const CellWindow& around) const;
    /// The heading variance of estimate() (pose mode, the belief materialized).
    double heading_variance() const;
    /// One slice's pending motion: its source bin and the shift and blur, in cells.
    struct SliceMotion {
        std::size_t source;
        double shift_x, shift_y, sigma_x, sigma_y;
    };
    void to_position();
    void choose_recall();
    void update_recalled(const float* table);
    void scale_learned();
    void to_pose();
    // A prediction is pending until the next update (fused with it) or materialize(): per bin of
    // the result its SliceMotion, then the heading blur, the normalization and the floor.
    void begin_prediction(std::vector<float> taps, std::vector<std::size_t> offsets);
    void materialize() const;
    void measure_predicted(detail::UpdateArgs& args);
    // The measurement of bins [d0, d1) over all cells; their priors' slices from slices_[first_slice].
    void measure_group(detail::UpdateArgs& args, std::size_t d0, std::size_t d1, std::size_t first_slice);
    void translate_blur_slice(const float* src, float* dst, const SliceMotion& m) const;
    // translate_blur_slice's common case: its composed taps as two explicit passes.
    void shift_blur_rows(const float* src, float* dst, std::ptrdiff_t off_x, std::ptrdiff_t off_y) const;
    void compute_marginal() const;
    double shift_of_bin0(std::size_t ref, double columns) const;

    GridFilterMap map_;
    GridFilterSettings settings_;
    std::size_t height_, width_, cells_, bins_, places_;
    bool can_pose_, pose_ = false;
    double offset_ = 0;
    mutable double scale_ = 1;
    mutable bool pending_ = false;
    std::vector<SliceMotion> pending_motion_;
    std::vector<float> pending_taps_;
    std::vector<std::size_t> pending_offsets_;
    float pending_a_ = 1, pending_f_ = 0;
    double lambda_ = 0;
    double cap_ = 0;               // score_cap tempered by the map's look-alikes
    std::size_t frames_ = 0;       // frames measured since reset()
    std::size_t slots_ = 0;        // most weights of a cell (>= 1)
    std::vector<float> ell_data_;  // the weights, slot k of cell c at k * cells + c; a cell
                                   // without weights: weight 1 at place index places_ (the fill)
    std::vector<std::int32_t> ell_index_;
    std::vector<std::int32_t> block_start_, block_places_;  // the measurement's dense blocks
    detail::LineVector<float> block_weights_;
    bool has_sparse_blocks_ = false;      // blocks with more than kDensePlaces places
    detail::LineVector<float> sparse_y_;  // their cells' log2-likelihoods, a few bins x cells
    mutable detail::LineVector<float> belief_;
    mutable detail::LineVector<float> work_;  // predicted slices (materialize: all bins; an update: a pool)
    std::vector<std::int32_t> slot_of_, free_slots_;
    std::vector<const float*> slices_;  // the measurement's prior slices
    std::vector<std::size_t> last_use_, dest_of_source_;
    mutable detail::LineVector<float> marginal_;
    mutable bool marginal_valid_ = true;
    mutable detail::LineVector<float> row_buf_, zeros_, padded_, wide_a_, wide_b_;
    mutable std::vector<float> taps_x_, taps_y_;
    mutable std::vector<float> sums_;        // running sums of the box passes
    std::vector<std::uint32_t> sums_table_;  // update_image's sums (kept between frames)
    std::vector<float> table_, mins_, sorted_, bin_high_, place_scores_, log_lik_;
    std::vector<std::int32_t> candidates_;      // the table's column candidates: shifts or offsets dx
    std::vector<std::int32_t> row_of_ref_;      // each reference's row of the per-place arrays (see the constructor)
    std::vector<std::int32_t> ref_c0_;          // per reference: the whole column shift of bin 0 in this frame
    std::vector<double> ref_fraction_;          // and its fraction (bin b: columns c0 + b, c0 + b + 1)
    std::vector<float> row_y_;                  // a row of log2-likelihoods (scratch)
    std::vector<std::uint8_t> first_of_place_;  // per reference: the first of its place
    bool two_kinds_ = false;                    // learned and day references both present
    std::vector<std::int32_t> proxy_;           // per learned reference its day reference, else -1
    std::vector<double> headings_;              // per reference the heading the table is read at
    std::vector<float> evidence_;               // per day reference its learned ones' best score (scratch)
    std::size_t day_refs_ = 0;                  // references of the day map (the recall's budget)
    std::vector<std::size_t> place_cell_;       // per place the cell of its largest weight
    std::size_t recall_cell_ = 0;               // the last frame's belief peak (the recall's centre)
    std::vector<std::uint8_t> recalled_;        // per reference: scored this frame (learned: recalled)
    std::vector<std::size_t> recall_order_;     // learned references with a day reference (scratch)
    std::vector<std::size_t> matched_;          // references update_image matches (scratch)
    std::vector<std::uint8_t> gathered_;        // their images, one after the other (scratch)
    std::vector<std::int32_t> empty_places_;    // places no reference stands at (take the bin's highest score)
    std::vector<float> bin_max_;                // each bin's largest value after the last measurement (pose mode)
    mutable bool bin_max_valid_ = false;        // false once the belief changed otherwise (see negligible)
    std::vector<std::int32_t> best_shifts_;
    mutable std::vector<double> xs_, dx2_, hist_, bin_mass_;  // the estimate's scratch
    struct RingCell {
        double d2, mass;  // squared distance (m^2) from the estimate, marginal mass
    };
    mutable std::vector<RingCell> ring_;
};

/// The settings' table (nightloc/settings.hpp), in declaration order: the names map files store
/// (nightloc/map_file.hpp), the Python class nightloc._core.GridFilterSettings binds and
/// nightloc.FilterParams reads its defaults from.
template <>
const std::vector<SettingField<GridFilterSettings>>& setting_fields<GridFilterSettings>();

/// Throws SettingError naming the first setting out of its range (the table's ranges).
void validate(const GridFilterSettings& settings);

}  // namespace nightloc
