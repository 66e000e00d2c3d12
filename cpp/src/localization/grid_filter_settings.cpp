// Grid-filter settings by name and their ranges: the one table of names, read by the map-file
// reader and by the Python class nightloc._core.GridFilterSettings.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "nightloc/grid_filter.hpp"

namespace nightloc {

namespace {

using S = GridFilterSettings;

constexpr std::array<GridFilterSettingField, kGridFilterSettingCount> kFields{{
    {"heading_bins", nullptr, &S::heading_bins},
    {"likelihood_gain", &S::likelihood_gain, nullptr},
    {"distance_std", &S::distance_std, nullptr},
    {"heading_std", &S::heading_std, nullptr},
    {"distance_per_metre", &S::distance_per_metre, nullptr},
    {"heading_per_radian", &S::heading_per_radian, nullptr},
    {"position_floor", &S::position_floor, nullptr},
    {"heading_floor", &S::heading_floor, nullptr},
    {"uniform_floor", &S::uniform_floor, nullptr},
    {"unknown_spread", &S::unknown_spread, nullptr},
    {"credibility", &S::credibility, nullptr},
    {"confidence_radius", &S::confidence_radius, nullptr},
    {"estimate_window", nullptr, &S::estimate_window},
    {"negligible", &S::negligible, nullptr},
    {"settle_frames", nullptr, &S::settle_frames},
    {"score_cap", &S::score_cap, nullptr},
    {"lookalike_places", &S::lookalike_places, nullptr},
}};

// A number in few characters: an integer without a fraction ("5000"), otherwise the fewest
// significant digits that read back as the same double ("1.5", "0.015", "-inf").
std::string text(double value) {
    char buffer[40];
    if (std::isfinite(value) && value == std::floor(value) && std::fabs(value) < 1e15) {
        std::snprintf(buffer, sizeof buffer, "%.0f", value);
        return buffer;
    }
    for (int digits = 1; digits <= 17; ++digits) {
        std::snprintf(buffer, sizeof buffer, "%.*g", digits, value);
        if (std::strtod(buffer, nullptr) == value) break;
    }
    return buffer;
}

void require(bool ok, const char* name, const std::string& range, double value) {
    if (!ok) throw std::invalid_argument(std::string(name) + " must be " + range + ", got " + text(value));
}

bool finite_nonnegative(double v) { return std::isfinite(v) && v >= 0; }

}  // namespace

const std::array<GridFilterSettingField, kGridFilterSettingCount>& grid_filter_setting_fields() noexcept {
    return kFields;
}

void validate(const GridFilterSettings& s) {
    require(s.heading_bins <= 4096, "heading_bins", "0 (one per image column) .. 4096",
            static_cast<double>(s.heading_bins));
    require(finite_nonnegative(s.likelihood_gain), "likelihood_gain", "a finite number >= 0", s.likelihood_gain);
    require(finite_nonnegative(s.distance_std), "distance_std", "a finite number of metres >= 0", s.distance_std);
    require(finite_nonnegative(s.heading_std), "heading_std", "a finite number of radians >= 0", s.heading_std);
    require(finite_nonnegative(s.distance_per_metre), "distance_per_metre", "a finite fraction >= 0",
            s.distance_per_metre);
    require(finite_nonnegative(s.heading_per_radian), "heading_per_radian", "a finite fraction >= 0",
            s.heading_per_radian);
    require(finite_nonnegative(s.position_floor), "position_floor", "a finite number of metres >= 0", s.position_floor);
    require(finite_nonnegative(s.heading_floor), "heading_floor", "a finite number of radians >= 0", s.heading_floor);
    require(std::isfinite(s.uniform_floor) && s.uniform_floor >= 0 && s.uniform_floor < 1, "uniform_floor", "in [0, 1)",
            s.uniform_floor);
    require(finite_nonnegative(s.unknown_spread), "unknown_spread", "a finite number of metres >= 0", s.unknown_spread);
    require(std::isfinite(s.credibility) && s.credibility > 0 && s.credibility <= 1, "credibility", "in (0, 1]",
            s.credibility);
    require(finite_nonnegative(s.confidence_radius), "confidence_radius", "a finite number of metres >= 0",
            s.confidence_radius);
    require(s.estimate_window <= 1000, "estimate_window", "0..1000 cells", static_cast<double>(s.estimate_window));
    require(std::isfinite(s.negligible) && s.negligible >= 0 && s.negligible < 1, "negligible", "in [0, 1)",
            s.negligible);
    require(s.settle_frames <= 1000, "settle_frames", "0..1000 frames", static_cast<double>(s.settle_frames));
    require(finite_nonnegative(s.score_cap), "score_cap", "a finite number >= 0", s.score_cap);
    require(std::isfinite(s.lookalike_places) && (s.lookalike_places == 0 || s.lookalike_places >= 2),
            "lookalike_places", "0 (never tempered) or >= 2", s.lookalike_places);
}

void set_grid_filter_setting(GridFilterSettings& s, const std::string& name, double value) {
    for (const GridFilterSettingField& field : kFields) {
        if (name != field.name) continue;
        if (!std::isfinite(value)) throw std::invalid_argument("grid filter setting '" + name + "' must be finite");
        if (field.real != nullptr) {
            s.*field.real = value;
        } else {
            if (!(value >= 0) || value != std::floor(value) || value > 1e15) {
                throw std::invalid_argument("grid filter setting '" + name + "' must be a non-negative integer, got " +
                                            text(value));
            }
            s.*field.count = static_cast<std::size_t>(value);
        }
        return;
    }
    throw std::invalid_argument("unknown grid filter setting '" + name + "'");
}

double grid_filter_setting(const GridFilterSettings& s, const GridFilterSettingField& field) noexcept {
    return field.real != nullptr ? s.*field.real : static_cast<double>(s.*field.count);
}

}  // namespace nightloc
