// Route mode (1D SeqSLAM): contrast enhancement and trajectory search. See seqslam.hpp for the
// semantics; the comments here explain how the loops keep OpenSeqSLAM's arithmetic exact.
//
// Exactness rests on one rule: every output element sees the same float32 operations in the
// same order as Octave's per-element computation. The inner loops run across neighbouring
// elements (references), each lane doing its own sequential sum, so the compiler may vectorize
// them without changing any result (IEEE add, sub, mul, div and sqrt are exact-rounded per lane;
// no FMA contraction, no reassociation: -ffp-contract=off, no -ffast-math).
#include "nightloc/seqslam.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/parallel.hpp"

namespace nightloc {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Octave's min, one element at a time: NaN is ignored unless everything is NaN.
inline float nan_ignoring_min(float current, float candidate) noexcept {
    return (std::isnan(current) || candidate < current) ? candidate : current;
}

// One query row of the enhancement: z-scores of `row` (n values) over windows of +-radius,
// written to `z`. `sum` and `squares` are scratch rows of n floats.
void zscores_row(const float* row, float* z, float* sum, float* squares, std::size_t n, std::size_t radius) {
    // Full windows (count = 2*radius+1) for i in [radius, n-radius); clipped windows elsewhere.
    const std::size_t full_begin = std::min(radius, n);
    const std::size_t full_end = n > radius ? std::max(full_begin, n - radius) : full_begin;
    const std::size_t width = 2 * radius + 1;

    // Edges: clipped windows, element by element (Octave: sum down rows lo..hi in order).
    auto edge = [&](std::size_t i) {
        const std::size_t lo = i >= radius ? i - radius : 0;
        const std::size_t hi = std::min(n - 1, i + radius);
        const float count = static_cast<float>(hi - lo + 1);
        float total = 0.0f;
        for (std::size_t j = lo; j <= hi; ++j) total += row[j];
        const float mean = total / count;
        float ss = 0.0f;
        for (std::size_t j = lo; j <= hi; ++j) {
            const float dev = row[j] - mean;
            ss += dev * dev;
        }
        const float sd = std::sqrt(ss / (count - 1.0f));
        z[i] = (row[i] - mean) / sd;
    };
    for (std::size_t i = 0; i < full_begin; ++i) edge(i);
    for (std::size_t i = full_end; i < n; ++i) edge(i);
    if (full_end <= full_begin) return;

    // Interior, lane-wise over i: sum[i] = ((0 + row[i-r]) + row[i-r+1]) + ... + row[i+r].
    const std::size_t m = full_end - full_begin;
    float* __restrict s = sum + full_begin;
    float* __restrict q = squares + full_begin;
    const float* base = row + full_begin - radius;  // base[i' + j] = row[i - r + j]
    const float count = static_cast<float>(width);
    for (std::size_t i = 0; i < m; ++i) s[i] = 0.0f;
    for (std::size_t j = 0; j < width; ++j) {
        const float* __restrict src = base + j;
        for (std::size_t i = 0; i < m; ++i) s[i] += src[i];
    }
    for (std::size_t i = 0; i < m; ++i) s[i] = s[i] / count;  // now the mean
    for (std::size_t i = 0; i < m; ++i) q[i] = 0.0f;
    for (std::size_t j = 0; j < width; ++j) {
        const float* __restrict src = base + j;
        for (std::size_t i = 0; i < m; ++i) {
            const float dev = src[i] - s[i];
            q[i] += dev * dev;
        }
    }
    const float dof = count - 1.0f;
    const float* __restrict x = row + full_begin;
    float* __restrict out = z + full_begin;
    for (std::size_t i = 0; i < m; ++i) out[i] = (x[i] - s[i]) / std::sqrt(q[i] / dof);
}

constexpr std::size_t kRowsPerTask = 8;

std::size_t task_count(std::size_t rows) { return (rows + kRowsPerTask - 1) / kRowsPerTask; }

// Octave's colon range base : 1 : limit, within its tolerance of 3 eps: the element count
// floor(limit - base + 1) taken with a relative tolerance, the elements base + i, the last one
// clipped to limit if it would overshoot.
std::vector<double> octave_unit_range(double base, double limit) {
    std::vector<double> values;
    if (base > limit) return values;
    const double span = limit - base + 1.0;
    const double tolerance = 3.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::fabs(span));
    const auto count = static_cast<std::size_t>(std::floor(span + tolerance));
    for (std::size_t i = 0; i < count; ++i) values.push_back(base + static_cast<double>(i));
    if (!values.empty() && values.back() > limit) values.back() = limit;
    return values;
}

}  // namespace

