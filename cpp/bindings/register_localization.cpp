// pybind11 glue for localization (nightloc.localization): heat-map interpolation weights, the
// translated sum of a frame sequence with its peak search (nightloc/heatmap.hpp), the
// translation kernel itself, and the grid Bayes filter (nightloc/grid_filter.hpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "glue.hpp"
#include "nightloc/grid_filter.hpp"
#include "nightloc/heatmap.hpp"
#include "nightloc/localizer.hpp"
#include "settings_glue.hpp"

namespace {

using nightloc::glue::checked_array;
using nightloc::glue::without_gil;

// A C-contiguous 1-D array of T.
template <class T>
nightloc::glue::CArray<T> checked_vector(const py::array& a, const char* name) {
    return checked_array<T>(a, name, 1);
}

template <class T>
std::vector<T> vector_of(const py::array& a, const char* name) {
    const auto v = checked_vector<T>(a, name);
    return std::vector<T>(v.data(), v.data() + v.size());
}

// out += source translated, on flat buffers of `height` rows `stride` elements apart.
template <class T>
void add_translated_typed(const py::array& out_in, const py::array& source_in, std::size_t height, std::size_t width,
                          std::size_t stride, double shift_x, double shift_y) {
    const auto source = checked_vector<T>(source_in, "source");
    const auto out = checked_vector<T>(out_in, "out");
    nightloc::glue::require_writable(out_in, "out");
    if (height == 0 || width == 0 || stride < width) throw py::value_error("invalid map layout");
    const std::size_t needed = (height - 1) * stride + width;
    if (static_cast<std::size_t>(source.size()) < needed || static_cast<std::size_t>(out.size()) < needed) {
        throw py::value_error("buffers hold fewer than height x stride elements");
    }
    const T* src = source.data();
    py::array writable = out_in;  // a second handle: mutable_data() is non-const
    T* dst = static_cast<T*>(writable.mutable_data());
    without_gil([&] { nightloc::add_translated(src, stride, dst, stride, height, width, shift_x, shift_y); });
}

void add_translated(const py::array& out, const py::array& source, std::size_t height, std::size_t width,
                    std::size_t stride, double shift_x, double shift_y) {
    if (nightloc::glue::has_dtype<float>(out)) {
        add_translated_typed<float>(out, source, height, width, stride, shift_x, shift_y);
    } else if (nightloc::glue::has_dtype<double>(out)) {
        add_translated_typed<double>(out, source, height, width, stride, shift_x, shift_y);
    } else {
        throw py::type_error("out must have dtype float32 or float64, got " + nightloc::glue::dtype_text(out));
    }
}

using Weights = std::shared_ptr<nightloc::HeatWeights>;  // pybind11 holders are non-const

Weights make_weights(std::size_t height, std::size_t width, std::size_t n_places, const py::array& indptr,
                     const py::array& indices, const py::array& data) {
    return std::make_shared<nightloc::HeatWeights>(height, width, n_places, vector_of<std::int32_t>(indptr, "indptr"),
                                                   vector_of<std::int32_t>(indices, "indices"),
                                                   vector_of<float>(data, "data"));
}

py::array map_copy(const float* values, std::size_t height, std::size_t width) {
    py::array_t<float> out({static_cast<py::ssize_t>(height), static_cast<py::ssize_t>(width)});
    std::copy(values, values + height * width, out.mutable_data());
    return std::move(out);
}

// A HeatSequence with the peak exclusion of its localizer.
class Sequence {
public:
    Sequence(Weights weights, std::size_t capacity, std::size_t rows, std::size_t cols, const py::array& mask)
        : weights_(weights), sequence_(std::move(weights), capacity) {
        exclusion_.rows = rows;
        exclusion_.cols = cols;
        exclusion_.mask = vector_of<std::uint8_t>(mask, "mask");
        if (exclusion_.mask.size() != (2 * rows + 1) * (2 * cols + 1)) {
            throw py::value_error("mask must hold (2 rows + 1) x (2 cols + 1) flags");
        }
    }

