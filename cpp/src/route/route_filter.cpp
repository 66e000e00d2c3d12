// Route mode's Bayes filter (see route_filter.hpp for the model): the likelihood of a frame's
// row, and the step every motion model shares (the rescaling to the on-route mass, the uniform
// floor, the off-route exchange, the update and the answer). The motion models are units of
// their own (route_motion.hpp). Plain sequential loops in double precision: the order of
// operations is fixed, so batch and streaming results agree exactly and a numpy oracle agrees
// to rounding.
#include "nightloc/route_filter.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/float_kernel_table.hpp"
#include "common/parallel.hpp"
#include "nightloc/simd.hpp"
#include "route/route_motion.hpp"

namespace nightloc {

namespace {

using route_detail::require;
using route_detail::sum_of;

#if defined(__GNUC__) || defined(__clang__)
#define NIGHTLOC_ALWAYS_INLINE __attribute__((always_inline))
#else
#define NIGHTLOC_ALWAYS_INLINE
#endif

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::size_t kMaxSpeedPlanes = 1000;
constexpr std::size_t kMaxCells = 64;
constexpr double kMaxBeliefValues = 4294967296.0;  // 2^32 doubles per buffer

// Sum of the squares of n doubles, in sum_of's order.
double sum_of_squares(const double* x, std::size_t n) noexcept {
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    std::size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        s0 += x[i] * x[i];
        s1 += x[i + 1] * x[i + 1];
        s2 += x[i + 2] * x[i + 2];
        s3 += x[i + 3] * x[i + 3];
    }
    double total = (s0 + s1) + (s2 + s3);
    for (; i < n; ++i) total += x[i] * x[i];
    return total;
}

// The largest value of n >= 1 doubles without NaN: four interleaved running maxima (exact in any
// order; the layout lets the compiler vectorize).
double max_of(const double* x, std::size_t n) noexcept {
    auto pick = [](double a, double b) { return b > a ? b : a; };
    double e0 = x[0], e1 = x[0], e2 = x[0], e3 = x[0];
    std::size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        e0 = pick(e0, x[i]);
        e1 = pick(e1, x[i + 1]);
        e2 = pick(e2, x[i + 2]);
        e3 = pick(e3, x[i + 3]);
    }
    double e = pick(pick(e0, e1), pick(e2, e3));
    for (; i < n; ++i) e = pick(e, x[i]);
    return e;
}

// exp(x) for x <= 0 in plain IEEE operations with a fixed order (the same result on every CPU;
// the loop calling it vectorizes), within a few ulp of the correctly rounded value; 0 below
// -708 (where exp underflows to subnormals). x = k ln2 + r with |r| <= ln2/2 (k by the
// 1.5 * 2^52 rounding trick, ln2 split so k * ln2_hi is exact), exp(r) by its Taylor series to
// r^13/13! (truncation below 2e-16 relative), times 2^k built in the exponent bits.
NIGHTLOC_ALWAYS_INLINE inline double exp_nonpositive(double x) noexcept {
    constexpr double kShifter = 6755399441055744.0;  // 1.5 * 2^52
    constexpr double kLog2e = 1.4426950408889634;
    constexpr double kLn2Hi = 6.93147180369123816490e-01;  // 0x3fe62e42fee00000: 32 trailing zero bits
    constexpr double kLn2Lo = 1.90821492927058770002e-10;
    const double clamped = x > -708.0 ? x : -708.0;
    const double shifted = clamped * kLog2e + kShifter;
    const double k = shifted - kShifter;
    const double r = (clamped - k * kLn2Hi) - k * kLn2Lo;
    double poly = 1.0 / 6227020800.0;  // 1/13!
    poly = poly * r + 1.0 / 479001600.0;
    poly = poly * r + 1.0 / 39916800.0;
    poly = poly * r + 1.0 / 3628800.0;
    poly = poly * r + 1.0 / 362880.0;
    poly = poly * r + 1.0 / 40320.0;
    poly = poly * r + 1.0 / 5040.0;
    poly = poly * r + 1.0 / 720.0;
    poly = poly * r + 1.0 / 120.0;
    poly = poly * r + 1.0 / 24.0;
    poly = poly * r + 1.0 / 6.0;
    poly = poly * r + 0.5;
    poly = poly * r + 1.0;
    poly = poly * r + 1.0;
    std::int64_t shifted_bits = 0;
    std::int64_t shifter_bits = 0;
    std::memcpy(&shifted_bits, &shifted, sizeof shifted);
    std::memcpy(&shifter_bits, &kShifter, sizeof kShifter);
    const std::int64_t exponent = (shifted_bits - shifter_bits + 1023) << 52;  // 2^k, k in [-1022, 0]
    double two_k = 0.0;
    std::memcpy(&two_k, &exponent, sizeof exponent);
    return x > -708.0 ? poly * two_k : 0.0;
}

}  // namespace

