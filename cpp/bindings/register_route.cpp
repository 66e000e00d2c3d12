// pybind11 glue for route mode (nightloc.route): contrast enhancement, trajectory search, and a
// difference matrix written in place into a caller's array. Checks every input and releases the
// GIL around the work. The documented API is python/nightloc/route.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "glue.hpp"
#include "nightloc/route_filter.hpp"
#include "nightloc/sad.hpp"
#include "nightloc/seqslam.hpp"
#include "settings_glue.hpp"

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
    return nightloc::make_trajectory_plan(params);  // SettingError, std::invalid_argument -> ValueError
}

py::tuple enhance_contrast(const py::array& d_in, int radius, const std::string& offset_name, int threads,
                           py::object out_in) {
    const F32Array d = checked_matrix(d_in, "d", false);
    if (radius < 1) throw py::value_error("radius must be >= 1, got " + std::to_string(radius));
    if (d.shape(1) < 2)
        throw py::value_error("enhancement needs at least 2 references, got " + std::to_string(d.shape(1)));
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
        return nightloc::enhance_contrast(src, dst, extent(d, 0), extent(d, 1), static_cast<std::size_t>(radius),
                                          offset, threads);
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
    py::array_t<std::int64_t> offsets(
        {static_cast<py::ssize_t>(plan.speeds.size()), static_cast<py::ssize_t>(plan.frames)});
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
                            int threads, double divisor, const py::array& out_in,
                            const std::pair<long long, long long>& window_in) {
    const nightloc::ShiftWindow window = nightloc::glue::shift_window(window_in);
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
                                    shifts.data(), shifts.size(), window, o, best_shifts.data(), nullptr, threads,
                                    divisor);
    });
}

// ---- route filter (nightloc/route_filter.hpp) ----------------------------------------------

// A C-contiguous 1-D float32 row of n values.
py::array_t<float, py::array::c_style> checked_row(const py::array& a, std::size_t n) {
    if (!py::isinstance<py::array_t<float>>(a)) {
        throw py::type_error("row must have dtype float32, got " + std::string(py::str(a.dtype())) +
                             " (convert with numpy.asarray(x, dtype=numpy.float32))");
    }
    if (a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != n) {
        throw py::value_error("row must have shape (" + std::to_string(n) + ",) (one value per reference), got " +
                              shape_text(a));
    }
    if (!(a.flags() & py::array::c_style)) throw py::value_error("row must be C-contiguous");
    return py::reinterpret_borrow<py::array_t<float, py::array::c_style>>(a);
}

// weights: None or n values in [0, 1] (copied), as a vector (empty for None).
std::vector<double> checked_weights(const py::object& weights_in, std::size_t n) {
    std::vector<double> weights;
    if (weights_in.is_none()) return weights;
    const auto w = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(weights_in);
    if (!w || w.ndim() != 1 || static_cast<std::size_t>(w.shape(0)) != n) {
        throw py::value_error("weights must be a 1-D array of " + std::to_string(n) +
                              " values in [0, 1] (one per query)");
    }
    weights.assign(w.data(), w.data() + n);
    for (double v : weights) {
        if (!(v >= 0.0 && v <= 1.0)) throw py::value_error("weights must lie in [0, 1], got " + std::to_string(v));
    }
    return weights;
}

// advances: None or n finite values (copied), as a vector (empty for None).
std::vector<double> checked_advances(const py::object& advances_in, std::size_t n) {
    std::vector<double> advances;
    if (advances_in.is_none()) return advances;
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(advances_in);
    if (!a || a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != n) {
        throw py::value_error("advances must be a 1-D array of " + std::to_string(n) +
                              " distances (one per query: the distance travelled since the previous one)");
    }
    advances.assign(a.data(), a.data() + n);
    for (std::size_t i = 0; i < n; ++i) {
        if (!std::isfinite(advances[i])) {
            throw py::value_error("advances must be finite, got " + std::to_string(advances[i]) + " at query " +
                                  std::to_string(i));
        }
    }
    return advances;
}

