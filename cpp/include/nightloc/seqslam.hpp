// Route mode (1D SeqSLAM): local contrast enhancement of a difference matrix and the search for
// straight-line trajectories over it, pointer-level API.
//
// Orientation: every matrix is (n_queries, n_refs) row-major float32, row q = query q, column
// r = reference r (nightloc's convention; OpenSeqSLAM stores the transpose). Lower = more similar.
//
// The arithmetic reproduces OpenSeqSLAM (doContrastEnhancement.m, doFindMatches.m) run under
// GNU Octave bit for bit: float32 sequential sums, float32 mean / deviations / sum of squares /
// division / sqrt, +inf beyond the ends of the reference axis, NaN ignored by minima, first
// minimum wins ties, the final ratio divided in double. Nothing here depends on the CPU's SIMD
// path: the kernels are plain loops (auto-vectorized lane-wise, which keeps each element's order
// of operations), and the library is built with -ffp-contract=off.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "nightloc/route_filter.hpp"
#include "nightloc/settings.hpp"

namespace nightloc {

/// What enhance_contrast adds after the z-scores.
enum class EnhanceOffset {
    kNone,           ///< raw z-scores (may be negative)
    kGlobalMinimum,  ///< subtract the minimum of the whole matrix (NaN ignored): OpenSeqSLAM
    kZscoreBound,    ///< add the bound (n-1)/sqrt(n) of |z| for n = 2*radius+1: causal, >= 0
};

/// The largest |z| a sample of n = 2*radius+1 values can reach with the N-1 standard deviation,
/// (n-1)/sqrt(n), as float32: adding it makes every enhanced value >= 0 without looking at the
/// rest of the matrix (usable frame by frame).
float zscore_bound(std::size_t radius) noexcept;

/// Local contrast enhancement (OpenSeqSLAM's, with R = 2*radius): for every query row q and
/// reference r, out[q, r] = (d[q, r] - mean) / std over references r-radius .. r+radius of the
/// same row (clipped at the ends), std with N-1, all in float32 in Octave's order; then the
/// offset. `out` may equal `d` (in place). Needs radius >= 1 and n_refs >= 2. Uses up to
/// `threads` threads. Returns the value added to every element (-minimum, the bound, or 0).
/// Throws std::invalid_argument on invalid sizes.
float enhance_contrast(const float* d, float* out, std::size_t n_queries, std::size_t n_refs, std::size_t radius,
                       EnhanceOffset offset, int threads = 1);

/// Where a trajectory lies relative to the query it scores.
enum class TrajectoryMode {
    /// OpenSeqSLAM: ds (rounded up to even) + 1 frames centred on the query, q-ds/2 .. q+ds/2;
    /// trajectories start at reference s (0 .. n_refs, the last one the +inf padding row); the
    /// row at frame k (0-based from the start) is s + floor(k*v); the match is s + ds/2.
    /// Defined for queries ds/2 .. n_queries-1-ds/2.
    kCentred,
    /// Online: ds frames ending at the query, q-ds+1 .. q; trajectories end at reference e
    /// (0 .. n_refs-1), the row j frames before the query is e - floor(j*v), rows before 0 cost
    /// +inf; the match is e. Defined for queries ds-1 .. n_queries-1.
    kCausal,
};

/// Most row offsets (speeds x frames) a trajectory plan may hold: 4 M (32 MB). OpenSeqSLAM's
/// defaults need 55; the bound turns a typo such as vmax = 1000 with a long ds into an error
/// instead of gigabytes of allocation.
inline constexpr double kMaxTrajectoryPlanEntries = 4194304.0;

/// The name of TrajectoryMode value `index` ("centred", "causal"), nullptr past the last.
const char* trajectory_mode_name(std::size_t index) noexcept;

/// Parameters of the trajectory search (OpenSeqSLAM's names in brackets; python: nightloc.RouteParams
/// takes ds, uniqueness_radius and mode from here). The speed window is the route filter's (one
/// default for both searches). Every field has its row in setting_fields<TrajectoryParams>().
struct TrajectoryParams {
    int ds = 10;                             ///< sequence length [ds]; centred mode rounds it up to even
    double vmin = RouteFilterParams{}.vmin;  ///< slowest speed, references per query frame [vmin]
    double vmax = RouteFilterParams{}.vmax;  ///< fastest speed [vmax]
    int uniqueness_radius = 5;               ///< second best excludes argmin +- this, inclusive [Rwindow/2]
    TrajectoryMode mode = TrajectoryMode::kCentred;
};

/// The parameters' table (nightloc/settings.hpp), in declaration order.
template <>
const std::vector<SettingField<TrajectoryParams>>& setting_fields<TrajectoryParams>();

/// Throws SettingError naming the first parameter out of range (the table's ranges, then vmin <=
/// vmax).
void validate(const TrajectoryParams& params);

/// The speeds searched and their row offsets, from TrajectoryParams.
struct TrajectoryPlan {
    int ds = 0;                  ///< effective sequence length (even in centred mode)
    std::size_t frames = 0;      ///< frames per trajectory: ds+1 centred, ds causal
    std::vector<double> speeds;  ///< move/ds for move = vmin*ds, vmin*ds+1, ... <= vmax*ds
    /// offsets[v * frames + k]: row of frame k (time order) relative to the anchor row.
    std::vector<std::int64_t> offsets;
    /// Column of frame k relative to the query: k - ds/2 (centred) or k - (ds-1) (causal).
    std::vector<std::int64_t> columns;
    /// First and one-past-last query with a defined match, for n_queries queries.
    std::size_t first_query(std::size_t n_queries) const noexcept;
    std::size_t last_query(std::size_t n_queries) const noexcept;
    TrajectoryMode mode = TrajectoryMode::kCentred;
    int uniqueness_radius = 5;
};

/// Builds the plan; throws std::invalid_argument for ds < 2, speeds not finite or outside
/// (0, 1000], vmin > vmax, or a negative uniqueness radius. Speeds are Octave's range
/// vmin*ds : 1 : vmax*ds (with its tolerance of 3 eps), then move/ds, offsets floor(k*v) in double.
TrajectoryPlan make_trajectory_plan(const TrajectoryParams& params);

/// Trajectory search over an enhanced matrix dd (n_queries x n_refs). For every query q:
/// ref[q] = matched reference (0-based; -1 where undefined: too close to the ends of the query
/// sequence), score[q] = best trajectory sum / best sum among anchors outside argmin +-
/// uniqueness_radius (lower = more distinctive; NaN where undefined). Queries outside
/// [query_begin, query_end) are left untouched (use 0, n_queries for all). Throws
/// std::invalid_argument when n_refs is too small for the uniqueness window (the number of
/// anchors must exceed 2*uniqueness_radius+1).
void trajectory_search(const float* dd, std::size_t n_queries, std::size_t n_refs, const TrajectoryPlan& plan,
                       std::int64_t* ref, double* score, std::size_t query_begin, std::size_t query_end,
                       int threads = 1);

}  // namespace nightloc
