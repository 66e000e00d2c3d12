// Grid-filter settings by name: one list of the names Python's GridFilter passes, shared by the
// Python module and the map-file reader.
#include <cmath>
#include <stdexcept>
#include <string>

#include "nightloc/grid_filter.hpp"

namespace nightloc {

namespace {

std::size_t count_of(const std::string& name, double value) {
    if (!(value >= 0) || value != std::floor(value) || value > 1e15) {
        throw std::invalid_argument("grid filter setting '" + name + "' must be a non-negative integer, got " +
                                    std::to_string(value));
    }
    return static_cast<std::size_t>(value);
}

}  // namespace

void set_grid_filter_setting(GridFilterSettings& s, const std::string& name, double value) {
    if (!std::isfinite(value)) throw std::invalid_argument("grid filter setting '" + name + "' must be finite");
    if (name == "heading_bins")
        s.heading_bins = count_of(name, value);
    else if (name == "likelihood_gain")
        s.likelihood_gain = value;
    else if (name == "distance_std")
        s.distance_std = value;
    else if (name == "heading_std")
        s.heading_std = value;
    else if (name == "distance_per_metre")
        s.distance_per_metre = value;
    else if (name == "heading_per_radian")
        s.heading_per_radian = value;
    else if (name == "position_floor")
        s.position_floor = value;
    else if (name == "heading_floor")
        s.heading_floor = value;
    else if (name == "uniform_floor")
        s.uniform_floor = value;
    else if (name == "unknown_spread")
        s.unknown_spread = value;
    else if (name == "credibility")
        s.credibility = value;
    else if (name == "confidence_radius")
        s.confidence_radius = value;
    else if (name == "estimate_window")
        s.estimate_window = count_of(name, value);
    else if (name == "negligible")
        s.negligible = value;
    else if (name == "settle_frames")
        s.settle_frames = count_of(name, value);
    else if (name == "score_cap")
        s.score_cap = value;
    else if (name == "lookalike_places")
        s.lookalike_places = value;
    else
        throw std::invalid_argument("unknown grid filter setting '" + name + "'");
}

}  // namespace nightloc
