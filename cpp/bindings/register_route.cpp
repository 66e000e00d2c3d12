// pybind11 glue for route mode (nightloc.route): contrast enhancement, trajectory search, and a
// difference matrix written in place into a caller's array. Checks every input and releases the
// GIL around the work. The documented API is python/nightloc/route.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "glue.hpp"
#include "nightloc/sad.hpp"
#include "nightloc/seqslam.hpp"

namespace {

using nightloc::glue::checked_array;
using nightloc::glue::extent;
using nightloc::glue::shape_text;
using nightloc::glue::without_gil;

using F32Array = nightloc::glue::CArray<float>;

// A C-contiguous (n_query, n_ref) float32 matrix, writable if asked.
F32Array checked_matrix(const py::array& a, const char* name, bool writable) {
    F32Array matrix = checked_array<float>(a, name, 2, "(n_query, n_ref)");
    if (writable) nightloc::glue::require_writable(a, name);
    return matrix;
}

// A C-contiguous, non-empty (n, h, w) uint8 image stack.
nightloc::glue::CArray<std::uint8_t> checked_stack(const py::array& a, const char* name) {
    auto stack = checked_array<std::uint8_t>(a, name, 3);
    nightloc::glue::require_images(stack, name);
    return stack;
}

nightloc::EnhanceOffset offset_from_name(const std::string& name) {
    if (name == "none") return nightloc::EnhanceOffset::kNone;
    if (name == "global_min") return nightloc::EnhanceOffset::kGlobalMinimum;
    if (name == "bound") return nightloc::EnhanceOffset::kZscoreBound;
    throw py::value_error("unknown enhancement offset '" + name + "'; expected none, global_min or bound");
}

nightloc::TrajectoryPlan plan_from(int ds, double vmin, double vmax, int uniqueness_radius, bool causal) {
    nightloc::TrajectoryParams params;
    params.ds = ds;
    params.vmin = vmin;
    params.vmax = vmax;
    params.uniqueness_radius = uniqueness_radius;
    params.mode = causal ? nightloc::TrajectoryMode::kCausal : nightloc::TrajectoryMode::kCentred;
    try {
        return nightloc::make_trajectory_plan(params);
    } catch (const std::invalid_argument& error) {
        throw py::value_error(error.what());
    }
}

py::tuple enhance_contrast(const py::array& d_in, int radius, const std::string& offset_name, int threads,
                           py::object out_in) {
    const F32Array d = checked_matrix(d_in, "d", false);
    if (radius < 1) throw py::value_error("radius must be >= 1, got " + std::to_string(radius));
    if (d.shape(1) < 2) throw py::value_error("enhancement needs at least 2 references, got " + std::to_string(d.shape(1)));
    const nightloc::EnhanceOffset offset = offset_from_name(offset_name);
    F32Array out;
    if (out_in.is_none()) {
        out = F32Array({d.shape(0), d.shape(1)});
    } else {
        out = checked_matrix(out_in.cast<py::array>(), "out", true);
        if (out.shape(0) != d.shape(0) || out.shape(1) != d.shape(1)) {
            throw py::value_error("out has shape " + shape_text(out) + " but d has shape " + shape_text(d));
        }
    }
    const float* src = d.data();
    float* dst = out.mutable_data();
    const float added = without_gil([&] {
        return nightloc::enhance_contrast(src, dst, extent(d, 0), extent(d, 1), static_cast<std::size_t>(radius), offset,
                                          threads);
    });
    return py::make_tuple(std::move(out), added);
}

py::tuple trajectory_search(const py::array& dd_in, int ds, double vmin, double vmax, int uniqueness_radius,
                            bool causal, py::ssize_t query_begin, py::ssize_t query_end, int threads) {
    const F32Array dd = checked_matrix(dd_in, "dd", false);
    const nightloc::TrajectoryPlan plan = plan_from(ds, vmin, vmax, uniqueness_radius, causal);
    const py::ssize_t n_queries = dd.shape(0);
    if (query_begin < 0 || query_end < query_begin || query_end > n_queries) {
        throw py::value_error("query range [" + std::to_string(query_begin) + ", " + std::to_string(query_end) +
                              ") is not inside [0, " + std::to_string(n_queries) + "]");
    }
    py::array_t<std::int64_t> refs(n_queries);
    py::array_t<double> scores(n_queries);
    std::int64_t* r = refs.mutable_data();
    double* s = scores.mutable_data();
    for (py::ssize_t q = 0; q < n_queries; ++q) {
        r[q] = -1;
        s[q] = std::numeric_limits<double>::quiet_NaN();
    }
    const float* m = dd.data();
    // std::invalid_argument (too few references) reaches Python as ValueError.
    without_gil([&] {
        nightloc::trajectory_search(m, extent(dd, 0), extent(dd, 1), plan, r, s, static_cast<std::size_t>(query_begin),
                                    static_cast<std::size_t>(query_end), threads);
    });
    return py::make_tuple(std::move(refs), std::move(scores));
}

py::dict trajectory_plan(int ds, double vmin, double vmax, int uniqueness_radius, bool causal) {
    const nightloc::TrajectoryPlan plan = plan_from(ds, vmin, vmax, uniqueness_radius, causal);
    py::array_t<std::int64_t> offsets({static_cast<py::ssize_t>(plan.speeds.size()),
                                       static_cast<py::ssize_t>(plan.frames)});
    std::copy(plan.offsets.begin(), plan.offsets.end(), offsets.mutable_data());
    py::dict out;
    out["ds"] = plan.ds;
    out["frames"] = plan.frames;
    out["speeds"] = plan.speeds;
    out["offsets"] = std::move(offsets);
    out["columns"] = plan.columns;
    return out;
}

void difference_matrix_into(const py::array& queries_in, const py::array& refs_in, const py::array& shifts_in,
                            int threads, double divisor, const py::array& out_in) {
    const auto queries = checked_stack(queries_in, "queries");
    const auto refs = checked_stack(refs_in, "refs");
    nightloc::glue::require_same_image_size(queries, 1, refs, "query");
    const std::vector<std::int32_t> shifts = nightloc::glue::shift_list(shifts_in, true);
    F32Array out = checked_matrix(out_in, "out", true);
    if (out.shape(0) != queries.shape(0) || out.shape(1) != refs.shape(0)) {
        throw py::value_error("out has shape " + shape_text(out) + ", expected (" + std::to_string(queries.shape(0)) +
                              ", " + std::to_string(refs.shape(0)) + ")");
    }
    if (!(divisor > 0.0)) throw py::value_error("divisor must be > 0");
    const std::uint8_t* q = queries.data();
    const std::uint8_t* r = refs.data();
    float* o = out.mutable_data();
    without_gil([&] {
        // Best shifts are not needed by route mode: a scratch buffer for this block of queries.
        std::vector<std::int32_t> best_shifts(extent(queries, 0) * extent(refs, 0));
        nightloc::difference_matrix(q, extent(queries, 0), r, extent(refs, 0), extent(refs, 1), extent(refs, 2),
                                    shifts.data(), shifts.size(), o, best_shifts.data(), threads, divisor);
    });
}

}  // namespace

