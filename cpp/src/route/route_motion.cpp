// The route filter's motion models: the registry (name <-> RouteMotion <-> unit) and what the
// models share (see route_motion.hpp).
#include "route/route_motion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace nightloc {

namespace route_detail {
namespace {

struct RouteMotionEntry {
    RouteMotion motion;
    const char* name;
    RouteMotionFactory make;
    bool needs_distances;        // the model moves by the distance travelled
    RouteMotionSpeedsOf speeds;  // its steady speeds (nullptr: it follows any speed)
};

// The registry: one line per model, in RouteMotion order.
constexpr RouteMotionEntry kRouteMotions[] = {
    {RouteMotion::kWindow, "window", &make_window_motion, false, &window_motion_speeds},
    {RouteMotion::kSpeed, "speed", &make_speed_motion, false, &speed_motion_speeds},
    {RouteMotion::kOdometry, "odometry", &make_odometry_motion, true, nullptr},
};

constexpr bool in_enum_order() noexcept {
    for (std::size_t i = 0; i < sizeof kRouteMotions / sizeof kRouteMotions[0]; ++i)
        if (static_cast<std::size_t>(kRouteMotions[i].motion) != i) return false;
    return true;
}
static_assert(in_enum_order(), "the registry's lines follow RouteMotion's values (a model's value is its index)");

const RouteMotionEntry* find_entry(RouteMotion motion) noexcept {
    for (const RouteMotionEntry& entry : kRouteMotions)
        if (entry.motion == motion) return &entry;
    return nullptr;
}

// "'window', 'speed', 'odometry'": the names as a setting's choices are worded.
std::string name_list() {
    std::string names;
    for (const RouteMotionEntry& entry : kRouteMotions)
        names += (names.empty() ? "'" : ", '") + std::string(entry.name) + "'";
    return names;
}

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

}  // namespace

void require(bool ok, const std::string& message) {
    if (!ok) throw std::invalid_argument(message);
}

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

MotionKernel with_backward(const MotionKernel& kernel, double backward, std::int64_t back) {
    if (!(backward > 0.0)) return kernel;
    MotionKernel out;
    out.first = back;
    out.weights.push_back(backward);
    for (std::int64_t k = back + 1; k < kernel.first; ++k) out.weights.push_back(0.0);
    for (double w : kernel.weights) out.weights.push_back(w * (1.0 - backward));
    return out;
}

RouteMotionModel::RouteMotionModel(std::size_t n_refs, std::size_t cells, std::vector<double> prior)
    : n_refs_(n_refs), cells_(cells), prior_(std::move(prior)) {}

double RouteMotionModel::speed(const std::vector<double>& /*plane_mass*/, double moved_speed) const {
    return moved_speed;
}

double RouteMotionModel::novelty(double /*advance*/) const noexcept { return 1.0; }

void RouteMotionModel::spread(const double* belief, double total, double* out) const {
    const std::size_t m = n_refs_ * cells_;
    const double per_cell = 1.0 / (total * static_cast<double>(cells_));
    for (std::size_t s = 0; s < prior_.size(); ++s)
        for (std::size_t c = 0; c < m; ++c) out[s * m + c] = belief[c / cells_] * per_cell * prior_[s];
}

const SpeedChain* RouteMotionModel::chain() const noexcept { return nullptr; }

std::unique_ptr<RouteMotionModel> make_route_motion(std::size_t n_refs, const RouteFilterParams& params,
                                                    const double* reference_distances) {
    const RouteMotionEntry* entry = find_entry(params.motion);
    require(entry != nullptr, "motion must be one of " + name_list() + ", got " +
                                  std::to_string(static_cast<std::int32_t>(params.motion)));
    if (entry->needs_distances) {
        require(reference_distances != nullptr,
                "the " + std::string(entry->name) + " motion model needs the references' distances along the route");
    } else {
        require(reference_distances == nullptr, "reference distances are the odometry model's input; the " +
                                                    std::string(entry->name) +
                                                    " motion model takes none (set motion to odometry)");
    }
    return entry->make(n_refs, params, reference_distances);
}

}  // namespace route_detail

const char* route_motion_name(RouteMotion motion) {
    const route_detail::RouteMotionEntry* entry = route_detail::find_entry(motion);
    route_detail::require(entry != nullptr, "motion must be one of " + route_detail::name_list() + ", got " +
                                                std::to_string(static_cast<std::int32_t>(motion)));
    return entry->name;
}

RouteMotion route_motion_from_name(const std::string& name) {
    for (const route_detail::RouteMotionEntry& entry : route_detail::kRouteMotions)
        if (name == entry.name) return entry.motion;
    throw SettingError("motion", "must be one of " + route_detail::name_list() + ", got '" + name + "'");
}

std::vector<std::string> route_motion_names() {
    std::vector<std::string> names;
    for (const route_detail::RouteMotionEntry& entry : route_detail::kRouteMotions) names.emplace_back(entry.name);
    return names;
}

bool route_motion_known(RouteMotion motion) noexcept { return route_detail::find_entry(motion) != nullptr; }

RouteMotionSpeeds route_motion_speeds(const RouteFilterParams& params) {
    const route_detail::RouteMotionEntry* entry = route_detail::find_entry(params.motion);
    route_detail::require(entry != nullptr, "motion must be one of " + route_detail::name_list() + ", got " +
                                                std::to_string(static_cast<std::int32_t>(params.motion)));
    validate(params);
    if (entry->speeds == nullptr) {
        RouteMotionSpeeds any;
        any.lowest = -std::numeric_limits<double>::infinity();
        any.highest = std::numeric_limits<double>::infinity();
        return any;
    }
    return entry->speeds(params);
}

const char* route_motion_choice(std::size_t index) noexcept {
    constexpr std::size_t count = sizeof route_detail::kRouteMotions / sizeof route_detail::kRouteMotions[0];
    return index < count ? route_detail::kRouteMotions[index].name : nullptr;
}

bool route_motion_needs_distances(RouteMotion motion) {
    const route_detail::RouteMotionEntry* entry = route_detail::find_entry(motion);
    route_detail::require(entry != nullptr, "motion must be one of " + route_detail::name_list() + ", got " +
                                                std::to_string(static_cast<std::int32_t>(motion)));
    return entry->needs_distances;
}

}  // namespace nightloc