namespace {

std::vector<SettingField<RouteFilterParams>> make_fields() {
    using S = RouteFilterParams;
    using K = SettingKind;
    constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
    constexpr SettingRange kProbability{0, 1, false, false, false, kNone, ""};
    constexpr SettingRange kCells{1, static_cast<double>(kMaxCells), false, false, false, kNone, ""};
    constexpr const char* kSpeed = "references per frame";
    return {
        setting<&S::vmin>({"vmin", K::real, kSpeed, "slowest speed (window model; SeqSLAM's too)",
                           SettingRange{0, 1000, false, false, false, kNone, ""}}),
        setting<&S::vmax>({"vmax", K::real, kSpeed, "fastest speed (>= vmin)",
                           SettingRange{0, 1000, false, false, false, kNone, ""}}),
        setting<&S::backward>({"backward", K::real, "", "probability per frame of stepping one reference back",
                               SettingRange{0, 1, false, true, false, kNone, ""}}),
        setting<&S::floor>(
            {"floor", K::real, "", "share of the belief spread uniformly over the route per frame", kProbability}),
        setting<&S::sharpness>({"sharpness", K::real, "",
                                "lambda of the likelihood, per standard deviation of the frame's row",
                                SettingRange{0, kInf, false, false, false, kNone, ""}}),
        setting<&S::clip>({"clip", K::real, "", "z-scores above this are no evidence against a place",
                           SettingRange{-kInf, kInf, true, false, true, kNone, ""}}),
        setting<&S::leave>({"leave", K::real, "", "probability per frame of leaving the route", kProbability}),
        setting<&S::rejoin>({"rejoin", K::real, "", "probability per frame of rejoining it (uniformly)", kProbability}),
        setting<&S::window>({"window", K::count, "references",
                             "confidence = the belief's mass within +-window references of the best",
                             SettingRange{0, kInf, false, false, false, kNone, ""}}),
        setting<&S::motion>(
            {"motion", K::choice, "", "the motion model (route_motion_names())", SettingRange{}, &route_motion_choice}),
        setting<&S::speed_min>({"speed_min", K::real, kSpeed, "slowest speed plane of the speed model",
                                SettingRange{-1000, 1000, false, false, false, kNone, ""}}),
        setting<&S::speed_max>({"speed_max", K::real, kSpeed, "fastest speed plane (>= speed_min)",
                                SettingRange{-1000, 1000, false, false, false, kNone, ""}}),
        setting<&S::speed_step>({"speed_step", K::real, kSpeed, "spacing of the speed planes",
                                 SettingRange{0, kInf, true, false, false, kNone, ""}}),
        setting<&S::speed_jitter>({"speed_jitter", K::real, kSpeed, "half-width of each plane's speed window",
                                   SettingRange{0, 1000, false, false, false, kNone, ""}}),
        setting<&S::speed_change>({"speed_change", K::real, kSpeed,
                                   "standard deviation of the speed's change per frame (<= 50 speed_step)",
                                   SettingRange{0, kInf, false, false, false, kNone, ""}}),
        setting<&S::speed_tau>({"speed_tau", K::real, "frames", "frames for a speed to relax towards 1 (inf: no pull)",
                                SettingRange{0, kInf, true, false, true, kNone, ""}}),
        setting<&S::speed_cells>(
            {"speed_cells", K::count, "", "position cells per reference of the speed model", kCells}),
        setting<&S::odometry_noise>({"odometry_noise", K::real, "",
                                     "relative standard deviation of an odometry advance",
                                     SettingRange{0, 10, false, false, false, kNone, ""}}),
        setting<&S::odometry_jitter>({"odometry_jitter", K::real, "references",
                                      "extra position noise per frame of the odometry model",
                                      SettingRange{0, 100, false, false, false, kNone, ""}}),
        setting<&S::odometry_novelty>({"odometry_novelty", K::real, "references",
                                       "travel for a frame's full evidence (0: always full)",
                                       SettingRange{0, 1000, false, false, false, kNone, ""}}),
        setting<&S::odometry_cells>(
            {"odometry_cells", K::count, "", "position cells per reference of the odometry model", kCells}),
    };
}

}  // namespace