float zscore_bound(std::size_t radius) noexcept {
    const double n = static_cast<double>(2 * radius + 1);
    return static_cast<float>((n - 1.0) / std::sqrt(n));
}

float enhance_contrast(const float* d, float* out, std::size_t n_queries, std::size_t n_refs, std::size_t radius,
                       EnhanceOffset offset, int threads) {
    if (radius < 1) throw std::invalid_argument("enhance_contrast: radius must be >= 1");
    if (n_refs < 2) throw std::invalid_argument("enhance_contrast: needs at least 2 references");
    if (n_queries == 0) return 0.0f;
    const std::size_t tasks = task_count(n_queries);
    std::vector<float> task_minimum(tasks, kNaN);
    detail::parallel_for(tasks, threads, [&](std::size_t task) {
        std::vector<float> scratch(3 * n_refs);
        float* z = scratch.data();
        float* sum = z + n_refs;
        float* squares = sum + n_refs;
        const std::size_t q_end = std::min(n_queries, (task + 1) * kRowsPerTask);
        float minimum = kNaN;
        for (std::size_t q = task * kRowsPerTask; q < q_end; ++q) {
            zscores_row(d + q * n_refs, z, sum, squares, n_refs, radius);
            for (std::size_t i = 0; i < n_refs; ++i) minimum = nan_ignoring_min(minimum, z[i]);
            std::copy(z, z + n_refs, out + q * n_refs);  // after the row is read: in place is safe
        }
        task_minimum[task] = minimum;
    });
    float added = 0.0f;
    if (offset == EnhanceOffset::kGlobalMinimum) {
        float minimum = kNaN;
        for (float m : task_minimum) minimum = nan_ignoring_min(minimum, m);
        // Octave: DD - min(min(DD)), float32 subtraction of the minimum.
        detail::parallel_for(tasks, threads, [&](std::size_t task) {
            const std::size_t begin = task * kRowsPerTask * n_refs;
            const std::size_t end = std::min(n_queries, (task + 1) * kRowsPerTask) * n_refs;
            float* __restrict p = out;
            for (std::size_t i = begin; i < end; ++i) p[i] = p[i] - minimum;
        });
        added = -minimum;
    } else if (offset == EnhanceOffset::kZscoreBound) {
        const float bound = zscore_bound(radius);
        detail::parallel_for(tasks, threads, [&](std::size_t task) {
            const std::size_t begin = task * kRowsPerTask * n_refs;
            const std::size_t end = std::min(n_queries, (task + 1) * kRowsPerTask) * n_refs;
            float* __restrict p = out;
            for (std::size_t i = begin; i < end; ++i) p[i] = p[i] + bound;
        });
        added = bound;
    }
    return added;
}

std::size_t TrajectoryPlan::first_query(std::size_t n_queries) const noexcept {
    const auto before = static_cast<std::size_t>(-columns.front());
    return std::min(before, n_queries);
}

std::size_t TrajectoryPlan::last_query(std::size_t n_queries) const noexcept {
    const auto after = static_cast<std::size_t>(columns.back());
    return n_queries > after ? n_queries - after : 0;
}

const char* trajectory_mode_name(std::size_t index) noexcept {
    static const char* const kNames[] = {"centred", "causal"};  // TrajectoryMode's values
    return index < sizeof kNames / sizeof kNames[0] ? kNames[index] : nullptr;
}

