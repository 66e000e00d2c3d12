// The settings schema: every settings struct of the core (GridFilterSettings, PrepareSettings,
// RouteFilterParams, TrajectoryParams) publishes one table of its fields -- name, kind, unit,
// range and a one-line doc -- with a way to read and write each field as a number. From it:
// validate() checks the ranges and words the errors (SettingError names the setting), the map
// reader and the Python bindings set fields by name, and the Python dataclasses, the TOML reader,
// the `--set` option and the docs' tables take their defaults, ranges, units and docs
// (python/nightloc/schema.py). A field's default is its default member initializer: the one place
// it is written (SettingField::get on a default-constructed struct reads it).
//
//   for (const auto& field : nightloc::setting_fields<nightloc::GridFilterSettings>())
//       std::printf("%s = %s (%s): %s\n", field.info.name, nightloc::setting_value_text(field.default_value()).c_str(),
//                   nightloc::range_text(field.info).c_str(), field.info.doc);
//   nightloc::set_setting(settings, "uniform_floor", 0.05);  // throws SettingError out of range
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace nightloc {

/// What a setting holds.
enum class SettingKind : int {
    real = 0,     ///< a double
    count = 1,    ///< a non-negative integer (std::size_t)
    integer = 2,  ///< an int
    flag = 3,     ///< a bool
    choice = 4,   ///< an enum, named by SettingInfo::choice (its value is the index of its name)
};

/// The name of a kind: "real", "count", "integer", "flag", "choice".
const char* setting_kind_name(SettingKind kind) noexcept;

/// The values a real, count or integer setting takes: min .. max (each end open or closed; an
/// infinite end: no bound), finite unless `infinite` (then +inf too), and `special` (NaN: none),
/// a value allowed outside the range whose meaning `special_means` says.
struct SettingRange {
    double min = -std::numeric_limits<double>::infinity();
    double max = std::numeric_limits<double>::infinity();
    bool min_open = false;
    bool max_open = false;
    bool infinite = false;
    double special = std::numeric_limits<double>::quiet_NaN();
    const char* special_means = "";
};

/// One setting's description (the table's row).
struct SettingInfo {
    const char* name;  ///< the field's name (the TOML key, the Python attribute, the map file's key)
    SettingKind kind;
    const char* unit;  ///< "m", "rad", "frames", ...; "" for a pure number
    const char* doc;   ///< one line
    SettingRange range{};
    /// choice: the name of value `index`, nullptr past the last (the names' one table)
    const char* (*choice)(std::size_t index) noexcept = nullptr;
};

/// One field of the settings struct S: its description, and its value as a double (a choice: its
/// index; a flag: 0 or 1), read and written.
template <class S>
struct SettingField {
    SettingInfo info;
    double (*get)(const S&) noexcept;
    void (*put)(S&, double) noexcept;
    double lowest;   ///< the smallest value the member's C++ type holds
    double highest;  ///< the largest

    /// The default: the field of a default-constructed S.
    double default_value() const noexcept { return get(S{}); }
};

/// A setting out of its range. what() is "<setting> <requirement>", e.g. "uniform_floor must be in
/// [0, 1), got 1.5"; the parts apart let a caller name the setting its own way (Python's
/// RouteParams calls `sharpness` `filter_sharpness`).
class SettingError : public std::invalid_argument {
public:
    SettingError(const std::string& setting, const std::string& requirement);
    const std::string& setting() const noexcept { return setting_; }
    const std::string& requirement() const noexcept { return requirement_; }

private:
    std::string setting_, requirement_;
};

/// A number in few characters: an integer without a fraction ("5000"), otherwise the fewest
/// significant digits that read back as the same double ("1.5", "0.015", "inf", "nan").
std::string setting_value_text(double value);

/// The range in words, as errors and the docs say it: "in [0, 1)", "a finite number >= 0 m",
/// "an integer in [1, 64]", "in [0, 4096] (0: one per image column)", "one of 'none', 'global',
/// 'clahe'", "true or false".
std::string range_text(const SettingInfo& info);

/// Whether `value` (the setting's number) lies in its range (flags and choices: a valid value).
bool in_range(const SettingInfo& info, double value) noexcept;

/// Throws SettingError("<name>", "must be <range_text>, got <value>") unless in_range.
void check_range(const SettingInfo& info, double value);

/// The value of a choice named `name`; throws SettingError naming the choices.
double choice_value(const SettingInfo& info, const std::string& name);

/// The name of a choice's value, or "" when it names none.
std::string choice_name(const SettingInfo& info, double value);

/// Throws SettingError unless `value` fits the kind and the member's type: finite (a real may be
/// infinite when its range allows it), a count a non-negative integer, an integer an integer, a
/// flag 0 or 1, a choice the index of a name. The range is check_range's.
template <class S>
void check_kind(const SettingField<S>& field, double value);

/// The table of S (specialized beside each settings struct: grid_filter.hpp, prepare.hpp,
/// route_filter.hpp, seqslam.hpp).
template <class S>
const std::vector<SettingField<S>>& setting_fields();

/// The field of S called `name`, or nullptr.
template <class S>
const SettingField<S>* find_setting(const std::string& name) {
    for (const SettingField<S>& field : setting_fields<S>())
        if (name == field.info.name) return &field;
    return nullptr;
}

/// Sets the field `name` of `settings` to `value` (check_kind, then check_range). Throws
/// SettingError for an unknown name (listing none: "unknown setting 'x'"), a value of the wrong
/// kind or out of range; `settings` is unchanged then.
template <class S>
void set_setting(S& settings, const std::string& name, double value) {
    const SettingField<S>* field = find_setting<S>(name);
    if (field == nullptr) throw SettingError(name, "is not a setting (unknown name)");
    check_kind(*field, value);
    check_range(field->info, value);
    field->put(settings, value);
}

/// Checks every field of `settings` against its range (the table's order: the first out of range
/// throws SettingError).
template <class S>
void check_ranges(const S& settings) {
    for (const SettingField<S>& field : setting_fields<S>()) check_range(field.info, field.get(settings));
}

// ---- building a table: nightloc::setting<&S::member>(info) ---------------------------------

namespace detail {
template <class>
struct MemberOf;
template <class S, class T>
struct MemberOf<T S::*> {
    using owner = S;
    using type = T;
};

template <auto Member>
double get_member(const typename MemberOf<decltype(Member)>::owner& s) noexcept {
    using T = typename MemberOf<decltype(Member)>::type;
    if constexpr (std::is_enum_v<T>) {
        return static_cast<double>(static_cast<std::underlying_type_t<T>>(s.*Member));
    } else {
        return static_cast<double>(s.*Member);
    }
}

template <auto Member>
void put_member(typename MemberOf<decltype(Member)>::owner& s, double value) noexcept {
    using T = typename MemberOf<decltype(Member)>::type;
    if constexpr (std::is_same_v<T, bool>) {
        s.*Member = value != 0.0;
    } else if constexpr (std::is_enum_v<T>) {
        s.*Member = static_cast<T>(static_cast<std::underlying_type_t<T>>(value));
    } else {
        s.*Member = static_cast<T>(value);
    }
}

template <class T>
constexpr double lowest_of() noexcept {
    if constexpr (std::is_same_v<T, bool> || std::is_enum_v<T>) {
        return 0.0;
    } else {
        return static_cast<double>(std::numeric_limits<T>::lowest());
    }
}

// Integers above 2^53 are not all doubles: a count or integer setting stops there.
inline constexpr double kLargestExactInteger = 9007199254740992.0;

template <class T>
constexpr double highest_of() noexcept {
    if constexpr (std::is_same_v<T, bool>) {
        return 1.0;
    } else if constexpr (std::is_enum_v<T>) {
        return static_cast<double>(std::numeric_limits<std::underlying_type_t<T>>::max());
    } else if constexpr (std::is_integral_v<T>) {
        constexpr double largest = static_cast<double>(std::numeric_limits<T>::max());
        return largest < kLargestExactInteger ? largest : kLargestExactInteger;
    } else {
        return std::numeric_limits<T>::max();
    }
}

[[noreturn]] void throw_kind_error(const SettingInfo& info, double value, double lowest, double highest);
bool fits_kind(const SettingInfo& info, double value, double lowest, double highest) noexcept;
}  // namespace detail

/// A table row for `Member` (a pointer to a member of the settings struct) with its description.
template <auto Member>
SettingField<typename detail::MemberOf<decltype(Member)>::owner> setting(SettingInfo info) {
    using T = typename detail::MemberOf<decltype(Member)>::type;
    return {info, &detail::get_member<Member>, &detail::put_member<Member>, detail::lowest_of<T>(),
            detail::highest_of<T>()};
}

template <class S>
void check_kind(const SettingField<S>& field, double value) {
    if (!detail::fits_kind(field.info, value, field.lowest, field.highest)) {
        detail::throw_kind_error(field.info, value, field.lowest, field.highest);
    }
}

}  // namespace nightloc