template <>
const std::vector<SettingField<RouteFilterParams>>& setting_fields<RouteFilterParams>() {
    static const std::vector<SettingField<RouteFilterParams>> fields = make_fields();
    return fields;
}

// Every field of RouteFilterParams (eight bytes each, the 4-byte motion padded) has its row.
static_assert(sizeof(std::size_t) != 8 || sizeof(RouteFilterParams) == 21 * 8,
              "a field of RouteFilterParams was added or removed: change its row in make_fields() and this count");

void validate(const RouteFilterParams& p) {
    check_ranges(p);
    if (!(p.vmax >= p.vmin)) {
        throw SettingError("vmax",
                           "must be >= vmin (" + setting_value_text(p.vmin) + "), got " + setting_value_text(p.vmax));
    }
    if (!(p.speed_max >= p.speed_min)) {
        throw SettingError("speed_max", "must be >= speed_min (" + setting_value_text(p.speed_min) + "), got " +
                                            setting_value_text(p.speed_max));
    }
    if (!((p.speed_max - p.speed_min) / p.speed_step < static_cast<double>(kMaxSpeedPlanes))) {
        throw SettingError("speed_step", "= " + setting_value_text(p.speed_step) + " gives more than " +
                                             std::to_string(kMaxSpeedPlanes) +
                                             " speed planes from speed_min to speed_max; widen it");
    }
    if (!(p.speed_jitter * static_cast<double>(p.speed_cells) <= 2000.0)) {
        throw SettingError("speed_jitter",
                           "x speed_cells must be at most 2000 cells (each plane's kernel spans twice "
                           "that), got " +
                               setting_value_text(p.speed_jitter * static_cast<double>(p.speed_cells)));
    }
    if (!(p.speed_change <= 50.0 * p.speed_step)) {
        throw SettingError("speed_change", "must be at most 50 x speed_step (" +
                                               setting_value_text(50.0 * p.speed_step) +
                                               ") references per frame, got " + setting_value_text(p.speed_change));
    }
}

RouteFilter::RouteFilter(std::size_t n_refs, const RouteFilterParams& params, const double* reference_distances)
    : params_(params), kernel_(motion_kernel(params.vmin, params.vmax, params.backward)), n_refs_(n_refs) {
    validate(params);
    require(n_refs >= 1, "the route filter needs at least one reference");
    model_ = route_detail::make_route_motion(n_refs, params, reference_distances);
    const std::size_t cells = model_->cells();
    const std::size_t planes = model_->planes();
    const double values = static_cast<double>(n_refs) * static_cast<double>(cells) * static_cast<double>(planes);
    require(values <= kMaxBeliefValues, "the " + std::string(motion_name()) + " model's belief would hold " +
                                            std::to_string(values) + " values; use fewer speed planes or cells");
    const std::size_t size = n_refs * cells * planes;
    belief_.assign(size, 0.0);
    scratch_.assign(size, 0.0);
    marginal_.assign(n_refs, 0.0);
    reset();
}

RouteFilter::RouteFilter(const RouteFilter& other)
    : params_(other.params_),
      kernel_(other.kernel_),
      n_refs_(other.n_refs_),
      model_(other.model_->clone()),
      fresh_(other.fresh_),
      belief_(other.belief_),
      scratch_(other.scratch_),
      marginal_(other.marginal_),
      plane_mass_(other.plane_mass_),
      cell_likelihood_(other.cell_likelihood_),
      likelihood_(other.likelihood_),
      off_(other.off_),
      threads_(other.threads_) {}

