// Route mode's Bayes filter (see route_filter.hpp for the model). Plain sequential loops in
// double precision: the order of operations is fixed, so batch and streaming results agree
// exactly and a numpy oracle agrees to rounding.
#include "nightloc/route_filter.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

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

}  // namespace

void validate(const RouteFilterParams& p) {
    require(std::isfinite(p.vmin) && p.vmin >= 0.0 && p.vmin <= 1000.0,
            "vmin must be a speed in [0, 1000] references per frame, got " + std::to_string(p.vmin));
    require(std::isfinite(p.vmax) && p.vmax >= p.vmin && p.vmax <= 1000.0,
            "vmax must be a speed in [vmin, 1000] references per frame, got " + std::to_string(p.vmax));
    require(p.backward >= 0.0 && p.backward < 1.0, "backward must be a probability in [0, 1), got " +
                                                       std::to_string(p.backward));
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

RouteFilterStep RouteFilter::step(const float* row, double weight) {
    require(weight >= 0.0 && weight <= 1.0, "weight must be in [0, 1], got " + std::to_string(weight));
    const std::size_t n = belief_.size();
    const double nd = static_cast<double>(n);
    double* b = belief_.data();
    double* p = scratch_.data();

    // 1. Predict: shift by every advance of the kernel, in order of the advance.
    double on = 0.0;
    for (std::size_t r = 0; r < n; ++r) on += b[r];
    std::fill(p, p + n, 0.0);
    for (std::size_t i = 0; i < kernel_.weights.size(); ++i) {
        const double w = kernel_.weights[i];
        const std::int64_t k = kernel_.first + static_cast<std::int64_t>(i);
        if (w == 0.0) continue;
        if (k >= 0) {
            const auto shift = static_cast<std::size_t>(k);
            for (std::size_t r = shift; r < n; ++r) p[r] += w * b[r - shift];
        } else {
            const auto shift = static_cast<std::size_t>(-k);
            for (std::size_t r = 0; r + shift < n; ++r) p[r] += w * b[r + shift];
        }
    }
    double moved = 0.0;
    for (std::size_t r = 0; r < n; ++r) moved += p[r];
    if (moved > 0.0) {
        const double scale = on / moved;
        for (std::size_t r = 0; r < n; ++r) p[r] *= scale;
    } else {
        for (std::size_t r = 0; r < n; ++r) p[r] = on / nd;
    }
    const double keep = 1.0 - params_.floor;
    const double spread = params_.floor * on / nd;
    for (std::size_t r = 0; r < n; ++r) p[r] = keep * p[r] + spread;
    const double stay = 1.0 - params_.leave;
    const double back = off_ * params_.rejoin / nd;
    for (std::size_t r = 0; r < n; ++r) p[r] = stay * p[r] + back;
    double off = off_ * (1.0 - params_.rejoin) + on * params_.leave;

    // 2. Update with the row's likelihood.
    const double lambda = params_.sharpness * weight;
    double sum = 0.0;
    std::size_t count = 0;
    for (std::size_t r = 0; r < n; ++r) {
        if (std::isfinite(row[r])) {
            sum += static_cast<double>(row[r]);
            ++count;
        }
    }
    double mean = 0.0;
    double sd = 0.0;
    if (count > 0) {
        mean = sum / static_cast<double>(count);
        double squares = 0.0;
        for (std::size_t r = 0; r < n; ++r) {
            if (std::isfinite(row[r])) {
                const double dev = static_cast<double>(row[r]) - mean;
                squares += dev * dev;
            }
        }
        sd = std::sqrt(squares / static_cast<double>(count));
    }
    if (lambda > 0.0 && sd > 0.0) {
        // Log-likelihoods into b (the old belief is no longer needed), then exp relative to the top.
        const double zero_clipped = std::min(0.0, params_.clip);
        double top = -std::numeric_limits<double>::infinity();
        for (std::size_t r = 0; r < n; ++r) {
            const double z = std::isfinite(row[r]) ? (static_cast<double>(row[r]) - mean) / sd : 0.0;
            const double ll = -lambda * (std::isfinite(row[r]) ? std::min(z, params_.clip) : zero_clipped);
            b[r] = ll;
            top = std::max(top, ll);
        }
        double likelihood_sum = 0.0;
        for (std::size_t r = 0; r < n; ++r) {
            const double l = std::exp(b[r] - top);
            likelihood_sum += l;
            b[r] = p[r] * l;
        }
        off *= likelihood_sum / nd;
    } else {
        std::copy(p, p + n, b);
    }
    double total = off;
    for (std::size_t r = 0; r < n; ++r) total += b[r];
    if (!(total > 0.0) || !std::isfinite(total)) {
        // Cannot happen with floor > 0; with floor = 0 every place may have been ruled out.
        reset();
        total = 1.0;
    } else {
        for (std::size_t r = 0; r < n; ++r) b[r] /= total;
        off_ = off / total;
    }

    // 3. Answer.
    RouteFilterStep out;
    std::size_t best = 0;
    for (std::size_t r = 1; r < n; ++r) {
        if (b[r] > b[best]) best = r;
    }
    const std::size_t lo = best >= params_.window ? best - params_.window : 0;
    const std::size_t hi = std::min(n - 1, best + params_.window);
    double mass = 0.0;
    for (std::size_t r = lo; r <= hi; ++r) mass += b[r];
    out.best = static_cast<std::int64_t>(best);
    out.confidence = std::min(1.0, mass);
    out.off_route = off_;
    return out;
}

void route_filter(const float* matrix, std::size_t n_queries, std::size_t n_refs, const RouteFilterParams& params,
                  const double* weights, std::int64_t* best, double* confidence, double* off_route) {
    RouteFilter filter(n_refs, params);
    for (std::size_t q = 0; q < n_queries; ++q) {
        const RouteFilterStep s = filter.step(matrix + q * n_refs, weights ? weights[q] : 1.0);
        best[q] = s.best;
        confidence[q] = s.confidence;
        off_route[q] = s.off_route;
    }
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
