// A settings struct of the core as a Python class, from its table (nightloc/settings.hpp): one
// property per field (a value is checked for its kind and range when set, as the map reader sets
// it), validate(), to_dict(), fields() (the table itself, for python/nightloc/schema.py), pickling
// and repr. SettingError reaches Python as nightloc._core.SettingError, a ValueError that keeps the
// setting's name and the requirement apart.
#pragma once

#include <climits>
#include <cmath>
#include <string>
#include <utility>

#include "glue.hpp"
#include "nightloc/settings.hpp"

namespace nightloc::glue {

/// Registers nightloc._core.SettingError (a ValueError with the attributes `setting` and
/// `requirement`) and the translation of nightloc::SettingError into it. Call once, first.
void register_setting_error(py::module_& m);

namespace settings_detail {

inline double number_of(const SettingInfo& info, const py::handle& value) {
    const std::string name = info.name;
    switch (info.kind) {
        case SettingKind::flag:
            if (!py::isinstance<py::bool_>(value)) {
                throw py::type_error(name + " must be true or false, got " + std::string(py::repr(value)));
            }
            return value.cast<bool>() ? 1.0 : 0.0;
        case SettingKind::choice:
            if (!py::isinstance<py::str>(value)) {
                throw py::type_error(name + " must be a name (" + range_text(info) + "), got " +
                                     std::string(py::repr(value)));
            }
            return choice_value(info, value.cast<std::string>());
        case SettingKind::count:
        case SettingKind::integer:
            if (py::isinstance<py::int_>(value) && !py::isinstance<py::bool_>(value)) {
                int overflow = 0;
                const long long v = PyLong_AsLongLongAndOverflow(value.ptr(), &overflow);
                if (overflow != 0) {
                    throw SettingError(name, "= " + std::string(py::str(value)) + " is too " +
                                                 (overflow > 0 ? "large" : "small") + " for the core");
                }
                return static_cast<double>(v);
            }
            break;
        case SettingKind::real:
            break;
    }
    if (py::isinstance<py::bool_>(value) || !(py::isinstance<py::int_>(value) || py::isinstance<py::float_>(value))) {
        throw py::type_error(name + " must be a number, got " + std::string(py::repr(value)));
    }
    return value.cast<double>();
}

inline py::object object_of(const SettingInfo& info, double value) {
    switch (info.kind) {
        case SettingKind::flag:
            return py::bool_(value != 0.0);
        case SettingKind::choice:
            return py::str(choice_name(info, value));
        case SettingKind::count:
        case SettingKind::integer:
            return py::int_(static_cast<long long>(value));
        case SettingKind::real:
            break;
    }
    return py::float_(value);
}

inline py::object bound(double value) {
    return std::isfinite(value) ? py::object(py::float_(value)) : py::object(py::none());
}

template <class S>
py::dict describe(const SettingField<S>& field) {
    const SettingInfo& info = field.info;
    static const char* const kTypes[] = {"float", "int", "int", "bool", "str"};
    py::dict row;
    row["name"] = info.name;
    row["kind"] = setting_kind_name(info.kind);
    row["type"] = kTypes[static_cast<int>(info.kind)];
    row["default"] = object_of(info, field.default_value());
    row["unit"] = info.unit;
    row["doc"] = info.doc;
    row["range"] = range_text(info);
    const bool numeric = info.kind != SettingKind::flag && info.kind != SettingKind::choice;
    row["min"] = numeric ? bound(info.range.min) : py::object(py::none());
    row["max"] = numeric ? bound(info.range.max) : py::object(py::none());
    row["min_open"] = info.range.min_open;
    row["max_open"] = info.range.max_open;
    row["infinite"] = info.range.infinite;
    row["special"] = std::isnan(info.range.special) ? py::object(py::none()) : object_of(info, info.range.special);
    row["special_means"] = info.range.special_means;
    py::list choices;
    for (std::size_t i = 0; info.choice != nullptr && info.choice(i) != nullptr; ++i) choices.append(info.choice(i));
    row["choices"] = info.kind == SettingKind::choice ? py::object(py::tuple(choices)) : py::object(py::none());
    return row;
}

}  // namespace settings_detail

/// Binds the settings struct S as the Python class `name` (see the top of this file).
template <class S>
py::class_<S> bind_settings(py::module_& m, const char* name, const char* doc) {
    using settings_detail::number_of;
    using settings_detail::object_of;
    py::class_<S> cls(m, name, doc);
    cls.def(py::init<>());
    for (const SettingField<S>& field : setting_fields<S>()) {
        const SettingField<S>* f = &field;  // the table lives as long as the program
        cls.def_property(
            f->info.name, [f](const S& s) { return object_of(f->info, f->get(s)); },
            [f](S& s, const py::object& value) { set_setting(s, f->info.name, number_of(f->info, value)); },
            f->info.doc);
    }
    cls.def(
           "validate", [](const S& s) { validate(s); },  // S's own, found beside S (argument-dependent)
           "SettingError (a ValueError) naming the first setting out of its range, and the range.")
        .def(
            "to_dict",
            [](const S& s) {
                py::dict out;
                for (const SettingField<S>& field : setting_fields<S>())
                    out[field.info.name] = object_of(field.info, field.get(s));
                return out;
            },
            "name -> value of every setting, in the table's order.")
        .def_static(
            "fields",
            []() {
                py::list out;
                for (const SettingField<S>& field : setting_fields<S>()) out.append(settings_detail::describe(field));
                return out;
            },
            "The table: one dict per field (name, kind, type, default, unit, doc, range and its bounds).")
        .def(py::pickle(
            [](const S& s) {
                py::tuple state(setting_fields<S>().size());
                std::size_t k = 0;
                for (const SettingField<S>& field : setting_fields<S>()) state[k++] = field.get(s);
                return state;
            },
            [name](const py::tuple& state) {
                if (state.size() != setting_fields<S>().size())
                    throw py::value_error(std::string("invalid ") + name + " state");
                S s;
                std::size_t k = 0;
                for (const SettingField<S>& field : setting_fields<S>())
                    set_setting(s, field.info.name, state[k++].cast<double>());
                return s;
            }))
        .def("__repr__", [name](const S& s) {
            std::string text = std::string(name) + "(";
            const char* separator = "";
            for (const SettingField<S>& field : setting_fields<S>()) {
                text += separator + std::string(field.info.name) + "=" +
                        std::string(py::repr(object_of(field.info, field.get(s))));
                separator = ", ";
            }
            return text + ")";
        });
    return cls;
}

}  // namespace nightloc::glue