RouteFilter& RouteFilter::operator=(const RouteFilter& other) {
    if (this != &other) *this = RouteFilter(other);
    return *this;
}

RouteFilter::RouteFilter(RouteFilter&& other) noexcept = default;
RouteFilter& RouteFilter::operator=(RouteFilter&& other) noexcept = default;
RouteFilter::~RouteFilter() = default;

RouteMotion RouteFilter::motion() const noexcept { return model_->motion(); }

const char* RouteFilter::motion_name() const noexcept { return route_motion_name(model_->motion()); }

const SpeedChain& RouteFilter::chain() const noexcept {
    static const SpeedChain none;
    const SpeedChain* chain = model_->chain();
    return chain != nullptr ? *chain : none;
}

namespace {

// marginal[r] = sum over planes and the cells of reference r, planes in order, cells in order.
void marginalize(const double* belief, std::size_t planes, std::size_t n_refs, std::size_t cells,
                 double* marginal) noexcept {
    const std::size_t m = n_refs * cells;
    for (std::size_t r = 0; r < n_refs; ++r) {
        double total = 0.0;
        for (std::size_t s = 0; s < planes; ++s) {
            const double* cell = belief + s * m + r * cells;
            for (std::size_t k = 0; k < cells; ++k) total += cell[k];
        }
        marginal[r] = total;
    }
}

}  // namespace

void RouteFilter::reset() {
    off_ = 0.0;
    fresh_ = true;
    const std::size_t m = n_refs_ * model_->cells();
    const std::vector<double>& prior = model_->prior();
    for (std::size_t s = 0; s < prior.size(); ++s)
        std::fill(belief_.begin() + static_cast<std::ptrdiff_t>(s * m),
                  belief_.begin() + static_cast<std::ptrdiff_t>((s + 1) * m), prior[s] / static_cast<double>(m));
    marginalize(belief_.data(), prior.size(), n_refs_, model_->cells(), marginal_.data());
}

void RouteFilter::set_state(const double* belief, double off_route) {
    double total = 0.0;
    for (std::size_t r = 0; r < n_refs_; ++r) {
        require(std::isfinite(belief[r]) && belief[r] >= 0.0, "belief values must be finite and >= 0");
        total += belief[r];
    }
    require(std::isfinite(off_route) && off_route >= 0.0, "off_route must be finite and >= 0");
    total += off_route;
    require(total > 0.0, "belief and off_route must not all be 0");
    off_ = off_route / total;
    model_->spread(belief, total, belief_.data());
    marginalize(belief_.data(), model_->planes(), n_refs_, model_->cells(), marginal_.data());
}

namespace {

// out[r] = exp(-slope * (min(out[r], cap) - best_dev)), the filter's hottest loop, compiled for the
// baseline and (x86-64) for AVX2 and AVX-512: the same operations per element in the same order,
// no FMA (-ffp-contract=off), so all give identical results; AVX2 runs four lanes, AVX-512 eight,
// instead of two. The SIMD path in use (nightloc/simd.hpp: NIGHTLOC_SIMD, set_simd_backend)
// picks the variant.
NIGHTLOC_ALWAYS_INLINE inline void likelihood_loop(double* out, std::size_t n, double slope, double cap,
                                                   double best_dev) noexcept {
    for (std::size_t r = 0; r < n; ++r) out[r] = exp_nonpositive(-slope * (std::min(out[r], cap) - best_dev));
}

void likelihood_baseline(double* out, std::size_t n, double slope, double cap, double best_dev) noexcept {
    likelihood_loop(out, n, slope, cap, best_dev);
}

#if NIGHTLOC_X86_KERNELS
__attribute__((target("avx2"))) void likelihood_avx2(double* out, std::size_t n, double slope, double cap,
                                                     double best_dev) noexcept {
    likelihood_loop(out, n, slope, cap, best_dev);
}
__attribute__((target("avx512f,avx512bw"))) void likelihood_avx512(double* out, std::size_t n, double slope, double cap,
                                                                   double best_dev) noexcept {
    likelihood_loop(out, n, slope, cap, best_dev);
}
#endif

struct LikelihoodKernel {
    void (*run)(double* out, std::size_t n, double slope, double cap, double best_dev) noexcept;
};

void likelihood_from_deviations(double* out, std::size_t n, double slope, double cap, double best_dev) noexcept {
    static const LikelihoodKernel baseline{likelihood_baseline};
#if NIGHTLOC_X86_KERNELS
    static const LikelihoodKernel avx2{likelihood_avx2}, avx512{likelihood_avx512};
    static const detail::FloatKernelTables<LikelihoodKernel> tables{baseline, baseline, &avx2, &avx512};
#else
    static const detail::FloatKernelTables<LikelihoodKernel> tables{baseline, baseline, nullptr, nullptr};
#endif
    tables.of(active_simd_backend()).run(out, n, slope, cap, best_dev);
}

}  // namespace

