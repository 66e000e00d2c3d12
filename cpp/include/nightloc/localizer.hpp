// The default localizer of nightloc for firmware: Python's `nightloc.Localizer(ref_map)` (the grid
// Bayes filter with the settings the map file carries) over a map file, without Python.
//
//   const nightloc::MapFile map = nightloc::load_map_file("garden.map");   // nightloc/map_file.hpp
//   nightloc::Localizer localizer(map);
//   per frame (an 8-bit camera frame and the wheel odometry since the previous frame):
//     const nightloc::LocalizerEstimate e =
//         localizer.update({pixels, rows, cols, stride, nightloc::PixelOrder::rgb},
//                          nightloc::Motion::robot(forward, left, turn));
//
// Per frame, as python/nightloc/localization/localizer.py: the frame is prepared with the map's
// parameters (nightloc::prepare_frame; a grey frame of exactly the prepared size is taken as
// already prepared), the filter predicts by the motion (ignored on the first frame after the start
// or reset()), matches the prepared frame against every reference at every column shift and
// updates (nightloc::GridFilter), and the estimate adds the closest reference (the one nearest to
// the estimate's cell, the best-scoring where several share a place) and, while the belief is
// position-only, the heading of that reference turned by its best shift. No allocation per frame
// after the first.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "nightloc/grid_filter.hpp"
#include "nightloc/map_file.hpp"
#include "nightloc/prepare.hpp"

namespace nightloc {

/// Odometry since the previous frame (python: RobotMotion, MapDisplacement, None).
struct Motion {
    enum class Kind { unknown, map, robot };
    Kind kind = Kind::unknown;
    double a = 0, b = 0, c = 0;  ///< robot: forward, left (metres), turn (radians ccw); map: dx, dy

    static Motion robot(double forward, double left, double turn) { return {Kind::robot, forward, left, turn}; }
    static Motion map(double dx, double dy) { return {Kind::map, dx, dy, 0.0}; }
    static Motion unknown() { return {}; }
};

/// An odometry noise model (python: nightloc.NoiseModel): per step, and per metre of a
/// robot-frame step and per radian of its turn (in quadrature).
struct OdometryNoise {
    double distance_std = 0, heading_std = 0, distance_per_metre = 0, heading_per_radian = 0;
};

/// The noise assumed for a log of wheel odometry (python:
/// nightloc.localization.odometry.WHEEL_ODOMETRY_NOISE): 4 % of each step's length, 0.02 rad per step.
constexpr OdometryNoise kWheelOdometryNoise{0.0, 0.02, 0.04, 0.0};

/// One update's answer (python: nightloc.Estimate of the filter).
struct LocalizerEstimate {
    double x = 0, y = 0;                        ///< metres in the map frame
    double heading = 0;                         ///< radians in (-pi, pi]; NaN when the map has no headings
    double confidence = 0;                      ///< belief within confidence_radius of (x, y), 0..1
    double credible_radius = 0;                 ///< metres holding `credibility` of the belief
    double cov_xx = 0, cov_xy = 0, cov_yy = 0;  ///< m^2
    std::size_t ref_index = 0;                  ///< the reference closest to the estimate
    std::size_t frames = 0;                     ///< frames since the start (or reset())
    std::size_t best_ref = 0;                   ///< the frame's best match (lowest score)
    float score = 0;                            ///< its score
};

class Localizer {
public:
    /// Keeps a copy of what it needs of `map` (the interpolation weights are shared). Throws
    /// MapFileError when the core cannot prepare frames for the map (CLAHE), and
    /// std::invalid_argument for inconsistent tables.
    explicit Localizer(const MapFile& map);

    /// Localizes one 8-bit camera frame. Throws std::invalid_argument (the state unchanged) for
    /// a frame of another size than the map's frames (when the map records it), one the core
    /// cannot prepare, or robot-frame odometry against a map without headings.
    LocalizerEstimate update(const FrameView& frame, const Motion& motion);
    /// The same from an already prepared image (height x width of the map's images).
    LocalizerEstimate update_prepared(const std::uint8_t* prepared, const Motion& motion);

    /// Forgets everything seen: a uniform belief, the next motion ignored.
    void reset();

    /// Replaces the filter's odometry noise (GridFilter::set_noise; the map file carries Table III
    /// model 1, a log of wheel odometry takes kWheelOdometryNoise as `nightloc localize` does).
    void set_noise(const OdometryNoise& noise) {
        filter_.set_noise(noise.distance_std, noise.heading_std, noise.distance_per_metre, noise.heading_per_radian);
    }

    const GridFilter& filter() const noexcept { return filter_; }

private:
    std::size_t closest_ref(std::size_t cell) const;

    MapFile map_;
    GridFilter filter_;
    std::vector<std::size_t> place_start_, place_members_;  // references of each place, ascending
    PrepareWorkspace workspace_;
    std::vector<std::uint8_t> query_;
    std::size_t frames_ = 0;
    PrepareSettings prepare_;
    std::size_t prepare_for_height_ = 0, prepare_for_width_ = 0;
};

/// Angles to (-pi, pi] exactly as Python's `math.pi - (math.pi - a) % (2 * math.pi)`.
double wrap_angle(double angle) noexcept;

}  // namespace nightloc
