// pybind11 glue for nightloc._core: checks every input (dtype, rank, contiguity, sizes) and
// releases the GIL around the work. The friendly, documented API is python/nightloc; this module
// is its private engine (see _core.pyi).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <string>
#include <vector>

#include "nightloc/normalize.hpp"
#include "nightloc/sad.hpp"
#include "nightloc/simd.hpp"

namespace py = pybind11;

namespace {

using U8Array = py::array_t<std::uint8_t, py::array::c_style>;

std::string shape_text(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
    return s + (a.ndim() == 1 ? ",)" : ")");
}

// A C-contiguous uint8 array of the given rank, or a TypeError/ValueError naming the problem.
U8Array checked_u8(const py::array& a, int ndim, const char* name) {
    // Equivalence, not identity: arrays rebuilt by pickle (e.g. on Dask workers) carry an equal
    // but distinct dtype object.
    if (!py::isinstance<py::array_t<std::uint8_t>>(a)) {
        throw py::type_error(std::string(name) + " must have dtype uint8, got " + std::string(py::str(a.dtype())));
    }
    if (a.ndim() != ndim) {
        throw py::value_error(std::string(name) + " must be " + std::to_string(ndim) + "-dimensional, got shape " +
                              shape_text(a));
    }
    if (!(a.flags() & py::array::c_style)) {
        throw py::value_error(std::string(name) + " must be C-contiguous (use numpy.ascontiguousarray)");
    }
    return py::reinterpret_borrow<U8Array>(a);
}

std::vector<std::int32_t> checked_shifts(const py::array& shifts) {
    if (!py::isinstance<py::array_t<std::int32_t>>(shifts) || shifts.ndim() != 1) {
        throw py::type_error("shifts must be a 1-D int32 array");
    }
    auto view = py::reinterpret_borrow<py::array_t<std::int32_t>>(shifts).unchecked<1>();
    std::vector<std::int32_t> out(static_cast<std::size_t>(view.shape(0)));
    for (py::ssize_t i = 0; i < view.shape(0); ++i) out[static_cast<std::size_t>(i)] = view(i);
    return out;
}

void require_same_image_size(const U8Array& a, py::ssize_t a_axis, const U8Array& b, const char* a_name) {
    if (a.shape(a_axis) != b.shape(1) || a.shape(a_axis + 1) != b.shape(2)) {
        throw py::value_error(std::string(a_name) + " images are " + std::to_string(a.shape(a_axis)) + " x " +
                              std::to_string(a.shape(a_axis + 1)) + " pixels but refs are " +
                              std::to_string(b.shape(1)) + " x " + std::to_string(b.shape(2)));
    }
}

void require_nonempty(const U8Array& a, const char* name) {
    if (a.shape(0) == 0) throw py::value_error(std::string(name) + " is empty (no images)");
}

nightloc::SimdBackend backend_from_name(const std::string& name) {
    nightloc::SimdBackend backend;
    if (!nightloc::parse_simd_backend(name, backend)) {
        throw py::value_error("unknown SIMD path '" + name + "'; expected one of scalar, sse2, avx2, avx512bw");
    }
    return backend;
}

// An (n, h, w) uint8 stack to a new stack of the same shape by `work(src, dst, n, h, w)`, run
// without the GIL.
template <class Work>
py::array map_stack(const py::array& images_in, Work&& work) {
    const U8Array images = checked_u8(images_in, 3, "images");
    U8Array out({images.shape(0), images.shape(1), images.shape(2)});
    const auto n = static_cast<std::size_t>(images.shape(0));
    const auto h = static_cast<std::size_t>(images.shape(1));
    const auto w = static_cast<std::size_t>(images.shape(2));
    const std::uint8_t* src = images.data();
    std::uint8_t* dst = out.mutable_data();
    {
        py::gil_scoped_release release;
        if (n > 0) work(src, dst, n, h, w);
    }
    return std::move(out);
}

py::array patch_normalize(const py::array& images, int radius, bool wrap, double scale) {
    return map_stack(images, [&](const std::uint8_t* src, std::uint8_t* dst, std::size_t n, std::size_t h,
                                 std::size_t w) { nightloc::patch_normalize(src, dst, n, h, w, radius, wrap, scale); });
}

py::array block_normalize(const py::array& images, int side) {
    return map_stack(images, [&](const std::uint8_t* src, std::uint8_t* dst, std::size_t n, std::size_t h,
                                 std::size_t w) { nightloc::block_normalize(src, dst, n, h, w, side); });
}

py::array rotational_sad(const py::array& query_in, const py::array& refs_in, const py::array& shifts_in, int threads,
                         double divisor) {
    const U8Array query = checked_u8(query_in, 2, "query");
    const U8Array refs = checked_u8(refs_in, 3, "refs");
    require_nonempty(refs, "refs");
    require_same_image_size(query, 0, refs, "query");
    const std::vector<std::int32_t> shifts = checked_shifts(shifts_in);
    py::array_t<float> out({refs.shape(0), static_cast<py::ssize_t>(shifts.size())});
    const std::uint8_t* q = query.data();
    const std::uint8_t* r = refs.data();
    float* o = out.mutable_data();
    {
        py::gil_scoped_release release;
        nightloc::rotational_sad(q, r, static_cast<std::size_t>(refs.shape(0)), static_cast<std::size_t>(refs.shape(1)),
                                 static_cast<std::size_t>(refs.shape(2)), shifts.data(), shifts.size(), o, threads,
                                 divisor);
    }
    return std::move(out);
}

py::tuple difference_matrix(const py::array& queries_in, const py::array& refs_in, const py::array& shifts_in,
                            int threads, double divisor) {
    const U8Array queries = checked_u8(queries_in, 3, "queries");
    const U8Array refs = checked_u8(refs_in, 3, "refs");
    require_nonempty(queries, "queries");
    require_nonempty(refs, "refs");
    require_same_image_size(queries, 1, refs, "query");
    const std::vector<std::int32_t> shifts = checked_shifts(shifts_in);
    py::array_t<float> scores({queries.shape(0), refs.shape(0)});
    py::array_t<std::int32_t> best_shifts({queries.shape(0), refs.shape(0)});
    const std::uint8_t* q = queries.data();
    const std::uint8_t* r = refs.data();
    float* s = scores.mutable_data();
    std::int32_t* b = best_shifts.mutable_data();
    {
        py::gil_scoped_release release;
        nightloc::difference_matrix(q, static_cast<std::size_t>(queries.shape(0)), r,
                                    static_cast<std::size_t>(refs.shape(0)), static_cast<std::size_t>(refs.shape(1)),
                                    static_cast<std::size_t>(refs.shape(2)), shifts.data(), shifts.size(), s, b,
                                    threads, divisor);
    }
    return py::make_tuple(std::move(scores), std::move(best_shifts));
}

py::tuple difference_matrix_sums(const py::array& queries_in, const py::array& refs_in, const py::array& shifts_in,
                                 int threads) {
    const U8Array queries = checked_u8(queries_in, 3, "queries");
    const U8Array refs = checked_u8(refs_in, 3, "refs");
    require_nonempty(queries, "queries");
    require_nonempty(refs, "refs");
    require_same_image_size(queries, 1, refs, "query");
    const std::vector<std::int32_t> shifts = checked_shifts(shifts_in);
    py::array_t<std::uint32_t> sums({queries.shape(0), refs.shape(0)});
    py::array_t<std::int32_t> best_shifts({queries.shape(0), refs.shape(0)});
    const std::uint8_t* q = queries.data();
    const std::uint8_t* r = refs.data();
    std::uint32_t* s = sums.mutable_data();
    std::int32_t* b = best_shifts.mutable_data();
    {
        py::gil_scoped_release release;
        nightloc::difference_matrix_sums(q, static_cast<std::size_t>(queries.shape(0)), r,
                                         static_cast<std::size_t>(refs.shape(0)),
                                         static_cast<std::size_t>(refs.shape(1)),
                                         static_cast<std::size_t>(refs.shape(2)), shifts.data(), shifts.size(), s, b,
                                         threads);
    }
    return py::make_tuple(std::move(sums), std::move(best_shifts));
}

// One query against all references: (best index, float32 scores, int32 shifts, float64 headings),
// all computed here so that a per-frame call costs one crossing of the binding.
py::tuple match(const py::array& query_in, const py::array& refs_in, const py::array& shifts_in, int threads) {
    const U8Array query = checked_u8(query_in, 2, "query");
    const U8Array refs = checked_u8(refs_in, 3, "refs");
    require_nonempty(refs, "refs");
    require_same_image_size(query, 0, refs, "query");
    const std::vector<std::int32_t> shifts = checked_shifts(shifts_in);
    const auto n = static_cast<std::size_t>(refs.shape(0));
    const auto h = static_cast<std::size_t>(refs.shape(1));
    const auto w = static_cast<std::size_t>(refs.shape(2));
    py::array_t<float> scores(refs.shape(0));
    py::array_t<std::int32_t> best_shifts(refs.shape(0));
    py::array_t<double> headings(refs.shape(0));
    const std::uint8_t* q = query.data();
    const std::uint8_t* r = refs.data();
    float* s = scores.mutable_data();
    std::int32_t* b = best_shifts.mutable_data();
    double* hd = headings.mutable_data();
    std::size_t best = 0;
    {
        py::gil_scoped_release release;
        std::vector<std::uint32_t> sums(n);
        nightloc::difference_matrix_sums(q, 1, r, n, h, w, shifts.data(), shifts.size(), sums.data(), b, threads);
        const double pixels = static_cast<double>(h * w);
        const double two_pi = 6.283185307179586476925286766559;
        for (std::size_t i = 0; i < n; ++i) {
            s[i] = nightloc::score_from_sum(sums[i], pixels);
            if (sums[i] < sums[best]) best = i;  // first minimum: ties go to the lowest index
            const double angle = two_pi * static_cast<double>(b[i]) / static_cast<double>(w);
            hd[i] = angle > 0.5 * two_pi ? angle - two_pi : angle;  // (-pi, pi]
        }
    }
    return py::make_tuple(best, std::move(scores), std::move(best_shifts), std::move(headings));
}

}  // namespace