double route_likelihood(const float* row, std::size_t n, double lambda, double clip, double* out) noexcept {
    // Row statistics over the finite values (v - v == 0 is false for NaN and inf), four
    // interleaved partial sums / minima / counts combined in a fixed order; `out` then holds the
    // deviations from the mean, with non-finite values counted as the mean (deviation 0).
    double sums[4] = {0.0, 0.0, 0.0, 0.0};
    double lows[4] = {kInf, kInf, kInf, kInf};
    std::size_t counts[4] = {0, 0, 0, 0};
    std::size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        for (std::size_t j = 0; j < 4; ++j) {
            const float v = row[i + j];
            const bool finite = v - v == 0.0f;
            const double x = finite ? static_cast<double>(v) : 0.0;
            sums[j] += x;
            lows[j] = finite && x < lows[j] ? x : lows[j];
            counts[j] += finite ? 1 : 0;
        }
    }
    double sum = (sums[0] + sums[1]) + (sums[2] + sums[3]);
    double lowest = std::min(std::min(lows[0], lows[1]), std::min(lows[2], lows[3]));
    std::size_t count = (counts[0] + counts[1]) + (counts[2] + counts[3]);
    for (; i < n; ++i) {
        const float v = row[i];
        if (v - v == 0.0f) {
            sum += static_cast<double>(v);
            lowest = std::min(lowest, static_cast<double>(v));
            ++count;
        }
    }
    const double mean = count > 0 ? sum / static_cast<double>(count) : 0.0;
    for (std::size_t r = 0; r < n; ++r) {
        const float v = row[r];
        out[r] = v - v == 0.0f ? static_cast<double>(v) - mean : 0.0;
    }
    const double squares = sum_of_squares(out, n);
    const double sd = count > 0 ? std::sqrt(squares / static_cast<double>(count)) : 0.0;
    if (!(lambda > 0.0 && sd > 0.0)) {
        std::fill(out, out + n, 1.0);
        return static_cast<double>(n);
    }
    // L = exp(-lambda * (min(z, clip) - min_r min(z_r, clip))), z = deviation / sd: 1 at the best
    // place; clip is applied in deviations (+inf: none).
    const double slope = lambda / sd;
    const double cap = clip * sd;
    const double best_dev = std::min(lowest - mean, cap);
    likelihood_from_deviations(out, n, slope, cap, best_dev);
    return sum_of(out, n);
}

RouteFilterStep RouteFilter::step(const float* row, double weight, double advance) {
    require(weight >= 0.0 && weight <= 1.0, "weight must be in [0, 1], got " + std::to_string(weight));
    require(std::isfinite(advance), "advance must be a finite distance, got " + std::to_string(advance));
    likelihood_.resize(n_refs_);
    const double lambda = params_.sharpness * frame_weight(weight, advance);
    const double sum = route_likelihood(row, n_refs_, lambda, params_.clip, likelihood_.data());
    return update(likelihood_.data(), sum, advance);
}

