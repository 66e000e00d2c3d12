// nightloc._core: the compiled engine of the Python package (private; the documented API is
// python/nightloc, the stubs are _core.pyi). Each register_*.cpp binds the part of the C++ core
// one Python subpackage uses; glue.hpp holds their shared input checks.
#include "glue.hpp"
#include "settings_glue.hpp"

void register_preparation(py::module_& m);   // register_preparation.cpp: nightloc.preparation
void register_matching(py::module_& m);      // register_matching.cpp: nightloc.matching
void register_localization(py::module_& m);  // register_localization.cpp: nightloc.localization
void register_route(py::module_& m);         // register_route.cpp: nightloc.route
void register_mapping(py::module_& m);       // register_mapping.cpp: nightloc.mapping

void nightloc::glue::register_setting_error(py::module_& m) {
    // One reference kept for the translator, never released (the module lives as long as Python).
    static PyObject* const kType = py::exception<nightloc::SettingError>(m, "SettingError", PyExc_ValueError).ptr();
    Py_INCREF(kType);
    py::register_exception_translator([](std::exception_ptr error) {
        try {
            if (error) std::rethrow_exception(error);
        } catch (const nightloc::SettingError& e) {
            py::object instance = py::reinterpret_borrow<py::object>(kType)(e.what());
            instance.attr("setting") = e.setting();
            instance.attr("requirement") = e.requirement();
            PyErr_SetObject(kType, instance.ptr());
        }
    });
}

PYBIND11_MODULE(_core, m) {
    m.doc() =
        "nightloc's compiled core: preparation, rotation-invariant SAD, heat maps, route mode (private; use nightloc)";
    m.attr("__version__") = NIGHTLOC_VERSION;   // the project's version, from the build (pyproject.toml)
    nightloc::glue::register_setting_error(m);  // first: every register_* may raise it
    register_preparation(m);
    register_matching(m);
    register_localization(m);
    register_route(m);
    register_mapping(m);
}
