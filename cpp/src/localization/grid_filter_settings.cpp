// The grid filter's settings table (nightloc/settings.hpp): the one list of GridFilterSettings'
// fields, with their units, ranges and docs; read by validate(), the map-file reader and the
// Python class nightloc._core.GridFilterSettings (and through it nightloc.FilterParams).
#include "nightloc/grid_filter.hpp"

namespace nightloc {

namespace {

using S = GridFilterSettings;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNone = std::numeric_limits<double>::quiet_NaN();

// [0, inf) finite
constexpr SettingRange kNonNegative{0.0, kInf, false, false, false, kNone, ""};
// [0, 1)
constexpr SettingRange kShare{0.0, 1.0, false, true, false, kNone, ""};

std::vector<SettingField<S>> make_fields() {
    using K = SettingKind;
    return {
        setting<&S::heading_bins>({"heading_bins", K::count, "", "heading bins B (1: position only)",
                                   SettingRange{0, 4096, false, false, false, 0, "one per image column"}}),
        setting<&S::likelihood_gain>({"likelihood_gain", K::real, "",
                                      "kappa: lambda = kappa / (median - min) of the frame's minimum scores",
                                      kNonNegative}),
        setting<&S::distance_std>({"distance_std", K::real, "m", "odometry noise per step", kNonNegative}),
        setting<&S::heading_std>({"heading_std", K::real, "rad", "odometry heading noise per step", kNonNegative}),
        setting<&S::distance_per_metre>({"distance_per_metre", K::real, "",
                                         "robot-frame odometry: distance noise per metre of the step (in quadrature)",
                                         kNonNegative}),
        setting<&S::heading_per_radian>({"heading_per_radian", K::real, "",
                                         "robot-frame odometry: heading noise per radian turned (in quadrature)",
                                         kNonNegative}),
        setting<&S::position_floor>({"position_floor", K::real, "m",
                                     "blur per prediction added in quadrature (grid and model error)", kNonNegative}),
        setting<&S::heading_floor>(
            {"heading_floor", K::real, "rad", "heading blur per prediction added in quadrature", kNonNegative}),
        setting<&S::uniform_floor>({"uniform_floor", K::real, "",
                                    "share of the belief spread uniformly at each prediction (a kidnapped robot is "
                                    "found again)",
                                    kShare}),
        setting<&S::unknown_spread>({"unknown_spread", K::real, "m", "blur when the motion is unknown", kNonNegative}),
        setting<&S::credibility>({"credibility", K::real, "", "mass of the disk reported as credible_radius",
                                  SettingRange{0.0, 1.0, true, false, false, kNone, ""}}),
        setting<&S::confidence_radius>({"confidence_radius", K::real, "m",
                                        "confidence = the belief's mass within this of the estimate", kNonNegative}),
        setting<&S::estimate_window>({"estimate_window", K::count, "cells",
                                      "cells on each side of the peak averaged into the estimate",
                                      SettingRange{0, 1000, false, false, false, kNone, ""}}),
        setting<&S::negligible>({"negligible", K::real, "",
                                 "a heading bin below this share of the belief's largest value moves without the "
                                 "position blur (0: every bin is blurred)",
                                 kShare}),
        setting<&S::settle_frames>({"settle_frames", K::count, "frames",
                                    "frame k after a reset weighs (k + 1) / settle_frames of the likelihood gain (0 or "
                                    "1: no tempering)",
                                    SettingRange{0, 1000, false, false, false, kNone, ""}}),
        setting<&S::score_cap>({"score_cap", K::real, "",
                                "scores above s_min + score_cap (median - min) count as that (0: no cap)",
                                kNonNegative}),
        setting<&S::lookalike_places>({"lookalike_places", K::real, "",
                                       "a map of P places, more than this, caps at score_cap ln(lookalike_places) / "
                                       "ln(P)",
                                       SettingRange{2.0, kInf, false, false, false, 0, "never tempered"}}),
    };
}

}  // namespace

template <>
const std::vector<SettingField<GridFilterSettings>>& setting_fields<GridFilterSettings>() {
    static const std::vector<SettingField<GridFilterSettings>> fields = make_fields();
    return fields;
}

// Every field of GridFilterSettings (eight bytes each) has its row.
static_assert(sizeof(std::size_t) != 8 || sizeof(GridFilterSettings) == 17 * 8,
              "a field of GridFilterSettings was added or removed: change its row in make_fields() and this count");

void validate(const GridFilterSettings& settings) { check_ranges(settings); }

}  // namespace nightloc
