// The route filter's window motion model (route_filter.hpp): one plane of one cell per
// reference; every frame the reference advances by floor(x + v) for a speed v uniform in
// vmin..vmax and a phase x uniform in [0, 1) (motion_kernel()), or steps back one with
// probability `backward`.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "route/route_motion.hpp"

namespace nightloc {

MotionKernel motion_kernel(double vmin, double vmax, double backward) {
    RouteFilterParams p;
    p.vmin = vmin;
    p.vmax = vmax;
    p.backward = backward;
    validate(p);
    return route_detail::with_backward(route_detail::forward_kernel(vmin, vmax), backward, -1);
}

namespace route_detail {
namespace {

class WindowMotion final : public RouteMotionModel {
public:
    WindowMotion(std::size_t n_refs, const RouteFilterParams& params)
        : RouteMotionModel(n_refs, 1, {1.0}), kernel_(motion_kernel(params.vmin, params.vmax, params.backward)) {}

    std::unique_ptr<RouteMotionModel> clone() const override { return std::make_unique<WindowMotion>(*this); }
    RouteMotion motion() const noexcept override { return RouteMotion::kWindow; }

    MotionStep predict(const std::vector<double>& belief, std::vector<double>& prediction, double on,
                       double /*advance*/, int /*threads*/) override {
        // The shifted sum of every advance of the kernel; the mass that moved past either end is
        // known from the belief's first and last entries.
        const std::size_t n = n_refs_;
        const double* b = belief.data();
        double* p = prediction.data();
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
        return {on - lost, std::numeric_limits<double>::quiet_NaN()};
    }

    void spread(const double* belief, double total, double* out) const override {
        for (std::size_t r = 0; r < n_refs_; ++r) out[r] = belief[r] / total;
    }

private:
    MotionKernel kernel_;
};

}  // namespace

std::unique_ptr<RouteMotionModel> make_window_motion(std::size_t n_refs, const RouteFilterParams& params,
                                                     const double* /*reference_distances*/) {
    return std::make_unique<WindowMotion>(n_refs, params);
}

RouteMotionSpeeds window_motion_speeds(const RouteFilterParams& params) {
    RouteMotionSpeeds speeds;
    const double margin = 0.5 * (1.0 - kRouteMotionSpeedMass) * (params.vmax - params.vmin);
    speeds.lowest = params.vmin + margin;
    speeds.highest = params.vmax - margin;
    speeds.fields = {"vmin", "vmax"};
    return speeds;
}

}  // namespace route_detail
}  // namespace nightloc
