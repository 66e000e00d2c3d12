// The route filter's odometry motion model (route_filter.hpp): `odometry_cells` cells per
// reference placed by the references' distances along the route; each frame every cell's mass
// moves by the distance travelled, then a position noise spreads it (odometry_spread()).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "route/route_motion.hpp"

namespace nightloc {

namespace {
constexpr std::size_t kMaxSpreadPasses = 256;
}  // namespace

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

namespace route_detail {
namespace {

class OdometryMotion final : public RouteMotionModel {
public:
    OdometryMotion(std::size_t n_refs, const RouteFilterParams& params, const double* reference_distances)
        : RouteMotionModel(n_refs, params.odometry_cells, {1.0}), params_(params) {
        require(n_refs >= 2, "the odometry model needs at least two references");
        for (std::size_t r = 0; r < n_refs; ++r) {
            require(std::isfinite(reference_distances[r]),
                    "reference distances must be finite (reference " + std::to_string(r) + ")");
            require(r == 0 || reference_distances[r] >= reference_distances[r - 1],
                    "reference distances must not decrease along the route (reference " + std::to_string(r) + ")");
        }
        const double length = reference_distances[n_refs - 1] - reference_distances[0];
        require(length > 0.0 && std::isfinite(length), "the reference distances must cover a positive, finite length");
        reference_distance_.assign(reference_distances, reference_distances + n_refs);
        spacing_ = length / static_cast<double>(n_refs - 1);
        // 1 / the gap after each reference (a gap of 0 is never divided by: the target interval
        // always ends above the target distance).
        inverse_gap_.assign(n_refs, 0.0);
        for (std::size_t r = 0; r + 1 < n_refs; ++r) {
            const double gap = reference_distance_[r + 1] - reference_distance_[r];
            if (gap > 0.0) inverse_gap_[r] = 1.0 / gap;
        }
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

    std::unique_ptr<RouteMotionModel> clone() const override { return std::make_unique<OdometryMotion>(*this); }
    RouteMotion motion() const noexcept override { return RouteMotion::kOdometry; }

    double novelty(double advance) const noexcept override {
        if (!(params_.odometry_novelty > 0.0)) return 1.0;
        return std::min(1.0, std::fabs(advance) / (params_.odometry_novelty * spacing_));
    }

    // Each cell's mass goes to the cell at its distance + advance, split linearly between the
    // two nearest cells (past either end: lost); then the position noise spreads it.
    MotionStep predict(const std::vector<double>& belief, std::vector<double>& prediction, double /*on*/,
                       double advance, int /*threads*/) override {
        const std::size_t m = n_refs_ * cells_;
        const double* b = belief.data();
        double* target = prediction.data();
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
        const double speed = mass > 0.0 ? travelled / mass : 0.0;
        const std::vector<double> taps = odometry_spread(advance, spacing_, params_);
        if (taps.size() == 1) return {sum_of(target, m), speed};
        // Spread: out[c] = sum_i taps[i] * target[c - (i - h)], into the scratch, which then
        // becomes the prediction.
        spread_scratch_.resize(prediction.size());
        double* p = spread_scratch_.data();
        std::fill(p, p + m, 0.0);
        const auto half = static_cast<std::int64_t>(taps.size() / 2);
        for (std::size_t i = 0; i < taps.size(); ++i)
            shift_add(target, p, m, static_cast<std::int64_t>(i) - half, taps[i]);
        prediction.swap(spread_scratch_);
        return {sum_of(prediction.data(), m), speed};
    }

private:
    RouteFilterParams params_;
    std::vector<double> cell_distance_;       // distance along the route of each cell
    std::vector<double> reference_distance_;  // of each reference
    std::vector<double> inverse_gap_;         // 1 / (distance to the next reference)
    double spacing_ = 1.0;                    // mean distance per reference
    std::vector<double> spread_scratch_;
};

}  // namespace

std::unique_ptr<RouteMotionModel> make_odometry_motion(std::size_t n_refs, const RouteFilterParams& params,
                                                       const double* reference_distances) {
    return std::make_unique<OdometryMotion>(n_refs, params, reference_distances);
}

}  // namespace route_detail
}  // namespace nightloc