namespace {

std::vector<SettingField<TrajectoryParams>> make_fields() {
    using S = TrajectoryParams;
    using K = SettingKind;
    constexpr double kUnbounded = std::numeric_limits<double>::infinity();
    constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
    constexpr SettingRange kSpeed{0, 1000, true, false, false, kNone, ""};
    return {
        setting<&S::ds>({"ds", K::integer, "frames", "sequence length (centred mode rounds it up to even)",
                         SettingRange{2, 100000, false, false, false, kNone, ""}}),
        setting<&S::vmin>({"vmin", K::real, "references per frame", "slowest speed", kSpeed}),
        setting<&S::vmax>({"vmax", K::real, "references per frame", "fastest speed (>= vmin)", kSpeed}),
        setting<&S::uniqueness_radius>({"uniqueness_radius", K::integer, "references",
                                        "the second-best trajectory excludes anchors within this of the best",
                                        SettingRange{0, kUnbounded, false, false, false, kNone, ""}}),
        setting<&S::mode>({"mode", K::choice, "",
                           "centred (OpenSeqSLAM: needs ds/2 future frames) or causal (ends at the query)",
                           SettingRange{}, &trajectory_mode_name}),
    };
}

}  // namespace

template <>
const std::vector<SettingField<TrajectoryParams>>& setting_fields<TrajectoryParams>() {
    static const std::vector<SettingField<TrajectoryParams>> fields = make_fields();
    return fields;
}

void validate(const TrajectoryParams& params) {
    check_ranges(params);
    if (!(params.vmin <= params.vmax)) {
        throw SettingError("vmin", "(" + setting_value_text(params.vmin) + ") must not exceed vmax (" +
                                       setting_value_text(params.vmax) + ")");
    }
}

TrajectoryPlan make_trajectory_plan(const TrajectoryParams& params) {
    validate(params);
    TrajectoryPlan plan;
    plan.mode = params.mode;
    plan.uniqueness_radius = params.uniqueness_radius;
    const bool centred = params.mode == TrajectoryMode::kCentred;
    plan.ds = centred ? params.ds + params.ds % 2 : params.ds;  // OpenSeqSLAM: ds forced even
    plan.frames = centred ? static_cast<std::size_t>(plan.ds) + 1 : static_cast<std::size_t>(plan.ds);
    const double ds = static_cast<double>(plan.ds);
    const double n_speeds = std::floor(params.vmax * ds - params.vmin * ds) + 1.0;
    if (n_speeds * static_cast<double>(plan.frames) > kMaxTrajectoryPlanEntries) {
        throw std::invalid_argument("trajectory search: " + std::to_string(static_cast<long long>(n_speeds)) +
                                    " speeds x " + std::to_string(plan.frames) +
                                    " frames is too large a search; narrow vmin..vmax or shorten ds");
    }
    for (double move : octave_unit_range(params.vmin * ds, params.vmax * ds)) plan.speeds.push_back(move / ds);
    if (plan.speeds.empty()) {
        throw std::invalid_argument(
            "trajectory search: no speed in vmin*ds : vmax*ds (it needs vmax*ds - vmin*ds >= 0)");
    }
    const auto frames = static_cast<std::int64_t>(plan.frames);
    for (double v : plan.speeds) {
        for (std::int64_t k = 0; k < frames; ++k) {
            if (centred) {
                plan.offsets.push_back(static_cast<std::int64_t>(std::floor(static_cast<double>(k) * v)));
            } else {
                const std::int64_t before = frames - 1 - k;  // frames before the query
                plan.offsets.push_back(-static_cast<std::int64_t>(std::floor(static_cast<double>(before) * v)));
            }
        }
    }
    for (std::int64_t k = 0; k < frames; ++k) plan.columns.push_back(centred ? k - plan.ds / 2 : k - (frames - 1));
    return plan;
}