void register_route(py::module_& m);  // register_route.cpp
void register_localization(py::module_& m);  // register_localization.cpp

PYBIND11_MODULE(_core, m) {
    m.doc() = "nightloc's compiled core: patch normalization and rotation-invariant SAD (private; use nightloc)";
    m.attr("__version__") = NIGHTLOC_VERSION_INFO;
    m.attr("DEFAULT_PATCH_SCALE") = nightloc::kDefaultPatchScale;
    m.attr("MAX_IMAGE_PIXELS") = nightloc::kMaxImagePixels;
    m.attr("MAX_PATCH_RADIUS") = nightloc::kMaxPatchRadius;

    m.def("simd_backend", [] { return std::string(nightloc::simd_backend_name(nightloc::active_simd_backend())); },
          "Name of the SIMD path the kernels use now.");
    m.def("best_simd_backend", [] { return std::string(nightloc::simd_backend_name(nightloc::best_simd_backend())); },
          "Name of the fastest SIMD path this CPU supports.");
    m.def(
        "available_simd_backends",
        [] {
            std::vector<std::string> names;
            for (auto b : nightloc::supported_simd_backends()) names.emplace_back(nightloc::simd_backend_name(b));
            return names;
        },
        "SIMD paths this CPU supports, slowest first.");
    m.def(
        "set_simd_backend",
        [](const std::string& name) {
            const nightloc::SimdBackend backend = backend_from_name(name);
            if (!nightloc::simd_backend_supported(backend)) {
                throw py::value_error("SIMD path '" + name + "' is not supported on this CPU");
            }
            nightloc::set_simd_backend(backend);
        },
        py::arg("name"), "Forces a SIMD path for the whole process.");
    m.def("reset_simd_backend", &nightloc::reset_simd_backend,
          "Returns to the default SIMD path (NIGHTLOC_SIMD if valid, else the best).");

    m.def("patch_normalize", &patch_normalize, py::arg("images"), py::arg("radius"), py::arg("wrap"),
          py::arg("scale"));
    m.def("block_normalize", &block_normalize, py::arg("images"), py::arg("side"));
    m.def("rotational_sad", &rotational_sad, py::arg("query"), py::arg("refs"), py::arg("shifts"), py::arg("threads"),
          py::arg("divisor") = 0.0);
    m.def("difference_matrix", &difference_matrix, py::arg("queries"), py::arg("refs"), py::arg("shifts"),
          py::arg("threads"), py::arg("divisor") = 0.0);
    m.def("match", &match, py::arg("query"), py::arg("refs"), py::arg("shifts"), py::arg("threads"));
    m.def("difference_matrix_sums", &difference_matrix_sums, py::arg("queries"), py::arg("refs"), py::arg("shifts"),
          py::arg("threads"));
    register_route(m);
    register_localization(m);
}
