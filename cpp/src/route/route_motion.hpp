// Internal: the route filter's motion models. One interface for a model's prediction
// (RouteMotionModel), one unit per model (route_motion_window.cpp, route_motion_speed.cpp,
// route_motion_odometry.cpp) and the registry that maps each RouteMotion to its name and its
// unit (route_motion.cpp). What follows every model's motion (the rescaling to the on-route
// mass, the uniform floor, the off-route exchange) and the update are RouteFilter's
// (route_filter.cpp), written once for all models.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "nightloc/route_filter.hpp"

namespace nightloc::route_detail {

/// Throws std::invalid_argument(message) unless ok.
void require(bool ok, const std::string& message);

/// Sum of n doubles in a fixed order: four interleaved partial sums (so the additions pipeline
/// and vectorize), combined as (s0 + s1) + (s2 + s3), then the remainder in order.
inline double sum_of(const double* x, std::size_t n) noexcept {
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

/// out[r] += w * in[r - k] for r and r - k in 0 .. n-1 (a shift by k, mass past either end lost).
inline void shift_add(const double* in, double* out, std::size_t n, std::int64_t k, double w) noexcept {
    const std::size_t shift = static_cast<std::size_t>(k >= 0 ? k : -k);
    if (shift >= n) return;
    const std::size_t inside = n - shift;
    if (k >= 0) {
        for (std::size_t r = 0; r < inside; ++r) out[r + shift] += w * in[r];
    } else {
        for (std::size_t r = 0; r < inside; ++r) out[r] += w * in[r + shift];
    }
}

/// The advances floor(x + v) of a speed window vmin..vmax (0 <= vmin <= vmax): weights of
/// lo .. lo + size - 1, impossible ones at either end trimmed, normalized to sum 1.
MotionKernel forward_kernel(double vmin, double vmax);

/// `kernel` taken with probability 1 - backward, a step of `back` (< kernel.first) otherwise.
MotionKernel with_backward(const MotionKernel& kernel, double backward, std::int64_t back);

/// What a model's motion gives: the mass still on the route after it (before the rescaling to
/// the on-route mass) and the speed it moved at (references per frame; NaN: the model has none).
struct MotionStep {
    double moved = 0.0;
    double speed = 0.0;
};

/// A motion model of the route filter. The belief it moves is `planes()` planes of n_refs x
/// `cells()` cells, plane-major; cell c of a plane shows reference c / cells. prior() is the
/// split of mass over the planes that the reset, the floor and the rejoining mass follow (one
/// plane: {1}).
class RouteMotionModel {
public:
    virtual ~RouteMotionModel() = default;
    virtual std::unique_ptr<RouteMotionModel> clone() const = 0;
    virtual RouteMotion motion() const noexcept = 0;

    /// Moves `belief` (summing to `on`) by one frame into `prediction` (the same size; a model
    /// may swap it with a buffer of its own); mass moved past either end of the route is
    /// dropped. `advance`: the distance travelled since the previous frame (0 on the first
    /// frame after a reset); `threads`: for the model's work over planes.
    virtual MotionStep predict(const std::vector<double>& belief, std::vector<double>& prediction, double on,
                               double advance, int threads) = 0;

    /// The answer's speed from the posterior's (unnormalized) mass per plane and the motion's
    /// speed (MotionStep::speed).
    virtual double speed(const std::vector<double>& plane_mass, double moved_speed) const;

    /// The factor on a frame's evidence weight for a frame that travelled `advance` (1: every
    /// frame counts fully).
    virtual double novelty(double advance) const noexcept;

    /// Writes the state for a belief over the references (n_refs values, `total` their sum with
    /// the off-route mass): each reference's share spread over its cells evenly and over the
    /// planes by prior().
    virtual void spread(const double* belief, double total, double* out) const;

    /// The speed model's planes (nullptr for the other models).
    virtual const SpeedChain* chain() const noexcept;

    std::size_t planes() const noexcept { return prior_.size(); }
    std::size_t cells() const noexcept { return cells_; }
    const std::vector<double>& prior() const noexcept { return prior_; }

protected:
    RouteMotionModel(std::size_t n_refs, std::size_t cells, std::vector<double> prior);

    std::size_t n_refs_;
    std::size_t cells_;
    std::vector<double> prior_;
};

/// Makes a model: (n_refs >= 1, validated params, reference distances or nullptr).
using RouteMotionFactory = std::unique_ptr<RouteMotionModel> (*)(std::size_t n_refs, const RouteFilterParams& params,
                                                                 const double* reference_distances);

std::unique_ptr<RouteMotionModel> make_window_motion(std::size_t n_refs, const RouteFilterParams& params,
                                                     const double* reference_distances);
std::unique_ptr<RouteMotionModel> make_speed_motion(std::size_t n_refs, const RouteFilterParams& params,
                                                    const double* reference_distances);
std::unique_ptr<RouteMotionModel> make_odometry_motion(std::size_t n_refs, const RouteFilterParams& params,
                                                       const double* reference_distances);

/// A model's steady speeds under validated params (RouteMotionSpeeds), said by its unit.
using RouteMotionSpeedsOf = RouteMotionSpeeds (*)(const RouteFilterParams& params);

RouteMotionSpeeds window_motion_speeds(const RouteFilterParams& params);
RouteMotionSpeeds speed_motion_speeds(const RouteFilterParams& params);

/// The model params.motion names, made by its unit. Reference distances are the odometry
/// model's input: given to another model, or missing for it, they throw
/// std::invalid_argument.
std::unique_ptr<RouteMotionModel> make_route_motion(std::size_t n_refs, const RouteFilterParams& params,
                                                    const double* reference_distances);

}  // namespace nightloc::route_detail