    void push(const py::array& values_in, double fill) {
        const auto values = checked_vector<float>(values_in, "place values");
        if (static_cast<std::size_t>(values.size()) != sequence_.weights().places()) {
            throw py::value_error("place values must have " + std::to_string(sequence_.weights().places()) +
                                  " entries, got " + std::to_string(values.size()));
        }
        const float* v = values.data();
        without_gil([&] { sequence_.push(v, fill); });
    }

    // (fill sum, cell, peak, floor, second or None) of the fused map.
    py::tuple fuse_peak(const py::array& offsets_in) {
        if (sequence_.size() == 0) throw py::value_error("the sequence is empty");
        if (!nightloc::glue::has_dtype<double>(offsets_in) || offsets_in.ndim() != 2 || offsets_in.shape(1) != 2 ||
            !(offsets_in.flags() & py::array::c_style)) {
            throw py::type_error("offsets must be a C-contiguous float64 (k, 2) array");
        }
        if (static_cast<std::size_t>(offsets_in.shape(0)) != sequence_.size() - 1) {
            throw py::value_error("offsets must have one row per earlier frame (" +
                                  std::to_string(sequence_.size() - 1) + "), got " +
                                  std::to_string(offsets_in.shape(0)));
        }
        const auto* offsets = static_cast<const double*>(offsets_in.data());
        for (py::ssize_t i = 0; i < 2 * offsets_in.shape(0); ++i) {
            if (!std::isfinite(offsets[i])) throw py::value_error("offsets must be finite");
        }
        double fill_sum = 0.0;
        nightloc::HeatPeak peak;
        without_gil([&] {
            fill_sum = sequence_.fuse(offsets);
            const auto& w = sequence_.weights();
            peak = nightloc::find_peak(sequence_.fused(), w.height(), w.width(), exclusion_);
        });
        if (!peak.finite) throw py::value_error("heat map contains NaN or infinity");
        return py::make_tuple(fill_sum, peak.cell, peak.peak, peak.floor,
                              peak.has_second ? py::object(py::float_(peak.second)) : py::object(py::none()));
    }

    // Pickling: (weights, capacity, exclusion, frames (k, h, w) float32, fills)
    py::tuple state(const Weights& weights) const {
        const auto& w = sequence_.weights();
        py::array_t<float> frames({static_cast<py::ssize_t>(sequence_.size()), static_cast<py::ssize_t>(w.height()),
                                   static_cast<py::ssize_t>(w.width())});
        std::vector<double> fills;
        for (std::size_t k = 0; k < sequence_.size(); ++k) {
            std::copy(sequence_.frame(k), sequence_.frame(k) + w.cells(), frames.mutable_data() + k * w.cells());
            fills.push_back(sequence_.fill(k));
        }
        py::array_t<std::uint8_t> mask(static_cast<py::ssize_t>(exclusion_.mask.size()));
        std::copy(exclusion_.mask.begin(), exclusion_.mask.end(), mask.mutable_data());
        return py::make_tuple(weights, sequence_.capacity(), exclusion_.rows, exclusion_.cols, mask, frames, fills);
    }

    void restore(const py::array& frames_in, const std::vector<double>& fills) {
        const auto& w = sequence_.weights();
        if (!nightloc::glue::has_dtype<float>(frames_in) || frames_in.ndim() != 3 ||
            static_cast<std::size_t>(frames_in.shape(0)) != fills.size() ||
            static_cast<std::size_t>(frames_in.shape(1)) != w.height() ||
            static_cast<std::size_t>(frames_in.shape(2)) != w.width()) {
            throw py::value_error("saved frames do not fit this sequence's grid");
        }
        const auto frames = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(frames_in);
        for (std::size_t k = 0; k < fills.size(); ++k) sequence_.push_map(frames.data() + k * w.cells(), fills[k]);
    }

