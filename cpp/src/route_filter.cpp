// Route mode's Bayes filter (see route_filter.hpp for the model). Plain sequential loops in
// double precision: the order of operations is fixed, so batch and streaming results agree
// exactly and a numpy oracle agrees to rounding.
#include "nightloc/route_filter.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "float_kernel_table.hpp"
#include "nightloc/simd.hpp"
#include "parallel.hpp"

namespace nightloc {

namespace {

// Integral of clip(u, 0, 1) du from -inf to t.
double ramp_integral(double t) noexcept {
    if (t <= 0.0) return 0.0;
    if (t < 1.0) return 0.5 * t * t;
    return t - 0.5;
}

// P(floor(x + v) >= k) for x ~ U[0, 1), v ~ U[vmin, vmax]: the mean of clip(v - k + 1, 0, 1).
double advance_at_least(std::int64_t k, double vmin, double vmax) noexcept {
    const double shift = 1.0 - static_cast<double>(k);
    if (vmax <= vmin) return std::clamp(vmin + shift, 0.0, 1.0);
    return (ramp_integral(vmax + shift) - ramp_integral(vmin + shift)) / (vmax - vmin);
}

void require(bool ok, const std::string& message) {
    if (!ok) throw std::invalid_argument(message);
}

bool probability(double p) noexcept { return p >= 0.0 && p <= 1.0; }

// Sum of n doubles in a fixed order: four interleaved partial sums (so the additions pipeline
// and vectorize), combined as (s0 + s1) + (s2 + s3), then the remainder in order.
double sum_of(const double* x, std::size_t n) noexcept {
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    std::size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        s0 += x[i];
        s1 += x[i + 1];
        s2 += x[i + 2];
        s3 += x[i + 3];
    }
    double total = (s0 + s1) + (s2 + s3);
    for (; i < n; ++i) total += x[i];
    return total;
}

#if defined(__GNUC__) || defined(__clang__)
#define NIGHTLOC_ALWAYS_INLINE __attribute__((always_inline))
#else
#define NIGHTLOC_ALWAYS_INLINE
#endif

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::size_t kMaxSpeedPlanes = 1000;
constexpr std::size_t kMaxCells = 64;
constexpr std::size_t kMaxSpreadPasses = 256;
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

void validate(const RouteFilterParams& p) {
    require(std::isfinite(p.vmin) && p.vmin >= 0.0 && p.vmin <= 1000.0,
            "vmin must be a speed in [0, 1000] references per frame, got " + std::to_string(p.vmin));
    require(std::isfinite(p.vmax) && p.vmax >= p.vmin && p.vmax <= 1000.0,
            "vmax must be a speed in [vmin, 1000] references per frame, got " + std::to_string(p.vmax));
    require(p.backward >= 0.0 && p.backward < 1.0,
            "backward must be a probability in [0, 1), got " + std::to_string(p.backward));
    require(probability(p.floor), "floor must be a probability in [0, 1], got " + std::to_string(p.floor));
    require(std::isfinite(p.sharpness) && p.sharpness >= 0.0,
            "sharpness must be a finite number >= 0, got " + std::to_string(p.sharpness));
    require(!std::isnan(p.clip) && p.clip > -std::numeric_limits<double>::infinity(),
            "clip must be a number or +inf, got " + std::to_string(p.clip));
    require(probability(p.leave), "leave must be a probability in [0, 1], got " + std::to_string(p.leave));
    require(probability(p.rejoin), "rejoin must be a probability in [0, 1], got " + std::to_string(p.rejoin));
    require(p.motion == RouteMotion::kWindow || p.motion == RouteMotion::kSpeed,
            "motion must be window (0) or speed (1), got " + std::to_string(static_cast<int>(p.motion)));
    require(std::isfinite(p.speed_min) && p.speed_min >= -1000.0 && p.speed_min <= 1000.0,
            "speed_min must be a speed in [-1000, 1000] references per frame, got " + std::to_string(p.speed_min));
    require(std::isfinite(p.speed_max) && p.speed_max >= p.speed_min && p.speed_max <= 1000.0,
            "speed_max must be a speed in [speed_min, 1000] references per frame, got " + std::to_string(p.speed_max));
    require(std::isfinite(p.speed_step) && p.speed_step > 0.0,
            "speed_step must be a speed > 0 references per frame, got " + std::to_string(p.speed_step));
    require((p.speed_max - p.speed_min) / p.speed_step < static_cast<double>(kMaxSpeedPlanes),
            "speed_min .. speed_max in steps of speed_step gives more than " + std::to_string(kMaxSpeedPlanes) +
                " speed planes; widen speed_step");
    require(std::isfinite(p.speed_jitter) && p.speed_jitter >= 0.0 && p.speed_jitter <= 1000.0,
            "speed_jitter must be in [0, 1000] references per frame, got " + std::to_string(p.speed_jitter));
    require(p.speed_jitter * static_cast<double>(p.speed_cells) <= 2000.0,
            "speed_jitter x speed_cells must be at most 2000 cells (each plane's kernel spans twice that), got " +
                std::to_string(p.speed_jitter * static_cast<double>(p.speed_cells)));
    require(std::isfinite(p.speed_change) && p.speed_change >= 0.0 && p.speed_change <= 50.0 * p.speed_step,
            "speed_change must be in [0, 50 * speed_step] references per frame, got " + std::to_string(p.speed_change));
    require(p.speed_tau > 0.0,
            "speed_tau must be > 0 frames (inf: no pull towards 1), got " + std::to_string(p.speed_tau));
    require(p.speed_cells >= 1 && p.speed_cells <= kMaxCells,
            "speed_cells must be 1 .. " + std::to_string(kMaxCells) + ", got " + std::to_string(p.speed_cells));
    require(p.odometry_cells >= 1 && p.odometry_cells <= kMaxCells,
            "odometry_cells must be 1 .. " + std::to_string(kMaxCells) + ", got " + std::to_string(p.odometry_cells));
    require(std::isfinite(p.odometry_noise) && p.odometry_noise >= 0.0 && p.odometry_noise <= 10.0,
            "odometry_noise must be a relative error in [0, 10], got " + std::to_string(p.odometry_noise));
    require(std::isfinite(p.odometry_jitter) && p.odometry_jitter >= 0.0 && p.odometry_jitter <= 100.0,
            "odometry_jitter must be in [0, 100] references, got " + std::to_string(p.odometry_jitter));
    require(std::isfinite(p.odometry_novelty) && p.odometry_novelty >= 0.0 && p.odometry_novelty <= 1000.0,
            "odometry_novelty must be in [0, 1000] references, got " + std::to_string(p.odometry_novelty));
}

namespace {

// The advances floor(x + v) of a speed window vmin..vmax (0 <= vmin <= vmax): weights of
// lo .. lo + size - 1, impossible ones at either end trimmed, normalized to sum 1.
MotionKernel forward_kernel(double vmin, double vmax) {
    const auto lo = static_cast<std::int64_t>(std::floor(vmin));
    const auto hi = static_cast<std::int64_t>(std::floor(vmax)) + 1;
    std::vector<double> forward;
    forward.reserve(static_cast<std::size_t>(hi - lo + 1));
    for (std::int64_t k = lo; k <= hi; ++k) {
        const double w = advance_at_least(k, vmin, vmax) - advance_at_least(k + 1, vmin, vmax);
        forward.push_back(std::max(0.0, w));
    }
    // Trim advances that cannot happen (e.g. an integer speed window).
    std::size_t begin = 0;
    std::size_t end = forward.size();
    while (begin < end && forward[begin] == 0.0) ++begin;
    while (end > begin && forward[end - 1] == 0.0) --end;
    double total = 0.0;
    for (std::size_t i = begin; i < end; ++i) total += forward[i];
    MotionKernel kernel;
    kernel.first = lo + static_cast<std::int64_t>(begin);
    for (std::size_t i = begin; i < end; ++i) kernel.weights.push_back(forward[i] / total);
    return kernel;
}

// `kernel` taken with probability 1 - backward, a step of `back` (< kernel.first) otherwise.
MotionKernel with_backward(const MotionKernel& kernel, double backward, std::int64_t back) {
    if (!(backward > 0.0)) return kernel;
    MotionKernel out;
    out.first = back;
    out.weights.push_back(backward);
    for (std::int64_t k = back + 1; k < kernel.first; ++k) out.weights.push_back(0.0);
    for (double w : kernel.weights) out.weights.push_back(w * (1.0 - backward));
    return out;
}

// A speed plane's kernel in cells: floor(x + u) for u uniform in lo .. hi cells (any signs),
// computed on the window shifted by a whole number of cells to lie at or above 0.
MotionKernel cell_kernel(double lo, double hi, double backward, std::int64_t back) {
    const double shift = lo < 0.0 ? std::ceil(-lo) : 0.0;
    MotionKernel kernel = forward_kernel(lo + shift, hi + shift);
    kernel.first -= static_cast<std::int64_t>(shift);
    if (kernel.first <= back) {
        // A plane that may already move back by a reference or more: the backward step mixes in.
        MotionKernel mixed;
        mixed.first = std::min(kernel.first, back);
        const auto last = std::max(kernel.first + static_cast<std::int64_t>(kernel.weights.size()) - 1, back);
        mixed.weights.assign(static_cast<std::size_t>(last - mixed.first + 1), 0.0);
        for (std::size_t i = 0; i < kernel.weights.size(); ++i)
            mixed.weights[static_cast<std::size_t>(kernel.first + static_cast<std::int64_t>(i) - mixed.first)] +=
                kernel.weights[i] * (1.0 - backward);
        mixed.weights[static_cast<std::size_t>(back - mixed.first)] += backward;
        return mixed;
    }
    return with_backward(kernel, backward, back);
}

std::size_t plane_count(const RouteFilterParams& p) {
    return static_cast<std::size_t>(std::floor((p.speed_max - p.speed_min) / p.speed_step + 1e-9)) + 1;
}

// out[r] += w * in[r - k] for r and r - k in 0 .. n-1 (a shift by k, mass past either end lost).
void shift_add(const double* in, double* out, std::size_t n, std::int64_t k, double w) noexcept {
    const std::size_t shift = static_cast<std::size_t>(k >= 0 ? k : -k);
    if (shift >= n) return;
    const std::size_t inside = n - shift;
    if (k >= 0) {
        for (std::size_t r = 0; r < inside; ++r) out[r + shift] += w * in[r];
    } else {
        for (std::size_t r = 0; r < inside; ++r) out[r] += w * in[r + shift];
    }
}

}  // namespace

MotionKernel motion_kernel(double vmin, double vmax, double backward) {
    RouteFilterParams p;
    p.vmin = vmin;
    p.vmax = vmax;
    p.backward = backward;
    validate(p);
    return with_backward(forward_kernel(vmin, vmax), backward, -1);
}

SpeedChain speed_chain(const RouteFilterParams& p) {
    validate(p);
    SpeedChain chain;
    const std::size_t n = plane_count(p);
    chain.speeds.resize(n);
    for (std::size_t s = 0; s < n; ++s) chain.speeds[s] = p.speed_min + static_cast<double>(s) * p.speed_step;
    chain.up.assign(n, 0.0);
    chain.down.assign(n, 0.0);
    chain.prior.assign(n, 1.0 / static_cast<double>(n));
    const double change = p.speed_change / p.speed_step;  // planes per frame
    const double variance = change * change;
    if (!(variance > 0.0) || n == 1) return chain;
    chain.passes = static_cast<std::size_t>(std::max(1.0, std::ceil(variance / 0.5)));
    const double per_pass = variance / static_cast<double>(chain.passes);
    for (std::size_t s = 0; s < n; ++s) {
        const double pull =
            std::isinf(p.speed_tau)
                ? 0.0
                : -(chain.speeds[s] - 1.0) / (p.speed_tau * p.speed_step * static_cast<double>(chain.passes));
        const double drift = std::clamp(pull, -per_pass, per_pass);
        chain.up[s] = s + 1 < n ? 0.5 * (per_pass + drift) : 0.0;
        chain.down[s] = s > 0 ? 0.5 * (per_pass - drift) : 0.0;
    }
    // Stationary distribution by detailed balance, outwards from the plane nearest to 1 (the
    // flows there point towards it, so every ratio is defined).
    std::size_t centre = 0;
    for (std::size_t s = 1; s < n; ++s)
        if (std::fabs(chain.speeds[s] - 1.0) < std::fabs(chain.speeds[centre] - 1.0)) centre = s;
    std::vector<double> weight(n, 0.0);
    weight[centre] = 1.0;
    for (std::size_t s = centre; s + 1 < n; ++s)
        weight[s + 1] = chain.down[s + 1] > 0.0 ? weight[s] * chain.up[s] / chain.down[s + 1] : 0.0;
    for (std::size_t s = centre; s > 0; --s)
        weight[s - 1] = chain.up[s - 1] > 0.0 ? weight[s] * chain.down[s] / chain.up[s - 1] : 0.0;
    const double total = sum_of(weight.data(), n);
    for (std::size_t s = 0; s < n; ++s) chain.prior[s] = weight[s] / total;
    return chain;
}

std::vector<double> odometry_spread(double advance, double spacing, const RouteFilterParams& p) {
    const double cells = static_cast<double>(p.odometry_cells);
    const double travel = p.odometry_noise * std::fabs(advance) / spacing;  // references
    const double variance = cells * cells * (travel * travel + p.odometry_jitter * p.odometry_jitter);
    std::vector<double> taps{1.0};
    if (!(variance > 0.0)) return taps;
    const double wanted = std::ceil(variance / 0.5);
    const std::size_t passes =
        wanted < static_cast<double>(kMaxSpreadPasses) ? static_cast<std::size_t>(wanted) : kMaxSpreadPasses;
    const double q = std::min(0.25, variance / (2.0 * static_cast<double>(passes)));
    for (std::size_t pass = 0; pass < passes; ++pass) {
        std::vector<double> next(taps.size() + 2, 0.0);
        for (std::size_t i = 0; i < taps.size(); ++i) {
            next[i] += q * taps[i];
            next[i + 1] += (1.0 - 2.0 * q) * taps[i];
            next[i + 2] += q * taps[i];
        }
        taps.swap(next);
    }
    return taps;
}

RouteFilter::RouteFilter(std::size_t n_refs, const RouteFilterParams& params, const double* reference_distances)
    : params_(params), kernel_(motion_kernel(params.vmin, params.vmax, params.backward)), n_refs_(n_refs) {
    validate(params);
    require(n_refs >= 1, "the route filter needs at least one reference");
    if (reference_distances != nullptr) {
        require(n_refs >= 2, "the odometry model needs at least two references");
        for (std::size_t r = 0; r < n_refs; ++r) {
            require(std::isfinite(reference_distances[r]),
                    "reference distances must be finite (reference " + std::to_string(r) + ")");
            require(r == 0 || reference_distances[r] >= reference_distances[r - 1],
                    "reference distances must not decrease along the route (reference " + std::to_string(r) + ")");
        }
        const double length = reference_distances[n_refs - 1] - reference_distances[0];
        require(length > 0.0 && std::isfinite(length), "the reference distances must cover a positive, finite length");
        odometry_ = true;
        planes_ = 1;
        cells_ = params.odometry_cells;
        reference_distance_.assign(reference_distances, reference_distances + n_refs);
        spacing_ = length / static_cast<double>(n_refs - 1);
        // 1 / the gap after each reference (a gap of 0 is never divided by: the target interval
        // always ends above the target distance).
        inverse_gap_.assign(n_refs, 0.0);
        for (std::size_t r = 0; r + 1 < n_refs; ++r) {
            const double gap = reference_distance_[r + 1] - reference_distance_[r];
            if (gap > 0.0) inverse_gap_[r] = 1.0 / gap;
        }
        plane_prior_.assign(1, 1.0);
    } else if (params.motion == RouteMotion::kSpeed) {
        chain_ = speed_chain(params);
        cells_ = params.speed_cells;
        planes_ = chain_.speeds.size();
        const double k = static_cast<double>(cells_);
        const auto back = -static_cast<std::int64_t>(cells_);
        for (double v : chain_.speeds)
            plane_kernels_.push_back(
                cell_kernel(k * (v - params.speed_jitter), k * (v + params.speed_jitter), params.backward, back));
        plane_prior_ = chain_.prior;
    }
    if (planes_ == 0) {
        belief_.assign(n_refs, 0.0);
        scratch_.assign(n_refs, 0.0);
    } else {
        const double values = static_cast<double>(n_refs) * static_cast<double>(cells_) * static_cast<double>(planes_);
        require(values <= kMaxBeliefValues, "the " + std::string(motion_name()) + " model's belief would hold " +
                                                std::to_string(values) + " values; use fewer speed planes or cells");
        const std::size_t size = n_refs * cells_ * planes_;
        belief_.assign(size, 0.0);
        scratch_.assign(size, 0.0);
        if (chain_.passes > 0 || odometry_) chain_scratch_.assign(size, 0.0);
        marginal_.assign(n_refs, 0.0);
        if (odometry_) {
            // Cell c shows reference c / cells at fractional position (c + 0.5) / cells - 0.5.
            const std::size_t m = n_refs * cells_;
            cell_distance_.resize(m);
            const double* d = reference_distance_.data();
            for (std::size_t c = 0; c < m; ++c) {
                const double u = (static_cast<double>(c) + 0.5) / static_cast<double>(cells_) - 0.5;
                if (u <= 0.0) {
                    cell_distance_[c] = d[0] + u * spacing_;
                } else if (u >= static_cast<double>(n_refs - 1)) {
                    cell_distance_[c] = d[n_refs - 1] + (u - static_cast<double>(n_refs - 1)) * spacing_;
                } else {
                    const auto r = static_cast<std::size_t>(std::floor(u));
                    const double f = u - static_cast<double>(r);
                    cell_distance_[c] = d[r] + f * (d[r + 1] - d[r]);
                }
            }
        }
    }
    reset();
}

const char* RouteFilter::motion_name() const noexcept {
    if (odometry_) return "odometry";
    return planes_ > 0 ? "speed" : "window";
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
    if (planes_ == 0) {
        std::fill(belief_.begin(), belief_.end(), 1.0 / static_cast<double>(belief_.size()));
        return;
    }
    const std::size_t m = n_refs_ * cells_;
    for (std::size_t s = 0; s < planes_; ++s)
        std::fill(belief_.begin() + static_cast<std::ptrdiff_t>(s * m),
                  belief_.begin() + static_cast<std::ptrdiff_t>((s + 1) * m), plane_prior_[s] / static_cast<double>(m));
    marginalize(belief_.data(), planes_, n_refs_, cells_, marginal_.data());
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
    if (planes_ == 0) {
        for (std::size_t r = 0; r < n_refs_; ++r) belief_[r] = belief[r] / total;
        return;
    }
    const std::size_t m = n_refs_ * cells_;
    const double per_cell = 1.0 / (total * static_cast<double>(cells_));
    for (std::size_t s = 0; s < planes_; ++s)
        for (std::size_t c = 0; c < m; ++c) belief_[s * m + c] = belief[c / cells_] * per_cell * plane_prior_[s];
    marginalize(belief_.data(), planes_, n_refs_, cells_, marginal_.data());
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
    const RouteFilterStep out =
        planes_ == 0 ? update_window(likelihood, likelihood_sum) : update_planes(likelihood, likelihood_sum, advance);
    fresh_ = false;
    return out;
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

RouteFilterStep RouteFilter::update_window(const double* likelihood, double likelihood_sum) {
    const std::size_t n = belief_.size();
    const double nd = static_cast<double>(n);
    double* b = belief_.data();
    double* p = scratch_.data();
    const double on = 1.0 - off_;  // the belief sums to 1 - off_ (normalized every step)

    // 1. Predict. The shifted sum of every advance of the kernel goes to p; the mass that moved
    // past either end is known from the belief's first and last entries, so the rescaling to the
    // on-route mass, the uniform floor and the off-route exchange fold into one affine map
    // p' = scale * p + offset, applied with the update.
    std::fill(p, p + n, 0.0);
    double lost = 0.0;
    for (std::size_t i = 0; i < kernel_.weights.size(); ++i) {
        const double w = kernel_.weights[i];
        const std::int64_t k = kernel_.first + static_cast<std::int64_t>(i);
        if (w == 0.0) continue;
        const std::size_t shift = static_cast<std::size_t>(k >= 0 ? k : -k);
        const std::size_t inside = shift < n ? n - shift : 0;
        if (k >= 0) {
            for (std::size_t r = 0; r < inside; ++r) p[r + shift] += w * b[r];
            lost += w * sum_of(b + inside, n - inside);
        } else {
            for (std::size_t r = 0; r < inside; ++r) p[r] += w * b[r + shift];
            lost += w * sum_of(b, n - inside);
        }
    }
    const double moved = on - lost;
    const double stay = 1.0 - params_.leave;
    const double back = off_ * params_.rejoin / nd;
    double scale = 0.0;
    double offset = stay * on / nd + back;  // nothing left on the route: uniform
    if (moved > 0.0) {
        scale = stay * (1.0 - params_.floor) * (on / moved);
        offset = stay * (params_.floor * on / nd) + back;
    }
    const double off = (off_ * (1.0 - params_.rejoin) + on * params_.leave) * (likelihood_sum / nd);

    // 2. Update: posterior = prediction x likelihood, normalized with the off-route state.
    for (std::size_t r = 0; r < n; ++r) b[r] = (scale * p[r] + offset) * likelihood[r];
    const double total = sum_of(b, n) + off;
    if (!(total > 0.0) || !std::isfinite(total)) {
        reset();  // cannot happen with floor > 0; with floor = 0 every place may be ruled out
    } else {
        const double inverse = 1.0 / total;
        for (std::size_t r = 0; r < n; ++r) b[r] *= inverse;
        off_ = off * inverse;
    }
    return answer(b, std::numeric_limits<double>::quiet_NaN());
}

double RouteFilter::move_planes() {
    // Every plane's mass advances by its kernel (in cells), each advance a shifted add; plane by
    // plane on the threads (each plane's sum in a fixed order, the planes' in plane order).
    const std::size_t m = n_refs_ * cells_;
    plane_mass_.resize(planes_);
    detail::parallel_for(planes_, plane_threads(), [&](std::size_t s) {
        const double* b = belief_.data() + s * m;
        double* p = scratch_.data() + s * m;
        std::fill(p, p + m, 0.0);
        const MotionKernel& kernel = plane_kernels_[s];
        for (std::size_t i = 0; i < kernel.weights.size(); ++i) {
            if (kernel.weights[i] == 0.0) continue;
            shift_add(b, p, m, kernel.first + static_cast<std::int64_t>(i), kernel.weights[i]);
        }
        plane_mass_[s] = sum_of(p, m);
    });
    double moved = 0.0;
    for (std::size_t s = 0; s < planes_; ++s) moved += plane_mass_[s];
    return moved;
}

double RouteFilter::move_odometry(double advance, double* speed) {
    // Each cell's mass goes to the cell at its distance + advance, split linearly between the
    // two nearest cells (past either end: lost); then the position noise spreads it.
    const std::size_t m = n_refs_ * cells_;
    const double* b = belief_.data();
    double* target = scratch_.data();
    std::fill(target, target + m, 0.0);
    const double k = static_cast<double>(cells_);
    const double* d = reference_distance_.data();
    const std::size_t n = n_refs_;
    double travelled = 0.0;  // belief-weighted advance, references
    double mass = 0.0;
    if (advance == 0.0) {
        std::copy(b, b + m, target);
        travelled = 0.0;
        mass = 1.0;
    } else {
        std::size_t r = 0;  // the last reference with d[r] <= the target distance (moves forward with c)
        for (std::size_t c = 0; c < m; ++c) {
            const double goal = cell_distance_[c] + advance;
            double u = 0.0;
            if (goal < d[0]) {
                u = (goal - d[0]) / spacing_;
            } else {
                while (r + 1 < n && d[r + 1] <= goal) ++r;
                u = r + 1 < n ? static_cast<double>(r) + (goal - d[r]) * inverse_gap_[r]
                              : static_cast<double>(n - 1) + (goal - d[n - 1]) / spacing_;
            }
            const double from = (static_cast<double>(c) + 0.5) / k - 0.5;
            travelled += b[c] * (u - from);
            mass += b[c];
            const double t = std::clamp((u + 0.5) * k - 0.5, -2.0, static_cast<double>(m) + 1.0);
            const double lower = std::floor(t);
            const double upper_share = t - lower;
            const auto i = static_cast<std::int64_t>(lower);
            if (i >= 0 && i < static_cast<std::int64_t>(m)) target[i] += (1.0 - upper_share) * b[c];
            if (i + 1 >= 0 && i + 1 < static_cast<std::int64_t>(m)) target[i + 1] += upper_share * b[c];
        }
    }
    *speed = mass > 0.0 ? travelled / mass : 0.0;
    const std::vector<double> taps = odometry_spread(advance, spacing_, params_);
    if (taps.size() == 1) return sum_of(target, m);
    // Spread: out[c] = sum_i taps[i] * target[c - (i - h)], into the chain scratch, which then
    // becomes the prediction.
    double* p = chain_scratch_.data();
    std::fill(p, p + m, 0.0);
    const auto half = static_cast<std::int64_t>(taps.size() / 2);
    for (std::size_t i = 0; i < taps.size(); ++i) shift_add(target, p, m, static_cast<std::int64_t>(i) - half, taps[i]);
    scratch_.swap(chain_scratch_);
    return sum_of(scratch_.data(), m);
}

void RouteFilter::mix_planes() {
    // The speed's random walk between neighbouring planes, `passes` passes; plane by plane on
    // the threads: out_s = keep_s p_s + up_{s-1} p_{s-1} + down_{s+1} p_{s+1}, in that order.
    const std::size_t m = n_refs_ * cells_;
    const std::size_t planes = chain_.speeds.size();
    for (std::size_t pass = 0; pass < chain_.passes; ++pass) {
        const double* p = scratch_.data();
        double* q = chain_scratch_.data();
        detail::parallel_for(planes, plane_threads(), [&](std::size_t s) {
            const double keep = 1.0 - chain_.up[s] - chain_.down[s];
            const double* here = p + s * m;
            double* out = q + s * m;
            const double from_below = s > 0 ? chain_.up[s - 1] : 0.0;
            const double from_above = s + 1 < planes ? chain_.down[s + 1] : 0.0;
            const double* below = s > 0 ? p + (s - 1) * m : here;
            const double* above = s + 1 < planes ? p + (s + 1) * m : here;
            for (std::size_t c = 0; c < m; ++c)
                out[c] = (keep * here[c] + from_below * below[c]) + from_above * above[c];
        });
        scratch_.swap(chain_scratch_);
    }
}

int RouteFilter::plane_threads() const noexcept {
    // A plane is worth a thread from about 64k cells on (below, waking the threads costs more).
    return n_refs_ * cells_ >= 65536 ? threads_ : 1;
}

double RouteFilter::novelty(double advance) const noexcept {
    if (!odometry_ || !(params_.odometry_novelty > 0.0)) return 1.0;
    return std::min(1.0, std::fabs(advance) / (params_.odometry_novelty * spacing_));
}

double RouteFilter::frame_weight(double weight, double advance) const noexcept {
    return fresh_ ? weight : weight * novelty(advance);
}

RouteFilterStep RouteFilter::update_planes(const double* likelihood, double likelihood_sum, double advance) {
    const std::size_t m = n_refs_ * cells_;
    const double md = static_cast<double>(m);
    const double on = 1.0 - off_;
    double speed = 0.0;
    // 1. Predict: the motion into scratch_, the speed chain, then the rescaling to the on-route
    // mass, the floor and the off-route exchange as one affine map per plane.
    const double moved = odometry_ ? move_odometry(fresh_ ? 0.0 : advance, &speed) : move_planes();
    if (!odometry_) mix_planes();
    const double stay = 1.0 - params_.leave;
    const double back = off_ * params_.rejoin / md;
    double scale = 0.0;
    double spread = stay * on / md + back;  // nothing left on the route: uniform
    if (moved > 0.0) {
        scale = stay * (1.0 - params_.floor) * (on / moved);
        spread = stay * (params_.floor * on / md) + back;
    }
    const double off =
        (off_ * (1.0 - params_.rejoin) + on * params_.leave) * (likelihood_sum / static_cast<double>(n_refs_));

    // 2. Update: posterior = prediction x likelihood (the same for every cell and plane of a
    // reference), plane by plane (on the threads when the planes are large), each plane's sum in
    // a fixed order.
    plane_mass_.resize(planes_);
    const std::size_t cells = cells_;
    const double* cell_likelihood = likelihood;
    if (cells > 1) {
        cell_likelihood_.resize(m);
        for (std::size_t r = 0; r < n_refs_; ++r)
            for (std::size_t k = 0; k < cells; ++k) cell_likelihood_[r * cells + k] = likelihood[r];
        cell_likelihood = cell_likelihood_.data();
    }
    const int threads = plane_threads();
    detail::parallel_for(planes_, threads, [&](std::size_t s) {
        const double offset = spread * plane_prior_[s];
        const double* p = scratch_.data() + s * m;
        double* b = belief_.data() + s * m;
        for (std::size_t c = 0; c < m; ++c) b[c] = (scale * p[c] + offset) * cell_likelihood[c];
        plane_mass_[s] = sum_of(b, m);
    });
    double total = off;
    for (std::size_t s = 0; s < planes_; ++s) total += plane_mass_[s];
    if (!(total > 0.0) || !std::isfinite(total)) {
        reset();  // cannot happen with floor > 0; with floor = 0 every place may be ruled out
        return answer(marginal_.data(), std::numeric_limits<double>::quiet_NaN());
    }
    // 3. Normalize, then sum over the planes (in plane order) per cell and over each reference's
    // cells (in cell order).
    const double inverse = 1.0 / total;
    off_ = off * inverse;
    detail::parallel_for(planes_, threads, [&](std::size_t s) {
        double* b = belief_.data() + s * m;
        for (std::size_t c = 0; c < m; ++c) b[c] *= inverse;
    });
    double* cell_sum = cells > 1 ? cell_likelihood_.data() : marginal_.data();  // the cells' likelihood is spent
    std::copy(belief_.data(), belief_.data() + m, cell_sum);
    for (std::size_t s = 1; s < planes_; ++s) {
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
    if (!odometry_) {
        // The posterior's mean speed.
        double weighted = 0.0;
        double mass = 0.0;
        for (std::size_t s = 0; s < planes_; ++s) {
            weighted += chain_.speeds[s] * plane_mass_[s];
            mass += plane_mass_[s];
        }
        speed = mass > 0.0 ? weighted / mass : std::numeric_limits<double>::quiet_NaN();
    }
    return answer(marginal_.data(), speed);
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