void trajectory_search(const float* dd, std::size_t n_queries, std::size_t n_refs, const TrajectoryPlan& plan,
                       std::int64_t* ref, double* score, std::size_t query_begin, std::size_t query_end, int threads) {
    if (plan.frames == 0 || plan.speeds.empty() || plan.columns.size() != plan.frames ||
        plan.offsets.size() != plan.frames * plan.speeds.size()) {
        throw std::invalid_argument("trajectory_search: invalid plan (build it with make_trajectory_plan)");
    }
    if (n_refs == 0) throw std::invalid_argument("trajectory_search: no references");
    const bool centred = plan.mode == TrajectoryMode::kCentred;
    const std::size_t n_anchors = centred ? n_refs + 1 : n_refs;
    const auto exclusion = static_cast<std::size_t>(plan.uniqueness_radius);
    if (n_anchors <= 2 * exclusion + 1) {
        throw std::invalid_argument("trajectory_search: " + std::to_string(n_refs) +
                                    " references are too few for a uniqueness window of +-" +
                                    std::to_string(exclusion) + " (needs at least " +
                                    std::to_string(2 * exclusion + 2 - (centred ? 1 : 0)) + ")");
    }
    query_end = std::min(query_end, n_queries);
    if (query_begin >= query_end) return;
    const std::size_t first = plan.first_query(n_queries);
    const std::size_t last = plan.last_query(n_queries);
    const std::size_t n_tasks = task_count(query_end - query_begin);
    const auto refs_signed = static_cast<std::int64_t>(n_refs);
    const auto anchors_signed = static_cast<std::int64_t>(n_anchors);

    detail::parallel_for(n_tasks, threads, [&](std::size_t task) {
        std::vector<float> buffers(2 * n_anchors);
        float* __restrict best = buffers.data();
        float* __restrict acc = best + n_anchors;
        const std::size_t q_begin = query_begin + task * kRowsPerTask;
        const std::size_t q_end = std::min(query_end, q_begin + kRowsPerTask);
        for (std::size_t q = q_begin; q < q_end; ++q) {
            if (q < first || q >= last) {
                ref[q] = -1;
                score[q] = std::numeric_limits<double>::quiet_NaN();
                continue;
            }
            for (std::size_t a = 0; a < n_anchors; ++a) best[a] = kNaN;
            for (std::size_t v = 0; v < plan.speeds.size(); ++v) {
                for (std::size_t a = 0; a < n_anchors; ++a) acc[a] = 0.0f;
                for (std::size_t k = 0; k < plan.frames; ++k) {
                    const auto column = static_cast<std::size_t>(static_cast<std::int64_t>(q) + plan.columns[k]);
                    const float* __restrict row = dd + column * n_refs;
                    const std::int64_t off = plan.offsets[v * plan.frames + k];
                    // Anchors whose row a + off lies in [0, n_refs); the others read +inf.
                    const std::int64_t lo = std::clamp<std::int64_t>(-off, 0, anchors_signed);
                    const std::int64_t hi = std::clamp<std::int64_t>(refs_signed - off, lo, anchors_signed);
                    for (std::int64_t a = 0; a < lo; ++a) acc[a] += kInf;
                    const float* __restrict src = row + (lo + off);  // src[i] = row[lo + i + off]
                    float* __restrict dst = acc + lo;
                    const std::int64_t count = hi - lo;
                    for (std::int64_t i = 0; i < count; ++i) dst[i] += src[i];
                    for (std::int64_t a = hi; a < anchors_signed; ++a) acc[a] += kInf;
                }
                for (std::size_t a = 0; a < n_anchors; ++a) {
                    const float current = best[a];
                    const float candidate = acc[a];
                    // nan_ignoring_min, written with x != x so that the loop vectorizes
                    best[a] = (current != current || candidate < current) ? candidate : current;
                }
            }
            // Best anchor (first minimum, NaN ignored; all NaN -> anchor 0 with NaN, as Octave).
            std::size_t argmin = 0;
            float minimum = kNaN;
            for (std::size_t a = 0; a < n_anchors; ++a) {
                if (std::isnan(minimum) ? !std::isnan(best[a]) : best[a] < minimum) {
                    minimum = best[a];
                    argmin = a;
                }
            }
            const std::size_t win_lo = argmin >= exclusion ? argmin - exclusion : 0;
            const std::size_t win_hi = std::min(n_anchors - 1, argmin + exclusion);
            float second = kNaN;
            for (std::size_t a = 0; a < win_lo; ++a) second = nan_ignoring_min(second, best[a]);
            for (std::size_t a = win_hi + 1; a < n_anchors; ++a) second = nan_ignoring_min(second, best[a]);
            const std::size_t matched = centred ? argmin + static_cast<std::size_t>(plan.ds / 2) : argmin;
            ref[q] = static_cast<std::int64_t>(std::min(matched, n_refs - 1));
            score[q] = static_cast<double>(minimum) / static_cast<double>(second);
        }
    });
}

}  // namespace nightloc