    py::array fused() const {
        return map_copy(sequence_.fused(), sequence_.weights().height(), sequence_.weights().width());
    }
    py::array frame(std::ptrdiff_t k) const {
        return map_copy(sequence_.frame(index(k)), sequence_.weights().height(), sequence_.weights().width());
    }
    double fill(std::ptrdiff_t k) const { return sequence_.fill(index(k)); }
    void clear() { sequence_.clear(); }
    std::size_t size() const { return sequence_.size(); }
    std::size_t capacity() const { return sequence_.capacity(); }

private:
    std::size_t index(std::ptrdiff_t k) const {  // Python-style: -1 = newest
        const auto n = static_cast<std::ptrdiff_t>(sequence_.size());
        if (k < -n || k >= n) throw py::index_error("frame index out of range");
        return static_cast<std::size_t>(k < 0 ? k + n : k);
    }

public:
    const Weights& weights() const { return weights_; }

private:
    Weights weights_;
    nightloc::HeatSequence sequence_;
    nightloc::PeakExclusion exclusion_;
};

// ---------------------------------------------------------------------------------------------
// the grid Bayes filter

// Motion codes of GridFilter.step/predict: what the frame's odometry says.
enum MotionKind : int { kNoMotion = 0, kUnknown = 1, kMapMotion = 2, kRobotMotion = 3 };

py::array_t<float, py::array::c_style> checked_table(const py::array& a, std::size_t n_refs, std::size_t n_shifts) {
    if (!py::isinstance<py::array_t<float>>(a)) {
        throw py::type_error("table must have dtype float32, got " + std::string(py::str(a.dtype())));
    }
    if (a.ndim() != 2 || static_cast<std::size_t>(a.shape(0)) != n_refs ||
        static_cast<std::size_t>(a.shape(1)) != n_shifts) {
        throw py::value_error("table must be (" + std::to_string(n_refs) + ", " + std::to_string(n_shifts) +
                              ") (references, shifts), got shape " + nightloc::glue::shape_text(a));
    }
    if (!(a.flags() & py::array::c_style)) throw py::value_error("table must be C-contiguous");
    const auto t = py::reinterpret_borrow<py::array_t<float, py::array::c_style>>(a);
    const float* v = t.data();
    for (std::size_t i = 0; i < n_refs * n_shifts; ++i) {
        if (!std::isfinite(v[i])) {
            throw py::value_error("table holds NaN or infinity (reference " + std::to_string(i / n_shifts) +
                                  "); the filter's belief is unchanged");
        }
    }
    return t;
}

class GridFilterPy {
public:
    GridFilterPy(Weights weights, double x0, double y0, double dx, double dy, const py::array& place_of_ref,
                 const py::object& ref_headings, std::size_t columns, const py::array& shifts,
                 const nightloc::GridFilterSettings& settings, double field_of_view, std::size_t window_columns,
                 std::size_t window_rows)
        : filter_(make_map(std::move(weights), x0, y0, dx, dy, place_of_ref, ref_headings, columns, shifts,
                           field_of_view, window_columns, window_rows),
                  settings) {}

    void reset() { filter_.reset(); }
    void set_noise(double distance_std, double heading_std, double distance_per_metre, double heading_per_radian) {
        filter_.set_noise(distance_std, heading_std, distance_per_metre, heading_per_radian);
    }

    void set_learned(const py::array& learned) { filter_.set_learned(vector_of<std::uint8_t>(learned, "learned")); }

    void predict(int kind, double a, double b, double c) {
        check_motion(kind, a, b, c);
        py::gil_scoped_release release;
        predict_locked(kind, a, b, c);
    }

