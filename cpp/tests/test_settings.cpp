// The settings schema (nightloc/settings.hpp): every table names each field once, reads and
// writes its own member, holds its struct's defaults inside their ranges; ranges are worded and
// checked as written by hand here; SettingError keeps the setting and the requirement apart.
#include <cmath>
#include <set>
#include <string>

#include "check.hpp"
#include "nightloc/grid_filter.hpp"
#include "nightloc/prepare.hpp"
#include "nightloc/route_filter.hpp"
#include "nightloc/seqslam.hpp"
#include "nightloc/settings.hpp"

namespace {

using nightloc::SettingError;
using nightloc::SettingInfo;
using nightloc::SettingKind;
using nightloc::SettingRange;

std::string message(const SettingError& error) { return error.what(); }

template <class S>
void check_table(std::size_t expected_fields) {
    const auto& fields = nightloc::setting_fields<S>();
    CHECK(fields.size() == expected_fields);
    std::set<std::string> names;
    for (const auto& field : fields) {
        CHECK(names.insert(field.info.name).second);  // each name once
        CHECK(field.info.doc[0] != '\0');
        // the default is inside its own range
        CHECK(nightloc::in_range(field.info, field.default_value()));
    }
    // each field writes its own member: a value distinct per field reads back from that field only
    for (std::size_t k = 0; k < fields.size(); ++k) {
        S s;
        const auto& field = fields[k];
        const double before = field.get(s);
        double other = before;
        switch (field.info.kind) {
            case SettingKind::flag:
                other = before == 0 ? 1 : 0;
                break;
            case SettingKind::choice:
                other = before == 0 ? 1 : 0;
                break;
            default: {
                const double r_max = field.info.range.max, r_min = field.info.range.min;
                const double candidates[] = {before + 1, before - 1, std::floor((before + r_max) / 2),
                                             (before + r_max) / 2, (before + r_min) / 2};
                for (const double candidate : candidates) {
                    if (candidate != before && std::isfinite(candidate) && nightloc::in_range(field.info, candidate) &&
                        (field.info.kind == SettingKind::real || candidate == std::floor(candidate))) {
                        other = candidate;
                        break;
                    }
                }
                break;
            }
        }
        CHECK(other != before);
        nightloc::set_setting(s, field.info.name, other);
        for (std::size_t j = 0; j < fields.size(); ++j) {
            CHECK(fields[j].get(s) == (j == k ? other : fields[j].default_value()));
        }
    }
}

void test_tables() {
    check_table<nightloc::GridFilterSettings>(17);
    check_table<nightloc::PrepareSettings>(11);
    check_table<nightloc::RouteFilterParams>(21);
    check_table<nightloc::TrajectoryParams>(5);
    // defaults come from the struct itself
    CHECK(nightloc::find_setting<nightloc::GridFilterSettings>("uniform_floor")->default_value() ==
          nightloc::GridFilterSettings{}.uniform_floor);
    CHECK(nightloc::TrajectoryParams{}.vmin == nightloc::RouteFilterParams{}.vmin);
    CHECK(nightloc::find_setting<nightloc::GridFilterSettings>("no_such") == nullptr);
}

const char* two_names(std::size_t i) noexcept { return i == 0 ? "a" : i == 1 ? "b" : nullptr; }

void test_range_words() {
    const double inf = INFINITY, none = NAN;
    const SettingInfo share{"x", SettingKind::real, "", "d", SettingRange{0, 1, false, true, false, none, ""}};
    CHECK(nightloc::range_text(share) == "in [0, 1)");
    const SettingInfo metres{"x", SettingKind::real, "m", "d", SettingRange{0, inf, false, false, false, none, ""}};
    CHECK(nightloc::range_text(metres) == "a finite number >= 0 m");
    const SettingInfo tau{"x", SettingKind::real, "frames", "d", SettingRange{0, inf, true, false, true, none, ""}};
    CHECK(nightloc::range_text(tau) == "a number > 0 frames (inf allowed)");
    CHECK(nightloc::in_range(tau, inf) && !nightloc::in_range(tau, -inf) && !nightloc::in_range(tau, 0));
    const SettingInfo bins{"x", SettingKind::count, "", "d", SettingRange{0, 4096, false, false, false, 0, "auto"}};
    CHECK(nightloc::range_text(bins) == "an integer in [0, 4096] (0: auto)");
    const SettingInfo places{"x", SettingKind::real, "", "d", SettingRange{2, inf, false, false, false, 0, "off"}};
    CHECK(nightloc::range_text(places) == "0 (off) or a finite number >= 2");
    CHECK(nightloc::in_range(places, 0) && !nightloc::in_range(places, 1) && nightloc::in_range(places, 2.5));
    const SettingInfo any{"x", SettingKind::real, "", "d", SettingRange{-inf, inf, true, false, true, none, ""}};
    CHECK(nightloc::range_text(any) == "a number (inf allowed)");
    CHECK(!nightloc::in_range(any, -inf) && !nightloc::in_range(any, NAN) && nightloc::in_range(any, inf));
    const SettingInfo pick{"x", SettingKind::choice, "", "d", SettingRange{}, &two_names};
    CHECK(nightloc::range_text(pick) == "one of 'a', 'b'");
    CHECK(nightloc::choice_value(pick, "b") == 1 && nightloc::choice_name(pick, 0) == "a");
    CHECK(nightloc::choice_name(pick, 2).empty());
    CHECK(nightloc::range_text({"x", SettingKind::flag, "", "d"}) == "true or false");
    CHECK(nightloc::setting_value_text(0.015) == "0.015" && nightloc::setting_value_text(5000) == "5000" &&
          nightloc::setting_value_text(-inf) == "-inf");
}

void test_errors_name_the_setting() {
    nightloc::GridFilterSettings s;
    s.uniform_floor = 1.5;
    try {
        nightloc::validate(s);
        CHECK(false);
    } catch (const SettingError& error) {
        CHECK(message(error) == "uniform_floor must be in [0, 1), got 1.5");
        CHECK(error.setting() == "uniform_floor" && error.requirement() == "must be in [0, 1), got 1.5");
    }
    nightloc::RouteFilterParams p;
    p.vmax = 0.5;
    try {
        nightloc::validate(p);
        CHECK(false);
    } catch (const SettingError& error) {
        CHECK(error.setting() == "vmax" && message(error) == "vmax must be >= vmin (0.8), got 0.5");
    }
    try {
        nightloc::set_setting(p, "speed_cells", 2.5);
        CHECK(false);
    } catch (const SettingError& error) {
        CHECK(message(error) == "speed_cells must be a non-negative integer, got 2.5");
    }
    try {
        nightloc::route_motion_from_name("teleport");
        CHECK(false);
    } catch (const SettingError& error) {
        CHECK(message(error) == "motion must be one of 'window', 'speed', 'odometry', got 'teleport'");
    }
    nightloc::PrepareSettings prepare;
    CHECK_THROWS(nightloc::set_setting(prepare, "radius", 3e9), SettingError);  // beyond an int
    CHECK_THROWS(nightloc::set_setting(prepare, "equalize", 7), SettingError);
    CHECK_THROWS(nightloc::set_setting(prepare, "wrap", 0.5), SettingError);
    nightloc::set_setting(
        prepare, "equalize",
        nightloc::choice_value(nightloc::find_setting<nightloc::PrepareSettings>("equalize")->info, "none"));
    CHECK(prepare.equalize == nightloc::Equalization::none);
    nightloc::TrajectoryParams t;
    t.vmin = 0;
    CHECK_THROWS(nightloc::make_trajectory_plan(t), SettingError);  // SeqSLAM needs a speed > 0
}

}  // namespace

int main() {
    test_tables();
    test_range_words();
    test_errors_name_the_setting();
    return nightloc_test::check_summary();
}
