// The route filter's speed motion model (route_filter.hpp): a belief over (speed plane, position
// cell); each plane's mass advances by its own speed window in cells, then the speed moves
// between neighbouring planes (speed_chain()).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "common/parallel.hpp"
#include "route/route_motion.hpp"

namespace nightloc {

namespace route_detail {
namespace {

std::size_t plane_count(const RouteFilterParams& p) {
    return static_cast<std::size_t>(std::floor((p.speed_max - p.speed_min) / p.speed_step + 1e-9)) + 1;
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

class SpeedMotion final : public RouteMotionModel {
public:
    SpeedMotion(std::size_t n_refs, const RouteFilterParams& params, SpeedChain chain)
        : RouteMotionModel(n_refs, params.speed_cells, chain.prior), chain_(std::move(chain)) {
        const double k = static_cast<double>(cells_);
        const auto back = -static_cast<std::int64_t>(cells_);
        for (double v : chain_.speeds)
            plane_kernels_.push_back(
                cell_kernel(k * (v - params.speed_jitter), k * (v + params.speed_jitter), params.backward, back));
    }

    std::unique_ptr<RouteMotionModel> clone() const override { return std::make_unique<SpeedMotion>(*this); }
    RouteMotion motion() const noexcept override { return RouteMotion::kSpeed; }
    const SpeedChain* chain() const noexcept override { return &chain_; }

    MotionStep predict(const std::vector<double>& belief, std::vector<double>& prediction, double /*on*/,
                       double /*advance*/, int threads) override {
        const double moved = move_planes(belief, prediction, threads);
        mix_planes(prediction, threads);
        return {moved, 0.0};
    }

    double speed(const std::vector<double>& plane_mass, double /*moved_speed*/) const override {
        // The posterior's mean speed.
        double weighted = 0.0;
        double mass = 0.0;
        for (std::size_t s = 0; s < plane_mass.size(); ++s) {
            weighted += chain_.speeds[s] * plane_mass[s];
            mass += plane_mass[s];
        }
        return mass > 0.0 ? weighted / mass : std::numeric_limits<double>::quiet_NaN();
    }

private:
    // Every plane's mass advances by its kernel (in cells), each advance a shifted add; plane by
    // plane on the threads (each plane's sum in a fixed order, the planes' in plane order).
    double move_planes(const std::vector<double>& belief, std::vector<double>& prediction, int threads) {
        const std::size_t m = n_refs_ * cells_;
        const std::size_t planes = plane_kernels_.size();
        plane_mass_.resize(planes);
        detail::parallel_for(planes, threads, [&](std::size_t s) {
            const double* b = belief.data() + s * m;
            double* p = prediction.data() + s * m;
            std::fill(p, p + m, 0.0);
            const MotionKernel& kernel = plane_kernels_[s];
            for (std::size_t i = 0; i < kernel.weights.size(); ++i) {
                if (kernel.weights[i] == 0.0) continue;
                shift_add(b, p, m, kernel.first + static_cast<std::int64_t>(i), kernel.weights[i]);
            }
            plane_mass_[s] = sum_of(p, m);
        });
        double moved = 0.0;
        for (std::size_t s = 0; s < planes; ++s) moved += plane_mass_[s];
        return moved;
    }

    // The speed's random walk between neighbouring planes, `passes` passes; plane by plane on
    // the threads: out_s = keep_s p_s + up_{s-1} p_{s-1} + down_{s+1} p_{s+1}, in that order.
    void mix_planes(std::vector<double>& prediction, int threads) {
        if (chain_.passes == 0) return;
        const std::size_t m = n_refs_ * cells_;
        const std::size_t planes = chain_.speeds.size();
        chain_scratch_.resize(prediction.size());
        for (std::size_t pass = 0; pass < chain_.passes; ++pass) {
            const double* p = prediction.data();
            double* q = chain_scratch_.data();
            detail::parallel_for(planes, threads, [&](std::size_t s) {
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
            prediction.swap(chain_scratch_);
        }
    }

    SpeedChain chain_;
    std::vector<MotionKernel> plane_kernels_;  // in cells
    std::vector<double> plane_mass_;
    std::vector<double> chain_scratch_;
};

}  // namespace

RouteMotionSpeeds speed_motion_speeds(const RouteFilterParams& params) {
    // The planes of the central kRouteMotionSpeedMass of the speed prior: from the first plane
    // where the prior's cumulative mass exceeds the tail (10 %) to the first where it reaches 90 %.
    const SpeedChain chain = speed_chain(params);
    RouteMotionSpeeds speeds;
    speeds.fields = {"speed_min", "speed_max", "speed_change", "speed_tau"};
    const double tail = 0.5 * (1.0 - kRouteMotionSpeedMass);
    double below = 0.0;
    bool low_found = false;
    speeds.lowest = chain.speeds.front();
    speeds.highest = chain.speeds.back();
    for (std::size_t s = 0; s < chain.speeds.size(); ++s) {
        below += chain.prior[s];
        if (!low_found && below > tail) {
            speeds.lowest = chain.speeds[s];
            low_found = true;
        }
        if (below >= 1.0 - tail - 1e-12) {
            speeds.highest = chain.speeds[s];
            break;
        }
    }
    return speeds;
}

std::unique_ptr<RouteMotionModel> make_speed_motion(std::size_t n_refs, const RouteFilterParams& params,
                                                    const double* /*reference_distances*/) {
    return std::make_unique<SpeedMotion>(n_refs, params, speed_chain(params));
}

}  // namespace route_detail

SpeedChain speed_chain(const RouteFilterParams& p) {
    validate(p);
    SpeedChain chain;
    const std::size_t n = route_detail::plane_count(p);
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
    const double total = route_detail::sum_of(weight.data(), n);
    for (std::size_t s = 0; s < n; ++s) chain.prior[s] = weight[s] / total;
    return chain;
}

}  // namespace nightloc