    // One frame: prediction by the motion, the measurement from a prepared image against refs,
    // the estimate. Returns (estimate tuple, min scores (n_refs,) float32, best shifts int32).
    py::tuple step_image(const py::array& query_in, const py::array& refs_in, int kind, double a, double b, double c,
                         int threads) {
        if (!py::isinstance<py::array_t<std::uint8_t>>(query_in) ||
            !py::isinstance<py::array_t<std::uint8_t>>(refs_in)) {
            throw py::type_error("query and refs must have dtype uint8");
        }
        if (query_in.ndim() != 2 || refs_in.ndim() != 3 || !(query_in.flags() & py::array::c_style) ||
            !(refs_in.flags() & py::array::c_style)) {
            throw py::value_error("query must be a C-contiguous (H, W) and refs an (N, H, W) uint8 array");
        }
        if (static_cast<std::size_t>(refs_in.shape(0)) != filter_.n_refs() || refs_in.shape(1) != query_in.shape(0) ||
            refs_in.shape(2) != query_in.shape(1)) {
            throw py::value_error("refs " + nightloc::glue::shape_text(refs_in) + " do not fit the query " +
                                  nightloc::glue::shape_text(query_in) + " and the filter's " +
                                  std::to_string(filter_.n_refs()) + " references");
        }
        check_motion(kind, a, b, c);
        const auto* q = static_cast<const std::uint8_t*>(query_in.data());
        const auto* r = static_cast<const std::uint8_t*>(refs_in.data());
        const auto h = static_cast<std::size_t>(query_in.shape(0));
        nightloc::GridEstimate e;
        {
            py::gil_scoped_release release;
            predict_locked(kind, a, b, c);
            filter_.update_image(q, r, filter_.n_refs(), h, threads);
            e = filter_.estimate();
        }
        return result(e);
    }

    py::tuple step_table(const py::array& table_in, int kind, double a, double b, double c) {
        const auto table = checked_table(table_in, filter_.n_refs(), filter_.n_shifts());
        check_motion(kind, a, b, c);
        const float* t = table.data();
        nightloc::GridEstimate e;
        {
            py::gil_scoped_release release;
            predict_locked(kind, a, b, c);
            filter_.update(t);
            e = filter_.estimate();
        }
        return result(e);
    }

    // step_table, and the prior it measured: the prediction's marginal over heading (height,
    // width) float64 summing to 1, before the frame.
    py::tuple step_table_with_prior(const py::array& table_in, int kind, double a, double b, double c) {
        const auto table = checked_table(table_in, filter_.n_refs(), filter_.n_shifts());
        check_motion(kind, a, b, c);
        const float* t = table.data();
        py::array_t<double> prior(
            {static_cast<py::ssize_t>(filter_.height()), static_cast<py::ssize_t>(filter_.width())});
        double* p = prior.mutable_data();
        nightloc::GridEstimate e;
        {
            py::gil_scoped_release release;
            predict_locked(kind, a, b, c);
            copy_marginal(p);  // makes the pending prediction; the update then measures it in place
            filter_.update(t);
            e = filter_.estimate();
        }
        return py::make_tuple(result(e), std::move(prior));
    }

    py::tuple estimate() const {
        nightloc::GridEstimate e;
        {
            py::gil_scoped_release release;
            e = filter_.estimate();
        }
        return estimate_tuple(e);
    }

    // The marginal over heading (height, width) float64, summing to 1.
    py::array marginal() const {
        py::array_t<double> out(
            {static_cast<py::ssize_t>(filter_.height()), static_cast<py::ssize_t>(filter_.width())});
        double* o = out.mutable_data();
        {
            py::gil_scoped_release release;
            copy_marginal(o);
        }
        return std::move(out);
    }

    // The marginal over heading into out (height x width doubles), summing to 1; a pending
    // prediction is made here. Called without the GIL.
    void copy_marginal(double* out) const {
        const float* m = filter_.marginal();
        const double scale = filter_.scale();
        for (std::size_t c = 0; c < filter_.height() * filter_.width(); ++c) out[c] = m[c] * scale;
    }

    // The belief (active bins, height, width) float64, summing to 1.
    py::array belief() const {
        const std::size_t bins = filter_.active_bins(), cells = filter_.height() * filter_.width();
        py::array_t<double> out({static_cast<py::ssize_t>(bins), static_cast<py::ssize_t>(filter_.height()),
                                 static_cast<py::ssize_t>(filter_.width())});
        const float* v = nullptr;
        double scale = 1;
        {
            py::gil_scoped_release release;  // a pending prediction is made here
            v = filter_.belief();
            scale = filter_.scale();
        }
        double* o = out.mutable_data();
        for (std::size_t c = 0; c < bins * cells; ++c) o[c] = v[c] * scale;
        return std::move(out);
    }

