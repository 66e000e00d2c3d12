// pybind11 glue for matching (nightloc.matching): rotation-invariant SAD tables, the per-frame
// match, difference matrices (nightloc/sad.hpp), the choice of SIMD path (nightloc/simd.hpp) and of
// the AVX-512 SAD variant (the core's internal avx512_variant.hpp).
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/simd_paths.hpp"
#include "glue.hpp"
#include "matching/avx512_variant.hpp"
#include "nightloc/sad.hpp"
#include "nightloc/simd.hpp"

namespace {

using nightloc::glue::checked_array;
using nightloc::glue::extent;
using nightloc::glue::require_images;
using nightloc::glue::require_same_image_size;
using nightloc::glue::shift_list;
using nightloc::glue::without_gil;

using WindowPair = std::pair<long long, long long>;

nightloc::SimdBackend backend_from_name(const std::string& name) {
    nightloc::SimdBackend backend;
    if (!nightloc::parse_simd_backend(name, backend)) {
        throw py::value_error("unknown SIMD path '" + name + "'; expected one of " + nightloc::simd_backend_names());
    }
    return backend;
}

// The (n_ref, n_columns) table with a translation window: (scores, best row offsets).
py::tuple shift_table(const py::array& query_in, const py::array& refs_in, const py::array& shifts_in, int threads,
                      double divisor, const WindowPair& window_in) {
    const auto query = checked_array<std::uint8_t>(query_in, "query", 2);
    const auto refs = checked_array<std::uint8_t>(refs_in, "refs", 3);
    require_images(refs, "refs");
    require_same_image_size(query, 0, refs, "query");
    const std::vector<std::int32_t> shifts = shift_list(shifts_in);
    const nightloc::ShiftWindow window = nightloc::glue::shift_window(window_in);
    // Checks sizes, shifts and window (std::invalid_argument -> ValueError) before allocating.
    const auto n_columns = static_cast<py::ssize_t>(
        nightloc::window_column_offsets(extent(refs, 1), extent(refs, 2), shifts.data(), shifts.size(), window).size());
    py::array_t<float> out({refs.shape(0), n_columns});
    py::array_t<std::int32_t> rows({refs.shape(0), n_columns});
    const std::uint8_t* q = query.data();
    const std::uint8_t* r = refs.data();
    float* o = out.mutable_data();
    std::int32_t* b = rows.mutable_data();
    without_gil([&] {
        nightloc::rotational_sad(q, r, extent(refs, 0), extent(refs, 1), extent(refs, 2), shifts.data(), shifts.size(),
                                 window, o, b, threads, divisor);
    });
    return py::make_tuple(std::move(out), std::move(rows));
}

py::array rotational_sad(const py::array& query_in, const py::array& refs_in, const py::array& shifts_in, int threads,
                         double divisor, const WindowPair& window) {
    return shift_table(query_in, refs_in, shifts_in, threads, divisor, window)[0].cast<py::array>();
}

// (n_query, n_ref) best sums or scores (Out), best shifts and best row offsets, by
// compute(queries, n_queries, refs, n_refs, height, width, shifts, values, best_shifts, best_rows).
template <class Out, class Compute>
py::tuple difference_table(const py::array& queries_in, const py::array& refs_in, const py::array& shifts_in,
                           bool with_rows, Compute&& compute) {
    const auto queries = checked_array<std::uint8_t>(queries_in, "queries", 3);
    const auto refs = checked_array<std::uint8_t>(refs_in, "refs", 3);
    require_images(queries, "queries");
    require_images(refs, "refs");
    require_same_image_size(queries, 1, refs, "query");
    const std::vector<std::int32_t> shifts = shift_list(shifts_in);
    py::array_t<Out> values({queries.shape(0), refs.shape(0)});
    py::array_t<std::int32_t> best_shifts({queries.shape(0), refs.shape(0)});
    py::array_t<std::int32_t> best_rows({with_rows ? queries.shape(0) : 0, with_rows ? refs.shape(0) : 0});
    const std::uint8_t* q = queries.data();
    const std::uint8_t* r = refs.data();
    Out* v = values.mutable_data();
    std::int32_t* b = best_shifts.mutable_data();
    std::int32_t* rows = with_rows ? best_rows.mutable_data() : nullptr;
    without_gil([&] {
        compute(q, extent(queries, 0), r, extent(refs, 0), extent(refs, 1), extent(refs, 2), shifts, v, b, rows);
    });
    if (!with_rows) return py::make_tuple(std::move(values), std::move(best_shifts));
    return py::make_tuple(std::move(values), std::move(best_shifts), std::move(best_rows));
}

using Shifts = std::vector<std::int32_t>;

// (scores, best shifts, best row offsets).
py::tuple difference_matrix(const py::array& queries, const py::array& refs, const py::array& shifts, int threads,
                            double divisor, const WindowPair& window_in) {
    const nightloc::ShiftWindow window = nightloc::glue::shift_window(window_in);
    return difference_table<float>(
        queries, refs, shifts, true,
        [&](const std::uint8_t* q, std::size_t n_q, const std::uint8_t* r, std::size_t n_r, std::size_t h,
            std::size_t w, const Shifts& s, float* scores, std::int32_t* b, std::int32_t* rows) {
            nightloc::difference_matrix(q, n_q, r, n_r, h, w, s.data(), s.size(), window, scores, b, rows, threads,
                                        divisor);
        });
}

py::tuple difference_matrix_sums(const py::array& queries, const py::array& refs, const py::array& shifts,
                                 int threads) {
    return difference_table<std::uint32_t>(
        queries, refs, shifts, false,
        [&](const std::uint8_t* q, std::size_t n_q, const std::uint8_t* r, std::size_t n_r, std::size_t h,
            std::size_t w, const Shifts& s, std::uint32_t* sums, std::int32_t* b, std::int32_t*) {
            nightloc::difference_matrix_sums(q, n_q, r, n_r, h, w, s.data(), s.size(), sums, b, threads);
        });
}

// One query against all references, the core's per-frame call (nightloc::match): (best index,
// float32 scores, int32 shifts, float64 headings, int32 row offsets) in one crossing of the binding.
py::tuple match(const py::array& query_in, const py::array& refs_in, const py::array& shifts_in, int threads,
                const WindowPair& window_in) {
    const nightloc::ShiftWindow window = nightloc::glue::shift_window(window_in);
    const auto query = checked_array<std::uint8_t>(query_in, "query", 2);
    const auto refs = checked_array<std::uint8_t>(refs_in, "refs", 3);
    require_images(refs, "refs");
    require_same_image_size(query, 0, refs, "query");
    const std::vector<std::int32_t> shifts = shift_list(shifts_in);
    py::array_t<float> scores(refs.shape(0));
    py::array_t<std::int32_t> best_shifts(refs.shape(0));
    py::array_t<double> headings(refs.shape(0));
    py::array_t<std::int32_t> best_rows(refs.shape(0));
    const std::uint8_t* q = query.data();
    const std::uint8_t* r = refs.data();
    float* s = scores.mutable_data();
    std::int32_t* b = best_shifts.mutable_data();
    double* hd = headings.mutable_data();
    std::int32_t* rows = best_rows.mutable_data();
    const std::size_t best = without_gil([&] {
        return nightloc::match(q, r, extent(refs, 0), extent(refs, 1), extent(refs, 2), shifts.data(), shifts.size(),
                               window, s, b, rows, hd, threads);
    });
    return py::make_tuple(best, std::move(scores), std::move(best_shifts), std::move(headings), std::move(best_rows));
}

std::vector<std::string> names_of(const std::vector<nightloc::SimdBackend>& backends) {
    std::vector<std::string> names;
    for (auto b : backends) names.emplace_back(nightloc::simd_backend_name(b));
    return names;
}

}  // namespace