// reference distances: None or n_refs values, as a vector (empty for None; checked by the core).
std::vector<double> checked_distances(const py::object& distances_in, std::size_t n_refs) {
    std::vector<double> distances;
    if (distances_in.is_none()) return distances;
    const auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(distances_in);
    if (!d || d.ndim() != 1 || static_cast<std::size_t>(d.shape(0)) != n_refs) {
        throw py::value_error("reference_distances must be a 1-D array of " + std::to_string(n_refs) +
                              " cumulative distances (one per reference)");
    }
    distances.assign(d.data(), d.data() + n_refs);
    return distances;
}

py::tuple step_tuple(const nightloc::RouteFilterStep& s) {
    return py::make_tuple(s.best, s.confidence, s.off_route, s.speed);
}

// Runs `filter` over the rows of `matrix` (continuing its state); returns (best, confidence,
// off_route, speed).
py::tuple run_rows(nightloc::RouteFilter& filter, const py::array& matrix_in, const py::object& weights_in, int threads,
                   const py::object& advances_in) {
    const F32Array matrix = checked_matrix(matrix_in, "matrix", false);
    const auto n_queries = static_cast<std::size_t>(matrix.shape(0));
    if (static_cast<std::size_t>(matrix.shape(1)) != filter.n_refs()) {
        throw py::value_error("matrix has " + std::to_string(matrix.shape(1)) + " columns but the filter has " +
                              std::to_string(filter.n_refs()) + " references");
    }
    const std::vector<double> weights = checked_weights(weights_in, n_queries);
    const std::vector<double> advances = checked_advances(advances_in, n_queries);
    py::array_t<std::int64_t> best(static_cast<py::ssize_t>(n_queries));
    py::array_t<double> confidence(static_cast<py::ssize_t>(n_queries));
    py::array_t<double> off_route(static_cast<py::ssize_t>(n_queries));
    py::array_t<double> speed(static_cast<py::ssize_t>(n_queries));
    nightloc::RouteFilterOutputs out;
    out.best = best.mutable_data();
    out.confidence = confidence.mutable_data();
    out.off_route = off_route.mutable_data();
    out.speed = speed.mutable_data();
    const float* m = matrix.data();
    const double* w = weights.empty() ? nullptr : weights.data();
    const double* a = advances.empty() ? nullptr : advances.data();
    {
        py::gil_scoped_release release;
        filter.run(m, n_queries, w, a, out, threads);
    }
    return py::make_tuple(std::move(best), std::move(confidence), std::move(off_route), std::move(speed));
}

nightloc::RouteFilter make_filter(std::size_t n_refs, const nightloc::RouteFilterParams& params,
                                  const py::object& distances_in) {
    const std::vector<double> distances = checked_distances(distances_in, n_refs);
    return nightloc::RouteFilter(n_refs, params, distances.empty() ? nullptr : distances.data());
}

py::tuple route_filter_matrix(const py::array& matrix_in, const nightloc::RouteFilterParams& params,
                              const py::object& weights_in, int threads, const py::object& advances_in,
                              const py::object& distances_in) {
    const F32Array matrix = checked_matrix(matrix_in, "matrix", false);
    if (matrix.shape(1) == 0) throw py::value_error("matrix has no references (shape " + shape_text(matrix) + ")");
    nightloc::RouteFilter filter = make_filter(static_cast<std::size_t>(matrix.shape(1)), params, distances_in);
    return run_rows(filter, matrix, weights_in, threads, advances_in);
}

py::array_t<double> texture_weights(const py::array& stack_in, double min_texture) {
    const auto stack = checked_stack(stack_in, "images");
    const auto n = static_cast<std::size_t>(stack.shape(0));
    const auto pixels = static_cast<std::size_t>(stack.shape(1) * stack.shape(2));
    py::array_t<double> out(static_cast<py::ssize_t>(n));
    const std::uint8_t* data = stack.data();
    double* o = out.mutable_data();
    {
        py::gil_scoped_release release;
        for (std::size_t i = 0; i < n; ++i) o[i] = nightloc::texture_weight(data + i * pixels, pixels, min_texture);
    }
    return out;
}