    void set_belief(const py::array& belief_in, bool pose, double offset) {
        const std::size_t bins = pose ? filter_.heading_bins() : 1;
        if (!py::isinstance<py::array_t<float>>(belief_in) || belief_in.ndim() != 3 ||
            static_cast<std::size_t>(belief_in.shape(0)) != bins ||
            static_cast<std::size_t>(belief_in.shape(1)) != filter_.height() ||
            static_cast<std::size_t>(belief_in.shape(2)) != filter_.width() ||
            !(belief_in.flags() & py::array::c_style)) {
            throw py::value_error("belief must be a C-contiguous float32 (" + std::to_string(bins) + ", " +
                                  std::to_string(filter_.height()) + ", " + std::to_string(filter_.width()) +
                                  ") array");
        }
        filter_.set_belief(static_cast<const float*>(belief_in.data()), pose, offset);
    }

    py::array table() const {
        py::array_t<float> out(
            {static_cast<py::ssize_t>(filter_.n_refs()), static_cast<py::ssize_t>(filter_.n_shifts())});
        std::copy(filter_.table().begin(), filter_.table().end(), out.mutable_data());
        return std::move(out);
    }

    const nightloc::GridFilter& core() const { return filter_; }

private:
    static nightloc::GridFilterMap make_map(Weights weights, double x0, double y0, double dx, double dy,
                                            const py::array& place_of_ref, const py::object& ref_headings,
                                            std::size_t columns, const py::array& shifts, double field_of_view,
                                            std::size_t window_columns, std::size_t window_rows) {
        nightloc::GridFilterMap map;
        map.weights = std::move(weights);
        map.x0 = x0;
        map.y0 = y0;
        map.dx = dx;
        map.dy = dy;
        map.place_of_ref = vector_of<std::int32_t>(place_of_ref, "place_of_ref");
        if (!ref_headings.is_none())
            map.ref_headings = vector_of<double>(ref_headings.cast<py::array>(), "ref_headings");
        map.columns = columns;
        map.shifts = vector_of<std::int32_t>(shifts, "shifts");
        map.field_of_view = field_of_view;
        map.window = {window_columns, window_rows};
        return map;
    }

    void check_motion(int kind, double a, double b, double c) const {
        if (kind < kNoMotion || kind > kRobotMotion) throw py::value_error("unknown motion kind");
        if (!std::isfinite(a) || !std::isfinite(b) || !std::isfinite(c)) throw py::value_error("motion must be finite");
        if (kind == kRobotMotion && !filter_.can_pose()) {
            throw py::value_error(
                "robot-frame odometry (RobotMotion) needs heading bins, and this filter has none (the map has no "
                "headings, or it is not a full panorama, or heading_bins is 1); pass map-frame displacements");
        }
    }

    void predict_locked(int kind, double a, double b, double c) {
        switch (kind) {
            case kUnknown:
                filter_.predict_unknown();
                break;
            case kMapMotion:
                filter_.predict_map(a, b);
                break;
            case kRobotMotion:
                filter_.predict_robot(a, b, c);
                break;
            default:
                break;
        }
    }

    static py::tuple estimate_tuple(const nightloc::GridEstimate& e) {
        return py::make_tuple(e.x, e.y, e.heading, e.cov_xx, e.cov_xy, e.cov_yy, e.credible_radius, e.confidence,
                              e.cell, e.flat, e.heading_var);
    }

    py::tuple result(const nightloc::GridEstimate& e) const {
        const auto n = static_cast<py::ssize_t>(filter_.n_refs());
        py::array_t<float> mins(n);
        py::array_t<std::int32_t> shifts(n);
        std::copy(filter_.min_scores().begin(), filter_.min_scores().end(), mins.mutable_data());
        std::copy(filter_.best_shifts().begin(), filter_.best_shifts().end(), shifts.mutable_data());
        return py::make_tuple(estimate_tuple(e), mins, shifts);
    }