void register_route(py::module_& m) {
    m.attr("MAX_TRAJECTORY_PLAN_ENTRIES") = nightloc::kMaxTrajectoryPlanEntries;
    m.def("zscore_bound", &nightloc::zscore_bound, py::arg("radius"),
          "(n-1)/sqrt(n) for n = 2*radius+1, as float32: the largest |z| of a window.");
    m.def("enhance_contrast", &enhance_contrast, py::arg("d"), py::arg("radius"), py::arg("offset"),
          py::arg("threads"), py::arg("out") = py::none(),
          "Local contrast enhancement of an (n_query, n_ref) float32 matrix; returns (out, added).");
    m.def("trajectory_search", &trajectory_search, py::arg("dd"), py::arg("ds"), py::arg("vmin"), py::arg("vmax"),
          py::arg("uniqueness_radius"), py::arg("causal"), py::arg("query_begin"), py::arg("query_end"),
          py::arg("threads"), "SeqSLAM trajectory search; returns (ref int64 (-1 undefined), score float64).");
    m.def("trajectory_plan", &trajectory_plan, py::arg("ds"), py::arg("vmin"), py::arg("vmax"),
          py::arg("uniqueness_radius"), py::arg("causal"), "The speeds and row offsets the search uses.");
    m.def("difference_matrix_into", &difference_matrix_into, py::arg("queries"), py::arg("refs"), py::arg("shifts"),
          py::arg("threads"), py::arg("divisor"), py::arg("out"),
          "Writes the (n_query, n_ref) float32 difference matrix into out (rows = queries).");
}
