// The settings schema's shared parts (nightloc/settings.hpp): range checks and their wording.
#include "nightloc/settings.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace nightloc {

SettingError::SettingError(const std::string& setting, const std::string& requirement)
    : std::invalid_argument(setting + " " + requirement), setting_(setting), requirement_(requirement) {}

const char* setting_kind_name(SettingKind kind) noexcept {
    switch (kind) {
        case SettingKind::real:
            return "real";
        case SettingKind::count:
            return "count";
        case SettingKind::integer:
            return "integer";
        case SettingKind::flag:
            return "flag";
        case SettingKind::choice:
            return "choice";
    }
    return "unknown";
}

std::string setting_value_text(double value) {
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

namespace {

bool integral(double value) noexcept { return std::isfinite(value) && value == std::floor(value); }

std::string choices_text(const SettingInfo& info) {
    std::string text = "one of ";
    for (std::size_t i = 0; info.choice != nullptr && info.choice(i) != nullptr; ++i) {
        text += (i ? ", '" : "'") + std::string(info.choice(i)) + "'";
    }
    return text;
}

bool in_numeric_range(const SettingRange& r, double value) noexcept {
    if (std::isnan(value)) return false;
    if (std::isinf(value) && !(r.infinite && value > 0)) return false;
    const bool above = r.min_open ? value > r.min : value >= r.min;
    const bool below = r.max_open ? value < r.max : value <= r.max;
    return above && below;
}

}  // namespace

std::string range_text(const SettingInfo& info) {
    if (info.kind == SettingKind::flag) return "true or false";
    if (info.kind == SettingKind::choice) return choices_text(info);
    const SettingRange& r = info.range;
    const bool low = std::isfinite(r.min), high = std::isfinite(r.max);
    std::string body;
    if (low && high) {
        body = std::string("in ") + (r.min_open ? "(" : "[") + setting_value_text(r.min) + ", " +
               setting_value_text(r.max) + (r.max_open ? ")" : "]");
    } else if (low) {
        body = (r.min_open ? "> " : ">= ") + setting_value_text(r.min);
    } else if (high) {
        body = (r.max_open ? "< " : "<= ") + setting_value_text(r.max);
    }
    std::string text;
    if (info.kind == SettingKind::real) {
        text = low && high
                   ? body
                   : std::string(r.infinite ? "a number" : "a finite number") + (body.empty() ? "" : " ") + body;
    } else {
        text = "an integer" + (body.empty() ? std::string() : " " + body);
    }
    if (info.unit[0] != '\0') text += std::string(" ") + info.unit;
    if (r.infinite) text += " (inf allowed)";
    if (!std::isnan(r.special)) {
        const std::string special = setting_value_text(r.special);
        if (in_numeric_range(r, r.special)) {
            text += " (" + special + ": " + r.special_means + ")";
        } else {
            text = special + " (" + r.special_means + ") or " + text;
        }
    }
    return text;
}

std::string choice_name(const SettingInfo& info, double value) {
    if (info.choice == nullptr || !integral(value) || value < 0) return "";
    for (std::size_t i = 0; info.choice(i) != nullptr; ++i) {
        if (static_cast<double>(i) == value) return info.choice(i);
    }
    return "";
}

double choice_value(const SettingInfo& info, const std::string& name) {
    for (std::size_t i = 0; info.choice != nullptr && info.choice(i) != nullptr; ++i) {
        if (name == info.choice(i)) return static_cast<double>(i);
    }
    throw SettingError(info.name, "must be " + choices_text(info) + ", got '" + name + "'");
}

bool in_range(const SettingInfo& info, double value) noexcept {
    switch (info.kind) {
        case SettingKind::flag:
            return value == 0.0 || value == 1.0;
        case SettingKind::choice:
            for (std::size_t i = 0; info.choice != nullptr && info.choice(i) != nullptr; ++i) {
                if (static_cast<double>(i) == value) return true;
            }
            return false;
        default:
            break;
    }
    if (!std::isnan(info.range.special) && value == info.range.special) return true;
    return in_numeric_range(info.range, value);
}

void check_range(const SettingInfo& info, double value) {
    if (in_range(info, value)) return;
    const std::string got = info.kind == SettingKind::flag     ? setting_value_text(value)
                            : info.kind == SettingKind::choice ? "value " + setting_value_text(value)
                                                               : setting_value_text(value);
    throw SettingError(info.name, "must be " + range_text(info) + ", got " + got);
}

namespace detail {

bool fits_kind(const SettingInfo& info, double value, double lowest, double highest) noexcept {
    switch (info.kind) {
        case SettingKind::real:
            return true;  // NaN and infinities: the range's
        case SettingKind::count:
        case SettingKind::integer:
            return integral(value) && value >= lowest && value <= highest;
        case SettingKind::flag:
            return value == 0.0 || value == 1.0;
        case SettingKind::choice:
            return in_range(info, value);
    }
    return false;
}

void throw_kind_error(const SettingInfo& info, double value, double lowest, double highest) {
    const std::string got = setting_value_text(value);
    switch (info.kind) {
        case SettingKind::count:
        case SettingKind::integer:
            if (integral(value) && value > highest) {
                throw SettingError(info.name, "= " + got + " is too large for the core");
            }
            if (integral(value) && value < lowest) {
                throw SettingError(info.name, info.kind == SettingKind::count
                                                  ? "must be a non-negative integer, got " + got
                                                  : "= " + got + " is too small for the core");
            }
            throw SettingError(info.name, std::string("must be ") +
                                              (info.kind == SettingKind::count ? "a non-negative " : "an ") +
                                              "integer, got " + got);
        case SettingKind::flag:
            throw SettingError(info.name, "must be true or false, got " + got);
        default:
            check_range(info, value);
            throw SettingError(info.name, "has the wrong kind of value: " + got);
    }
}

}  // namespace detail

}  // namespace nightloc
