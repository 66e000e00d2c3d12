// pybind11 glue for localization (nightloc.localization): heat-map interpolation weights, the
// translated sum of a frame sequence with its peak search (nightloc/heatmap.hpp), and the
// translation kernel itself.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "glue.hpp"
#include "nightloc/heatmap.hpp"

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

}  // namespace

void register_localization(py::module_& m) {
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