void register_matching(py::module_& m) {
    m.attr("MAX_IMAGE_PIXELS") = nightloc::kMaxImagePixels;

    std::vector<std::string> all_names;
    for (const auto& entry : nightloc::kSimdBackendNames) all_names.emplace_back(entry.name);
    m.attr("ALL_SIMD_BACKENDS") = py::tuple(py::cast(all_names));
    m.def(
        "simd_paths",
        [] {
            static const char* const kFloatWidths[] = {"scalar", "baseline", "avx2", "avx512"};
            py::list paths;
            for (const auto& entry : nightloc::kSimdBackendNames) {
                const nightloc::detail::SimdPath* path = nightloc::detail::find_simd_path(entry.backend);
                py::dict row;
                row["name"] = entry.name;
                row["architecture"] = entry.architecture;
                row["compiled"] = path != nullptr;
                row["supported"] = nightloc::simd_backend_supported(entry.backend);
                row["alignment"] = path != nullptr ? py::object(py::int_(path->alignment)) : py::object(py::none());
                row["all_shift_kernel"] = path != nullptr && path->sad_all_shifts != nullptr;
                row["float_kernels"] = path != nullptr
                                           ? py::object(py::str(kFloatWidths[static_cast<int>(path->float_kernels)]))
                                           : py::object(py::none());
                paths.append(row);
            }
            return paths;
        },
        "The SIMD path registry, every path the library knows in kSimdBackendNames' order: name, architecture, "
        "compiled (into this build), supported (by this CPU), and for a compiled path its alignment, whether it has "
        "an all-shift SAD kernel and its float kernels' width.");
    m.def(
        "simd_backend", [] { return std::string(nightloc::simd_backend_name(nightloc::active_simd_backend())); },
        "Name of the SIMD path the kernels use now.");
    m.def(
        "best_simd_backend", [] { return std::string(nightloc::simd_backend_name(nightloc::best_simd_backend())); },
        "Name of the fastest SIMD path this CPU supports.");
    m.def(
        "available_simd_backends", [] { return names_of(nightloc::supported_simd_backends()); },
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

    m.def(
        "available_avx512_sad_variants",
        [] {
            std::vector<std::string> names;
            for (auto v : {nightloc::Avx512SadVariant::vpaddw, nightloc::Avx512SadVariant::vnni}) {
                if (nightloc::avx512_sad_variant_supported(v)) names.emplace_back(nightloc::avx512_sad_variant_name(v));
            }
            return names;
        },
        "Accumulations of the avx512bw all-shift SAD kernel this CPU can run (vpaddw, vnni).");
    m.def(
        "avx512_sad_variant",
        []() -> py::object {
            if (!nightloc::avx512_sad_variant_supported(nightloc::Avx512SadVariant::vpaddw)) return py::none();
            const auto variant = nightloc::avx512_sad_variant();  // may time both variants, once per process
            return py::make_tuple(nightloc::avx512_sad_variant_name(variant), nightloc::avx512_sad_variant_reason());
        },
        "(variant, reason) of the avx512bw path's all-shift SAD kernel; None without AVX-512BW.");
    m.def(
        "set_avx512_sad_variant",
        [](const std::optional<std::string>& name) {
            if (!name) return nightloc::reset_avx512_sad_variant();
            if (*name != "vpaddw" && *name != "vnni") {
                throw py::value_error("unknown AVX-512 SAD variant '" + *name + "'; expected vpaddw or vnni");
            }
            nightloc::set_avx512_sad_variant(*name == "vnni" ? nightloc::Avx512SadVariant::vnni
                                                             : nightloc::Avx512SadVariant::vpaddw);
        },
        py::arg("name"), "Forces the avx512bw all-shift SAD variant process-wide (None: the per-CPU choice).");

    const WindowPair no_window{0, 0};
    m.def("rotational_sad", &rotational_sad, py::arg("query"), py::arg("refs"), py::arg("shifts"), py::arg("threads"),
          py::arg("divisor") = 0.0, py::arg("window") = no_window);
    m.def("shift_table", &shift_table, py::arg("query"), py::arg("refs"), py::arg("shifts"), py::arg("threads"),
          py::arg("divisor") = 0.0, py::arg("window") = no_window,
          "(n_ref, n_columns) float32 scores and int32 best row offsets of a translation-window search.");
    m.def("difference_matrix", &difference_matrix, py::arg("queries"), py::arg("refs"), py::arg("shifts"),
          py::arg("threads"), py::arg("divisor") = 0.0, py::arg("window") = no_window);
    m.def("match", &match, py::arg("query"), py::arg("refs"), py::arg("shifts"), py::arg("threads"),
          py::arg("window") = no_window);
    m.def("difference_matrix_sums", &difference_matrix_sums, py::arg("queries"), py::arg("refs"), py::arg("shifts"),
          py::arg("threads"));
}
