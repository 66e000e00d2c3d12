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
}

MotionKernel motion_kernel(double vmin, double vmax, double backward) {
    RouteFilterParams p;
    p.vmin = vmin;
    p.vmax = vmax;
    p.backward = backward;
    validate(p);
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
    if (backward > 0.0) {
        kernel.first = -1;
        kernel.weights.push_back(backward);
        // Advances of 0 .. lo-1 (between the backward step and the speed window) cannot happen.
        for (std::int64_t k = 0; k < lo + static_cast<std::int64_t>(begin); ++k) kernel.weights.push_back(0.0);
    } else {
        kernel.first = lo + static_cast<std::int64_t>(begin);
    }
    for (std::size_t i = begin; i < end; ++i) kernel.weights.push_back(forward[i] / total * (1.0 - backward));
    return kernel;
}

RouteFilter::RouteFilter(std::size_t n_refs, const RouteFilterParams& params)
    : params_(params), kernel_(motion_kernel(params.vmin, params.vmax, params.backward)) {
    validate(params);
    require(n_refs >= 1, "the route filter needs at least one reference");
    belief_.assign(n_refs, 0.0);
    scratch_.assign(n_refs, 0.0);
    reset();
}

void RouteFilter::reset() {
    std::fill(belief_.begin(), belief_.end(), 1.0 / static_cast<double>(belief_.size()));
    off_ = 0.0;
}

void RouteFilter::set_state(const double* belief, double off_route) {
    double total = 0.0;
    for (std::size_t r = 0; r < belief_.size(); ++r) {
        require(std::isfinite(belief[r]) && belief[r] >= 0.0, "belief values must be finite and >= 0");
        total += belief[r];
    }
    require(std::isfinite(off_route) && off_route >= 0.0, "off_route must be finite and >= 0");
    total += off_route;
    require(total > 0.0, "belief and off_route must not all be 0");
    for (std::size_t r = 0; r < belief_.size(); ++r) belief_[r] = belief[r] / total;
    off_ = off_route / total;
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

RouteFilterStep RouteFilter::step(const float* row, double weight) {
    require(weight >= 0.0 && weight <= 1.0, "weight must be in [0, 1], got " + std::to_string(weight));
    likelihood_.resize(belief_.size());
    const double sum =
        route_likelihood(row, belief_.size(), params_.sharpness * weight, params_.clip, likelihood_.data());
    return update(likelihood_.data(), sum);
}

RouteFilterStep RouteFilter::update(const double* likelihood, double likelihood_sum) {
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

    // 3. Answer: the first maximum, and the mass around it.
    const double top = max_of(b, n);
    std::size_t best = 0;
    while (best + 1 < n && b[best] != top) ++best;
    const std::size_t lo = best >= params_.window ? best - params_.window : 0;
    const std::size_t hi = std::min(n - 1, best + params_.window);
    RouteFilterStep out;
    out.best = static_cast<std::int64_t>(best);
    out.confidence = std::min(1.0, sum_of(b + lo, hi - lo + 1));
    out.off_route = off_;
    return out;
}

void RouteFilter::run(const float* rows, std::size_t n_rows, const double* weights, std::int64_t* best,
                      double* confidence, double* off_route, int threads) {
    const std::size_t n = belief_.size();
    for (std::size_t q = 0; q < n_rows; ++q) {
        const double w = weights ? weights[q] : 1.0;
        require(w >= 0.0 && w <= 1.0, "weight " + std::to_string(q) + " must be in [0, 1], got " + std::to_string(w));
    }
    // Likelihoods do not depend on the belief: a block of rows at a time on the threads, then
    // the sequential updates of that block.
    const std::size_t block = threads > 1 ? std::min<std::size_t>(n_rows, 64) : 1;
    std::vector<double> likelihoods(block * n);
    std::vector<double> sums(block);
    for (std::size_t start = 0; start < n_rows; start += block) {
        const std::size_t rows_here = std::min(block, n_rows - start);
        detail::parallel_for(rows_here, threads, [&](std::size_t i) {
            const std::size_t q = start + i;
            const double lambda = params_.sharpness * (weights ? weights[q] : 1.0);
            sums[i] = route_likelihood(rows + q * n, n, lambda, params_.clip, likelihoods.data() + i * n);
        });
        for (std::size_t i = 0; i < rows_here; ++i) {
            const RouteFilterStep s = update(likelihoods.data() + i * n, sums[i]);
            best[start + i] = s.best;
            confidence[start + i] = s.confidence;
            off_route[start + i] = s.off_route;
        }
    }
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