// One camera frame's whole step in one crossing: difference row against the references, its
// contrast enhancement (causal offset), the texture weight, the filter step. The row is kept in
// `row_out` (the enhanced row, float32 (n_refs,)).
py::tuple filter_frame(nightloc::RouteFilter& filter, const py::array& image_in, const py::array& refs_in,
                       const py::array& shifts_in, double divisor, int enhance_radius, double min_texture, int threads,
                       const py::array& row_in, const std::pair<long long, long long>& window_in, double advance) {
    const nightloc::ShiftWindow window = nightloc::glue::shift_window(window_in);
    const auto refs = checked_stack(refs_in, "refs");
    if (!py::isinstance<py::array_t<std::uint8_t>>(image_in) || image_in.ndim() != 2 ||
        !(image_in.flags() & py::array::c_style)) {
        throw py::type_error("image must be a C-contiguous 2-D uint8 array (one prepared frame)");
    }
    const auto image = py::reinterpret_borrow<nightloc::glue::CArray<std::uint8_t>>(image_in);
    if (image.shape(0) != refs.shape(1) || image.shape(1) != refs.shape(2)) {
        throw py::value_error("the image is " + std::to_string(image.shape(0)) + " x " +
                              std::to_string(image.shape(1)) + " pixels but refs are " + std::to_string(refs.shape(1)) +
                              " x " + std::to_string(refs.shape(2)));
    }
    const auto n_refs = static_cast<std::size_t>(refs.shape(0));
    if (n_refs != filter.n_refs()) {
        throw py::value_error("refs hold " + std::to_string(n_refs) + " images but the filter has " +
                              std::to_string(filter.n_refs()) + " references");
    }
    if (n_refs < 2) throw py::value_error("enhancement needs at least 2 references");
    if (enhance_radius < 1) throw py::value_error("enhance_radius must be >= 1, got " + std::to_string(enhance_radius));
    if (!(divisor > 0.0)) throw py::value_error("divisor must be > 0");
    if (!std::isfinite(advance)) throw py::value_error("advance must be a finite distance");
    const std::vector<std::int32_t> shifts = nightloc::glue::shift_list(shifts_in, /*non_empty=*/true);
    F32Array row = checked_matrix(row_in, "row", true);
    if (row.shape(0) != 1 || static_cast<std::size_t>(row.shape(1)) != n_refs) {
        throw py::value_error("row must have shape (1, " + std::to_string(n_refs) + "), got " + shape_text(row));
    }
    const std::uint8_t* q = image.data();
    const std::uint8_t* r = refs.data();
    float* out = row.mutable_data();
    const auto h = static_cast<std::size_t>(refs.shape(1));
    const auto w = static_cast<std::size_t>(refs.shape(2));
    nightloc::RouteFilterStep step;
    double weight = 1.0;
    {
        py::gil_scoped_release release;
        std::vector<std::int32_t> best_shifts(n_refs);
        nightloc::difference_matrix(q, 1, r, n_refs, h, w, shifts.data(), shifts.size(), window, out,
                                    best_shifts.data(), nullptr, threads, divisor);
        nightloc::enhance_contrast(out, out, 1, n_refs, static_cast<std::size_t>(enhance_radius),
                                   nightloc::EnhanceOffset::kZscoreBound, 1);
        weight = nightloc::texture_weight(q, h * w, min_texture);
        filter.set_threads(threads);
        step = filter.step(out, weight, advance);
    }
    return py::make_tuple(step.best, step.confidence, step.off_route, weight, step.speed);
}

