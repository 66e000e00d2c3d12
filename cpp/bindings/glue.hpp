// Shared glue of the nightloc._core bindings (register_*.cpp): input checks that raise a Python
// exception naming the argument, the problem and the fix; shape text; shift lists; running work
// without the GIL. The documented API is python/nightloc; _core is its private engine (_core.pyi).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "nightloc/sad.hpp"

namespace py = pybind11;

namespace nightloc::glue {

/// A C-contiguous numpy array of T.
template <class T>
using CArray = py::array_t<T, py::array::c_style>;

/// numpy's name of the dtype T (for messages).
template <class T>
constexpr const char* dtype_name();
template <>
constexpr const char* dtype_name<std::uint8_t>() {
    return "uint8";
}
template <>
constexpr const char* dtype_name<std::int32_t>() {
    return "int32";
}
template <>
constexpr const char* dtype_name<float>() {
    return "float32";
}
template <>
constexpr const char* dtype_name<double>() {
    return "float64";
}

/// The shape as numpy prints it: "(3, 24, 48)", "(5,)".
inline std::string shape_text(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
    return s + (a.ndim() == 1 ? ",)" : ")");
}

inline std::string dtype_text(const py::array& a) { return std::string(py::str(a.dtype())); }

/// Whether `a` has dtype T. Equivalence, not identity: arrays rebuilt by pickle (e.g. on Dask
/// workers) carry an equal but distinct dtype object.
template <class T>
bool has_dtype(const py::array& a) {
    return py::isinstance<py::array_t<T>>(a);
}

/// `a` as a C-contiguous array of T with `ndim` dimensions, or TypeError (dtype) / ValueError
/// (rank, layout) naming `name`. `axes` (e.g. "(n_query, n_ref)") describes the expected shape.
template <class T>
CArray<T> checked_array(const py::array& a, const char* name, py::ssize_t ndim, const char* axes = nullptr) {
    if (!has_dtype<T>(a)) {
        throw py::type_error(std::string(name) + " must have dtype " + dtype_name<T>() + ", got " + dtype_text(a) +
                             " (convert with numpy.asarray(x, dtype=numpy." + dtype_name<T>() + "))");
    }
    if (a.ndim() != ndim) {
        throw py::value_error(std::string(name) + " must be " + std::to_string(ndim) + "-D" +
                              (axes ? std::string(" ") + axes : std::string()) + ", got shape " + shape_text(a));
    }
    if (!(a.flags() & py::array::c_style)) {
        throw py::value_error(std::string(name) + " must be C-contiguous (use numpy.ascontiguousarray)");
    }
    return py::reinterpret_borrow<CArray<T>>(a);
}

/// ValueError unless `a` may be written to.
inline void require_writable(const py::array& a, const char* name) {
    if (!a.writeable()) throw py::value_error(std::string(name) + " must be writable (pass a new array)");
}

/// ValueError when a stack of images holds none.
inline void require_images(const py::array& a, const char* name) {
    if (a.shape(0) == 0) throw py::value_error(std::string(name) + " is empty (no images)");
}

/// ValueError unless the images of `a` (axes a_axis, a_axis + 1) have the size of those of the
/// (n, h, w) stack `refs`.
inline void require_same_image_size(const py::array& a, py::ssize_t a_axis, const py::array& refs, const char* a_name) {
    if (a.shape(a_axis) != refs.shape(1) || a.shape(a_axis + 1) != refs.shape(2)) {
        throw py::value_error(std::string(a_name) + " images are " + std::to_string(a.shape(a_axis)) + " x " +
                              std::to_string(a.shape(a_axis + 1)) + " pixels but refs are " +
                              std::to_string(refs.shape(1)) + " x " + std::to_string(refs.shape(2)));
    }
}

/// Extent of axis `axis` as a size.
inline std::size_t extent(const py::array& a, py::ssize_t axis) { return static_cast<std::size_t>(a.shape(axis)); }

/// A copy of a 1-D int32 shift list (any strides), or TypeError. Values are checked by the core.
inline std::vector<std::int32_t> shift_list(const py::array& shifts, bool non_empty = false) {
    if (!has_dtype<std::int32_t>(shifts) || shifts.ndim() != 1 || (non_empty && shifts.size() == 0)) {
        throw py::type_error(std::string("shifts must be a ") + (non_empty ? "non-empty " : "") + "1-D int32 array");
    }
    const auto view = py::reinterpret_borrow<py::array_t<std::int32_t>>(shifts).unchecked<1>();
    std::vector<std::int32_t> out(static_cast<std::size_t>(view.shape(0)));
    for (py::ssize_t i = 0; i < view.shape(0); ++i) out[static_cast<std::size_t>(i)] = view(i);
    return out;
}

/// A translation window (columns, rows) from a pair of non-negative ints, or ValueError. Sizes
/// against the images are checked by the core.
inline nightloc::ShiftWindow shift_window(const std::pair<long long, long long>& window) {
    if (window.first < 0 || window.second < 0) {
        throw py::value_error("the shift window (columns, rows) must be two ints >= 0, got (" +
                              std::to_string(window.first) + ", " + std::to_string(window.second) + ")");
    }
    return nightloc::ShiftWindow{static_cast<std::size_t>(window.first), static_cast<std::size_t>(window.second)};
}

/// Runs work() with the GIL released and returns its result: the inputs it reads must be
/// pointers or C++ objects taken before (never Python objects). C++ exceptions propagate
/// (std::invalid_argument reaches Python as ValueError).
template <class Work>
decltype(auto) without_gil(Work&& work) {
    py::gil_scoped_release release;
    return std::forward<Work>(work)();
}

}  // namespace nightloc::glue