RouteFilterStep RouteFilter::update(const double* likelihood, double likelihood_sum, double advance) {
    const std::size_t cells = model_->cells();
    const std::size_t planes = model_->planes();
    const std::size_t m = n_refs_ * cells;
    const double md = static_cast<double>(m);
    const double on = 1.0 - off_;  // the belief sums to 1 - off_ (normalized every step)
    const int threads = plane_threads();
    // 1. Predict: the model's motion into scratch_; then the rescaling to the on-route mass, the
    // floor and the off-route exchange as one affine map per plane, p' = scale * p + offset_s,
    // applied with the update.
    const route_detail::MotionStep moved = model_->predict(belief_, scratch_, on, fresh_ ? 0.0 : advance, threads);
    fresh_ = false;
    const double stay = 1.0 - params_.leave;
    const double back = off_ * params_.rejoin / md;
    double scale = 0.0;
    double spread = stay * on / md + back;  // nothing left on the route: uniform
    if (moved.moved > 0.0) {
        scale = stay * (1.0 - params_.floor) * (on / moved.moved);
        spread = stay * (params_.floor * on / md) + back;
    }
    const double off =
        (off_ * (1.0 - params_.rejoin) + on * params_.leave) * (likelihood_sum / static_cast<double>(n_refs_));

    // 2. Update: posterior = prediction x likelihood (the same for every cell and plane of a
    // reference), plane by plane (on the threads when the planes are large), each plane's sum in
    // a fixed order.
    plane_mass_.resize(planes);
    const double* cell_likelihood = likelihood;
    if (cells > 1) {
        cell_likelihood_.resize(m);
        for (std::size_t r = 0; r < n_refs_; ++r)
            for (std::size_t k = 0; k < cells; ++k) cell_likelihood_[r * cells + k] = likelihood[r];
        cell_likelihood = cell_likelihood_.data();
    }
    const std::vector<double>& prior = model_->prior();
    detail::parallel_for(planes, threads, [&](std::size_t s) {
        const double offset = spread * prior[s];
        const double* p = scratch_.data() + s * m;
        double* b = belief_.data() + s * m;
        for (std::size_t c = 0; c < m; ++c) b[c] = (scale * p[c] + offset) * cell_likelihood[c];
        plane_mass_[s] = sum_of(b, m);
    });
    double total = off;
    for (std::size_t s = 0; s < planes; ++s) total += plane_mass_[s];
    if (!(total > 0.0) || !std::isfinite(total)) {
        reset();  // cannot happen with floor > 0; with floor = 0 every place may be ruled out
        fresh_ = false;
        return answer(marginal_.data(), std::numeric_limits<double>::quiet_NaN());
    }
    // 3. Normalize, then sum over the planes (in plane order) per cell and over each reference's
    // cells (in cell order).
    const double inverse = 1.0 / total;
    off_ = off * inverse;
    detail::parallel_for(planes, threads, [&](std::size_t s) {
        double* b = belief_.data() + s * m;
        for (std::size_t c = 0; c < m; ++c) b[c] *= inverse;
    });
    if (planes == 1 && cells == 1) return answer(belief_.data(), model_->speed(plane_mass_, moved.speed));
    double* cell_sum = cells > 1 ? cell_likelihood_.data() : marginal_.data();  // the cells' likelihood is spent
    std::copy(belief_.data(), belief_.data() + m, cell_sum);
    for (std::size_t s = 1; s < planes; ++s) {
        const double* b = belief_.data() + s * m;
        for (std::size_t c = 0; c < m; ++c) cell_sum[c] += b[c];
    }
    if (cells > 1) {
        for (std::size_t r = 0; r < n_refs_; ++r) {
            double sum = cell_sum[r * cells];
            for (std::size_t k = 1; k < cells; ++k) sum += cell_sum[r * cells + k];
            marginal_[r] = sum;
        }
    }
    return answer(marginal_.data(), model_->speed(plane_mass_, moved.speed));
}

RouteFilterStep RouteFilter::answer(const double* marginal, double speed) {
    // The first maximum, and the mass around it.
    const std::size_t n = n_refs_;
    const double top = max_of(marginal, n);
    std::size_t best = 0;
    while (best + 1 < n && marginal[best] != top) ++best;
    const std::size_t lo = best >= params_.window ? best - params_.window : 0;
    const std::size_t hi = std::min(n - 1, best + params_.window);
    RouteFilterStep out;
    out.best = static_cast<std::int64_t>(best);
    out.confidence = std::min(1.0, sum_of(marginal + lo, hi - lo + 1));
    out.off_route = off_;
    out.speed = speed;
    return out;
}