void register_route_filter(py::module_& m) {
    nightloc::glue::bind_settings<nightloc::RouteFilterParams>(
        m, "RouteFilterParams",
        "Parameters of the route filter (nightloc/route_filter.hpp); setting a field checks its kind and range.");
    nightloc::glue::bind_settings<nightloc::TrajectoryParams>(
        m, "TrajectoryParams",
        "Parameters of SeqSLAM's trajectory search (nightloc/seqslam.hpp); setting a field checks its kind and range.");

    py::class_<nightloc::RouteFilter>(m, "RouteFilter", "The route filter's state and per-frame step.")
        .def(py::init(&make_filter), py::arg("n_refs"), py::arg("params"),
             py::arg("reference_distances") = py::none())  // std::invalid_argument -> ValueError
        .def(
            "step",
            [](nightloc::RouteFilter& f, const py::array& row_in, double weight, double advance) {
                const auto row = checked_row(row_in, f.n_refs());  // weight and advance are checked by the core
                const float* r = row.data();
                nightloc::RouteFilterStep s;
                {
                    py::gil_scoped_release release;
                    s = f.step(r, weight, advance);
                }
                return step_tuple(s);
            },
            py::arg("row"), py::arg("weight") = 1.0, py::arg("advance") = 0.0,
            "One frame's row: returns (best, confidence, off_route, speed).")
        .def("run", &run_rows, py::arg("matrix"), py::arg("weights") = py::none(), py::arg("threads") = 1,
             py::arg("advances") = py::none(),
             "Consecutive frames' rows (n, n_refs) float32: returns (best, confidence, off_route, speed) arrays.")
        .def("frame", &filter_frame, py::arg("image"), py::arg("refs"), py::arg("shifts"), py::arg("divisor"),
             py::arg("enhance_radius"), py::arg("min_texture"), py::arg("threads"), py::arg("row"),
             py::arg("window") = std::pair<long long, long long>{0, 0}, py::arg("advance") = 0.0,
             "One prepared frame: difference row, enhancement, texture weight and step; returns "
             "(best, confidence, off_route, weight, speed).")
        .def("reset", &nightloc::RouteFilter::reset)
        .def("__copy__", [](const nightloc::RouteFilter& f) { return nightloc::RouteFilter(f); })
        .def(
            "__deepcopy__", [](const nightloc::RouteFilter& f, const py::dict&) { return nightloc::RouteFilter(f); },
            py::arg("memo"))
        .def(
            "set_state",
            [](nightloc::RouteFilter& f, const py::array& belief_in, double off_route) {
                const auto belief = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(belief_in);
                if (!belief || belief.ndim() != 1 || static_cast<std::size_t>(belief.shape(0)) != f.n_refs()) {
                    throw py::value_error("belief must be a 1-D array of " + std::to_string(f.n_refs()) + " values");
                }
                f.set_state(belief.data(), off_route);
            },
            py::arg("belief"), py::arg("off_route"))
        .def_property_readonly("belief",
                               [](const nightloc::RouteFilter& f) {
                                   const auto& b = f.belief();
                                   return py::array_t<double>(static_cast<py::ssize_t>(b.size()), b.data());
                               })
        .def_property_readonly("off_route", &nightloc::RouteFilter::off_route)
        .def_property_readonly("n_refs", &nightloc::RouteFilter::n_refs)
        .def_property_readonly("motion", [](const nightloc::RouteFilter& f) { return std::string(f.motion_name()); })
        .def_property_readonly("plane_belief", [](const nightloc::RouteFilter& f) {
            const auto& b = f.plane_belief();
            return py::array_t<double>(static_cast<py::ssize_t>(b.size()), b.data());
        });

    m.def("route_filter", &route_filter_matrix, py::arg("matrix"), py::arg("params"), py::arg("weights") = py::none(),
          py::arg("threads") = 1, py::arg("advances") = py::none(), py::arg("reference_distances") = py::none(),
          "The route filter over an (n_query, n_ref) float32 matrix; returns (best int64, confidence, off_route, "
          "speed).");
    m.def(
        "speed_chain",
        [](const nightloc::RouteFilterParams& p) {
            const nightloc::SpeedChain c = nightloc::speed_chain(p);
            auto array = [](const std::vector<double>& v) {
                return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
            };
            return py::make_tuple(array(c.speeds), array(c.up), array(c.down), array(c.prior), c.passes);
        },
        py::arg("params"), "The speed model's planes: (speeds, up, down, prior, passes per frame).");
    m.def(
        "odometry_spread",
        [](double advance, double spacing, const nightloc::RouteFilterParams& p) {
            if (!std::isfinite(advance) || !(spacing > 0.0) || !std::isfinite(spacing)) {
                throw py::value_error("advance must be finite and spacing a finite distance > 0");
            }
            nightloc::validate(p);
            const std::vector<double> taps = nightloc::odometry_spread(advance, spacing, p);
            return py::array_t<double>(static_cast<py::ssize_t>(taps.size()), taps.data());
        },
        py::arg("advance"), py::arg("spacing"), py::arg("params"),
        "The odometry model's position noise for one frame: taps over cells, centred.");
    m.def(
        "motion_kernel",
        [](double vmin, double vmax, double backward) {
            const nightloc::MotionKernel k = nightloc::motion_kernel(vmin, vmax, backward);
            return py::make_tuple(k.first,
                                  py::array_t<double>(static_cast<py::ssize_t>(k.weights.size()), k.weights.data()));
        },
        py::arg("vmin"), py::arg("vmax"), py::arg("backward"), "The prediction kernel: (first advance, weights).");
    m.def("route_motion_names", &nightloc::route_motion_names,
          "The route filter's motion models by name, in the order of the C++ RouteMotion enum.");
    m.def(
        "route_motion_speeds",
        [](const nightloc::RouteFilterParams& p) {
            const nightloc::RouteMotionSpeeds s = nightloc::route_motion_speeds(p);
            return py::make_tuple(s.lowest, s.highest, s.fields);
        },
        py::arg("params"),
        "The steady speeds params.motion follows, references per query frame: (lowest, highest, the "
        "RouteFilterParams fields that set them); (-inf, inf, []) for a model that moves by the distance travelled.");
    m.def(
        "route_motion_models",
        []() {
            py::list models;
            for (const std::string& name : nightloc::route_motion_names()) {
                const nightloc::RouteMotion motion = nightloc::route_motion_from_name(name);
                py::dict model;
                model["name"] = name;
                model["needs_distances"] = nightloc::route_motion_needs_distances(motion);
                models.append(model);
            }
            return models;
        },
        "The motion models' registry, in RouteMotion order: {name, needs_distances (moves by the distance "
        "travelled)} each.");
    m.def("texture_weights", &texture_weights, py::arg("images"), py::arg("min_texture"),
          "Evidence weight min(1, mean absolute deviation / min_texture) of each prepared image.");
}

}  // namespace