    nightloc::GridFilter filter_;
};

}  // namespace

void register_localization(py::module_& m) {
    nightloc::glue::bind_settings<nightloc::GridFilterSettings>(
        m, "GridFilterSettings",
        "The grid filter's settings with the core's defaults (nightloc/grid_filter.hpp); setting a field checks its "
        "kind and range.");
    const nightloc::OdometryNoise& wheel = nightloc::kWheelOdometryNoise;
    m.attr("WHEEL_ODOMETRY_NOISE") =
        py::make_tuple(wheel.distance_std, wheel.heading_std, wheel.distance_per_metre, wheel.heading_per_radian);
    py::class_<GridFilterPy>(m, "GridFilter",
                             "The grid Bayes filter over position x heading (nightloc/grid_filter.hpp).")
        .def(py::init<Weights, double, double, double, double, const py::array&, const py::object&, std::size_t,
                      const py::array&, const nightloc::GridFilterSettings&, double, std::size_t, std::size_t>(),
             py::arg("weights"), py::arg("x0"), py::arg("y0"), py::arg("dx"), py::arg("dy"), py::arg("place_of_ref"),
             py::arg("ref_headings"), py::arg("columns"), py::arg("shifts"), py::arg("settings"),
             py::arg("field_of_view") = 0.0, py::arg("window_columns") = 0, py::arg("window_rows") = 0)
        .def("reset", &GridFilterPy::reset)
        .def(
            "__copy__", [](const GridFilterPy& f) { return GridFilterPy(f); },
            "An independent filter in the same state, bit for bit (the map's weights are shared: immutable).")
        .def("set_learned", &GridFilterPy::set_learned, py::arg("learned"))
        .def("set_noise", &GridFilterPy::set_noise, py::arg("distance_std"), py::arg("heading_std"),
             py::arg("distance_per_metre") = 0.0, py::arg("heading_per_radian") = 0.0)
        .def("predict", &GridFilterPy::predict, py::arg("kind"), py::arg("a"), py::arg("b"), py::arg("c"))
        .def("step_image", &GridFilterPy::step_image, py::arg("query"), py::arg("refs"), py::arg("kind"), py::arg("a"),
             py::arg("b"), py::arg("c"), py::arg("threads"))
        .def("step_table", &GridFilterPy::step_table, py::arg("table"), py::arg("kind"), py::arg("a"), py::arg("b"),
             py::arg("c"))
        .def("step_table_with_prior", &GridFilterPy::step_table_with_prior, py::arg("table"), py::arg("kind"),
             py::arg("a"), py::arg("b"), py::arg("c"))
        .def("estimate", &GridFilterPy::estimate)
        .def("marginal", &GridFilterPy::marginal)
        .def("belief", &GridFilterPy::belief)
        .def("set_belief", &GridFilterPy::set_belief, py::arg("belief"), py::arg("pose"), py::arg("offset"))
        .def("table", &GridFilterPy::table)
        .def_property_readonly("pose_mode", [](const GridFilterPy& f) { return f.core().pose_mode(); })
        .def_property_readonly("can_pose", [](const GridFilterPy& f) { return f.core().can_pose(); })
        .def_property_readonly("heading_bins", [](const GridFilterPy& f) { return f.core().heading_bins(); })
        .def_property_readonly(
            "settings", [](const GridFilterPy& f) { return f.core().settings(); },
            "A copy of the settings the filter runs with (heading_bins 0 resolved to the image's columns).")
        .def_property_readonly("offset", [](const GridFilterPy& f) { return f.core().offset(); })
        .def_property_readonly("lambda_", [](const GridFilterPy& f) { return f.core().lambda(); })
        .def_property_readonly("frames", [](const GridFilterPy& f) { return f.core().frames(); })
        .def_property_readonly("score_cap", [](const GridFilterPy& f) { return f.core().score_cap(); })
        .def_property_readonly("forward", [](const GridFilterPy& f) { return f.core().forward(); })
        .def_property_readonly("sparse_blocks", [](const GridFilterPy& f) { return f.core().sparse_blocks(); })
        .def_property_readonly("memory_bytes", [](const GridFilterPy& f) { return f.core().memory_bytes(); });

    m.def("add_translated", &add_translated, py::arg("out"), py::arg("source"), py::arg("height"), py::arg("width"),
          py::arg("stride"), py::arg("shift_x"), py::arg("shift_y"),
          "out += source translated by (shift_x, shift_y) cells, bilinear, zero beyond the grid "
          "(flat float32/float64 buffers, rows `stride` apart; nightloc/heatmap.hpp).");
    py::class_<nightloc::HeatWeights, Weights>(m, "HeatWeights",
                                               "Sparse interpolation weights of a heat-map grid (CSR, float32).")
        .def(py::init(&make_weights), py::arg("height"), py::arg("width"), py::arg("n_places"), py::arg("indptr"),
             py::arg("indices"), py::arg("data"))
        .def_property_readonly("height", &nightloc::HeatWeights::height)
        .def_property_readonly("width", &nightloc::HeatWeights::width)
        .def_property_readonly("places", &nightloc::HeatWeights::places)
        .def(py::pickle(
            [](const nightloc::HeatWeights& w) {
                const auto& c = w.csr();
                return py::make_tuple(
                    w.height(), w.width(), w.places(),
                    py::array_t<std::int32_t>(static_cast<py::ssize_t>(c.indptr.size()), c.indptr.data()),
                    py::array_t<std::int32_t>(static_cast<py::ssize_t>(c.indices.size()), c.indices.data()),
                    py::array_t<float>(static_cast<py::ssize_t>(c.data.size()), c.data.data()));
            },
            [](const py::tuple& t) {
                if (t.size() != 6) throw py::value_error("invalid HeatWeights state");
                return make_weights(t[0].cast<std::size_t>(), t[1].cast<std::size_t>(), t[2].cast<std::size_t>(),
                                    t[3].cast<py::array>(), t[4].cast<py::array>(), t[5].cast<py::array>());
            }))
        .def(
            "interpolate",
            [](const nightloc::HeatWeights& w, const py::array& values_in) {
                const auto values = checked_vector<float>(values_in, "place values");
                if (static_cast<std::size_t>(values.size()) != w.places()) {
                    throw py::value_error("place values must have " + std::to_string(w.places()) + " entries");
                }
                py::array_t<float> out({static_cast<py::ssize_t>(w.height()), static_cast<py::ssize_t>(w.width())});
                float* o = out.mutable_data();
                const float* v = values.data();
                without_gil([&] { w.interpolate(v, o); });
                return out;
            },
            py::arg("values"), "The (height, width) float32 map of per-place values.");
    py::class_<Sequence>(m, "HeatSequence", "The excess heat maps of the last frames and their translated sum.")
        .def(py::init<Weights, std::size_t, std::size_t, std::size_t, const py::array&>(), py::arg("weights"),
             py::arg("capacity"), py::arg("exclusion_rows"), py::arg("exclusion_cols"), py::arg("exclusion_mask"))
        .def("push", &Sequence::push, py::arg("place_values"), py::arg("fill"))
        .def("fuse_peak", &Sequence::fuse_peak, py::arg("offsets"))
        .def("fused", &Sequence::fused)
        .def("frame", &Sequence::frame, py::arg("k"))
        .def("fill", &Sequence::fill, py::arg("k"))
        .def("clear", &Sequence::clear)
        .def(py::pickle([](const Sequence& q) { return q.state(q.weights()); },
                        [](const py::tuple& t) {
                            if (t.size() != 7) throw py::value_error("invalid HeatSequence state");
                            Sequence q(t[0].cast<Weights>(), t[1].cast<std::size_t>(), t[2].cast<std::size_t>(),
                                       t[3].cast<std::size_t>(), t[4].cast<py::array>());
                            q.restore(t[5].cast<py::array>(), t[6].cast<std::vector<double>>());
                            return q;
                        }))
        .def_property_readonly("size", &Sequence::size)
        .def_property_readonly("capacity", &Sequence::capacity);
}