bool RouteFilter::single_cell() const noexcept { return model_->planes() == 1 && model_->cells() == 1; }

int RouteFilter::plane_threads() const noexcept {
    // A plane is worth a thread from about 64k cells on (below, waking the threads costs more).
    return n_refs_ * model_->cells() >= 65536 ? threads_ : 1;
}

double RouteFilter::novelty(double advance) const noexcept { return model_->novelty(advance); }

double RouteFilter::frame_weight(double weight, double advance) const noexcept {
    return fresh_ ? weight : weight * novelty(advance);
}

void RouteFilter::run(const float* rows, std::size_t n_rows, const double* weights, const double* advances,
                      const RouteFilterOutputs& out, int threads) {
    const std::size_t n = n_refs_;
    for (std::size_t q = 0; q < n_rows; ++q) {
        const double w = weights ? weights[q] : 1.0;
        require(w >= 0.0 && w <= 1.0, "weight " + std::to_string(q) + " must be in [0, 1], got " + std::to_string(w));
        const double a = advances ? advances[q] : 0.0;
        require(std::isfinite(a),
                "advance " + std::to_string(q) + " must be a finite distance, got " + std::to_string(a));
    }
    // Likelihoods do not depend on the belief: a block of rows at a time on the threads, then
    // the sequential updates of that block.
    const std::size_t block = threads > 1 ? std::min<std::size_t>(n_rows, 64) : 1;
    std::vector<double> likelihoods(block * n);
    std::vector<double> sums(block);
    const bool fresh_at_start = fresh_;
    const int threads_before = threads_;
    threads_ = threads;
    for (std::size_t start = 0; start < n_rows; start += block) {
        const std::size_t rows_here = std::min(block, n_rows - start);
        detail::parallel_for(rows_here, threads, [&](std::size_t i) {
            const std::size_t q = start + i;
            const double w = weights ? weights[q] : 1.0;
            // frame_weight() of the state this row meets: only the run's first row can be fresh
            const double weight = q == 0 && fresh_at_start ? w : w * novelty(advances ? advances[q] : 0.0);
            sums[i] =
                route_likelihood(rows + q * n, n, params_.sharpness * weight, params_.clip, likelihoods.data() + i * n);
        });
        for (std::size_t i = 0; i < rows_here; ++i) {
            const std::size_t q = start + i;
            const RouteFilterStep s = update(likelihoods.data() + i * n, sums[i], advances ? advances[q] : 0.0);
            out.best[q] = s.best;
            out.confidence[q] = s.confidence;
            out.off_route[q] = s.off_route;
            if (out.speed != nullptr) out.speed[q] = s.speed;
        }
    }
    threads_ = threads_before;
}

void RouteFilter::run(const float* rows, std::size_t n_rows, const double* weights, std::int64_t* best,
                      double* confidence, double* off_route, int threads) {
    RouteFilterOutputs out;
    out.best = best;
    out.confidence = confidence;
    out.off_route = off_route;
    run(rows, n_rows, weights, nullptr, out, threads);
}

void route_filter(const float* matrix, std::size_t n_queries, std::size_t n_refs, const RouteFilterParams& params,
                  const double* weights, std::int64_t* best, double* confidence, double* off_route, int threads) {
    RouteFilter filter(n_refs, params);
    filter.run(matrix, n_queries, weights, best, confidence, off_route, threads);
}

double texture_weight(const std::uint8_t* image, std::size_t n_pixels, double min_texture) noexcept {
    if (!(min_texture > 0.0)) return 1.0;
    if (n_pixels == 0) return 0.0;
    double sum = 0.0;
    for (std::size_t i = 0; i < n_pixels; ++i) sum += image[i];
    const double mean = sum / static_cast<double>(n_pixels);
    double deviation = 0.0;
    for (std::size_t i = 0; i < n_pixels; ++i) deviation += std::fabs(static_cast<double>(image[i]) - mean);
    const double mad = deviation / static_cast<double>(n_pixels);
    return std::min(1.0, mad / min_texture);
}

}  // namespace nightloc