void register_route(py::module_& m) {
    m.attr("MAX_TRAJECTORY_PLAN_ENTRIES") = nightloc::kMaxTrajectoryPlanEntries;
    m.def("zscore_bound", &nightloc::zscore_bound, py::arg("radius"),
          "(n-1)/sqrt(n) for n = 2*radius+1, as float32: the largest |z| of a window.");
    m.def("enhance_contrast", &enhance_contrast, py::arg("d"), py::arg("radius"), py::arg("offset"), py::arg("threads"),
          py::arg("out") = py::none(),
          "Local contrast enhancement of an (n_query, n_ref) float32 matrix; returns (out, added).");
    m.def("trajectory_search", &trajectory_search, py::arg("dd"), py::arg("ds"), py::arg("vmin"), py::arg("vmax"),
          py::arg("uniqueness_radius"), py::arg("causal"), py::arg("query_begin"), py::arg("query_end"),
          py::arg("threads"), "SeqSLAM trajectory search; returns (ref int64 (-1 undefined), score float64).");
    m.def("trajectory_plan", &trajectory_plan, py::arg("ds"), py::arg("vmin"), py::arg("vmax"),
          py::arg("uniqueness_radius"), py::arg("causal"), "The speeds and row offsets the search uses.");
    m.def("difference_matrix_into", &difference_matrix_into, py::arg("queries"), py::arg("refs"), py::arg("shifts"),
          py::arg("threads"), py::arg("divisor"), py::arg("out"),
          py::arg("window") = std::pair<long long, long long>{0, 0},
          "Writes the (n_query, n_ref) float32 difference matrix into out (rows = queries), with the translation "
          "window (columns, rows).");
    register_route_filter(m);
}
