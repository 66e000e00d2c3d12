// pybind11 glue for the per-frame path of the robot: frame preparation (nightloc/prepare.hpp)
// and the heat-map sequence kernels (nightloc/heatmap.hpp). Checks every input and releases the
// GIL around the work. The documented API is python/nightloc (preparation.py, sequence.py,
// localizer.py); this is their private engine (see _core.pyi).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "nightloc/heatmap.hpp"
#include "nightloc/prepare.hpp"

namespace py = pybind11;

namespace {

std::string shape_string(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
    return s + (a.ndim() == 1 ? ",)" : ")");
}

nightloc::PixelOrder order_from_name(const std::string& name) {
    if (name == "grey") return nightloc::PixelOrder::grey;
    if (name == "bgr") return nightloc::PixelOrder::bgr;
    if (name == "rgb") return nightloc::PixelOrder::rgb;
    if (name == "bgra") return nightloc::PixelOrder::bgra;
    if (name == "rgba") return nightloc::PixelOrder::rgba;
    throw py::value_error("unknown pixel order '" + name + "'; expected grey, bgr, rgb, bgra or rgba");
}

nightloc::Equalization equalization_from_name(const std::string& name) {
    if (name == "global") return nightloc::Equalization::global;
    if (name == "none") return nightloc::Equalization::none;
    throw py::value_error("the core equalizes 'global' or 'none', got '" + name + "' (CLAHE runs in OpenCV)");
}

const char* method_name(nightloc::DownsampleMethod method) {
    switch (method) {
        case nightloc::DownsampleMethod::copy: return "copy";
        case nightloc::DownsampleMethod::integral: return "integral";
        case nightloc::DownsampleMethod::blocks: return "blocks";
        case nightloc::DownsampleMethod::weights: return "weights";
        case nightloc::DownsampleMethod::unsupported: return "unsupported";
    }
    return "unsupported";
}

// A view of a uint8 (H, W) or (H, W, C) frame with packed pixels (any row stride).
nightloc::FrameView frame_view(const py::array& frame, nightloc::PixelOrder order) {
    if (!py::isinstance<py::array_t<std::uint8_t>>(frame)) {
        throw py::type_error("frame must have dtype uint8, got " + std::string(py::str(frame.dtype())));
    }
    const std::size_t channels = nightloc::pixel_bytes(order);
    const bool grey = order == nightloc::PixelOrder::grey;
    if (grey ? frame.ndim() != 2 : (frame.ndim() != 3 || frame.shape(2) != static_cast<py::ssize_t>(channels))) {
        throw py::value_error("frame of shape " + shape_string(frame) + " does not hold " +
                              (grey ? std::string("grey (H, W)") : "(H, W, " + std::to_string(channels) + ")") +
                              " pixels");
    }
    const auto height = static_cast<std::size_t>(frame.shape(0));
    const auto width = static_cast<std::size_t>(frame.shape(1));
    const bool packed = frame.strides(1) == static_cast<py::ssize_t>(channels) && (grey || frame.strides(2) == 1);
    const py::ssize_t row_stride = height > 1 ? frame.strides(0) : static_cast<py::ssize_t>(width * channels);
    if (!packed || row_stride < static_cast<py::ssize_t>(width * channels)) {
        throw py::value_error("frame pixels must be packed row by row (use numpy.ascontiguousarray)");
    }
    return {static_cast<const std::uint8_t*>(frame.data()), height, width, static_cast<std::size_t>(row_stride), order};
}

using Crop = std::tuple<std::size_t, std::size_t, std::size_t, std::size_t>;  // top, bottom, left, right

py::array prepare_frame(const py::array& frame, const std::string& order_name, const Crop& crop,
                        const std::string& equalize, std::size_t width, std::size_t height, bool normalize, int radius,
                        bool wrap, double scale) {
    const nightloc::FrameView view = frame_view(frame, order_from_name(order_name));
    nightloc::PrepareSettings settings;
    std::tie(settings.crop_top, settings.crop_bottom, settings.crop_left, settings.crop_right) = crop;
    settings.equalize = equalization_from_name(equalize);
    settings.width = width;
    settings.height = height;
    settings.normalize = normalize;
    settings.radius = radius;
    settings.wrap = wrap;
    settings.scale = scale;
    py::array_t<std::uint8_t> out({static_cast<py::ssize_t>(height), static_cast<py::ssize_t>(width)});
    std::uint8_t* o = out.mutable_data();
    {
        py::gil_scoped_release release;
        // one workspace per thread: its buffers (a grey copy of the frame) are reused across frames
        // (std::invalid_argument becomes ValueError)
        thread_local nightloc::PrepareWorkspace workspace;
        nightloc::prepare_frame(view, settings, o, workspace);
    }
    return std::move(out);
}

// ---------------------------------------------------------------------------------------------
// heat maps

template <class T>
py::array_t<T, py::array::c_style> checked_vector(const py::array& a, const char* name, const char* dtype) {
    if (!py::isinstance<py::array_t<T>>(a)) {
        throw py::type_error(std::string(name) + " must have dtype " + dtype + ", got " +
                             std::string(py::str(a.dtype())));
    }
    if (a.ndim() != 1) throw py::value_error(std::string(name) + " must be 1-D, got shape " + shape_string(a));
    if (!(a.flags() & py::array::c_style)) throw py::value_error(std::string(name) + " must be C-contiguous");
    return py::reinterpret_borrow<py::array_t<T, py::array::c_style>>(a);
}

template <class T>
std::vector<T> vector_of(const py::array& a, const char* name, const char* dtype) {
    const auto v = checked_vector<T>(a, name, dtype);
    return std::vector<T>(v.data(), v.data() + v.size());
}

// out += source translated, on flat buffers of `height` rows `stride` elements apart.
template <class T>
void add_translated_typed(const py::array& out_in, const py::array& source_in, std::size_t height, std::size_t width,
                          std::size_t stride, double shift_x, double shift_y) {
    const char* dtype = sizeof(T) == 4 ? "float32" : "float64";
    const auto source = checked_vector<T>(source_in, "source", dtype);
    const auto out = checked_vector<T>(out_in, "out", dtype);
    if (!out_in.writeable()) throw py::value_error("out must be writable");
    if (height == 0 || width == 0 || stride < width) throw py::value_error("invalid map layout");
    const std::size_t needed = (height - 1) * stride + width;
    if (static_cast<std::size_t>(source.size()) < needed || static_cast<std::size_t>(out.size()) < needed) {
        throw py::value_error("buffers hold fewer than height x stride elements");
    }
    const T* src = source.data();
    py::array writable = out_in;  // a second handle: mutable_data() is non-const
    T* dst = static_cast<T*>(writable.mutable_data());
    py::gil_scoped_release release;
    nightloc::add_translated(src, stride, dst, stride, height, width, shift_x, shift_y);
}

void add_translated(const py::array& out, const py::array& source, std::size_t height, std::size_t width,
                    std::size_t stride, double shift_x, double shift_y) {
    if (py::isinstance<py::array_t<float>>(out)) {
        add_translated_typed<float>(out, source, height, width, stride, shift_x, shift_y);
    } else if (py::isinstance<py::array_t<double>>(out)) {
        add_translated_typed<double>(out, source, height, width, stride, shift_x, shift_y);
    } else {
        throw py::type_error("out must have dtype float32 or float64, got " + std::string(py::str(out.dtype())));
    }
}

using Weights = std::shared_ptr<nightloc::HeatWeights>;  // pybind11 holders are non-const

Weights make_weights(std::size_t height, std::size_t width, std::size_t n_places, const py::array& indptr,
                     const py::array& indices, const py::array& data) {
    return std::make_shared<nightloc::HeatWeights>(height, width, n_places,
                                                         vector_of<std::int32_t>(indptr, "indptr", "int32"),
                                                         vector_of<std::int32_t>(indices, "indices", "int32"),
                                                         vector_of<float>(data, "data", "float32"));
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
        exclusion_.mask = vector_of<std::uint8_t>(mask, "mask", "uint8");
        if (exclusion_.mask.size() != (2 * rows + 1) * (2 * cols + 1)) {
            throw py::value_error("mask must hold (2 rows + 1) x (2 cols + 1) flags");
        }
    }

    void push(const py::array& values_in, double fill) {
        const auto values = checked_vector<float>(values_in, "place values", "float32");
        if (static_cast<std::size_t>(values.size()) != sequence_.weights().places()) {
            throw py::value_error("place values must have " + std::to_string(sequence_.weights().places()) +
                                  " entries, got " + std::to_string(values.size()));
        }
        const float* v = values.data();
        py::gil_scoped_release release;
        sequence_.push(v, fill);
    }

    // (fill sum, cell, peak, floor, second or None) of the fused map.
    py::tuple fuse_peak(const py::array& offsets_in) {
        if (sequence_.size() == 0) throw py::value_error("the sequence is empty");
        if (!py::isinstance<py::array_t<double>>(offsets_in) || offsets_in.ndim() != 2 || offsets_in.shape(1) != 2 ||
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
        double fill_sum;
        nightloc::HeatPeak peak;
        {
            py::gil_scoped_release release;
            fill_sum = sequence_.fuse(offsets);
            const auto& w = sequence_.weights();
            peak = nightloc::find_peak(sequence_.fused(), w.height(), w.width(), exclusion_);
        }
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
        if (!py::isinstance<py::array_t<float>>(frames_in) || frames_in.ndim() != 3 ||
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
                const auto values = checked_vector<float>(values_in, "place values", "float32");
                if (static_cast<std::size_t>(values.size()) != w.places()) {
                    throw py::value_error("place values must have " + std::to_string(w.places()) + " entries");
                }
                py::array_t<float> out({static_cast<py::ssize_t>(w.height()), static_cast<py::ssize_t>(w.width())});
                float* o = out.mutable_data();
                const float* v = values.data();
                {
                    py::gil_scoped_release release;
                    w.interpolate(v, o);
                }
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

    m.def("prepare_frame", &prepare_frame, py::arg("frame"), py::arg("order"), py::arg("crop"), py::arg("equalize"),
          py::arg("width"), py::arg("height"), py::arg("normalize"), py::arg("radius"), py::arg("wrap"),
          py::arg("scale"),
          "Crop, grey, equalize, area-downsample and patch-normalize one uint8 frame (nightloc/prepare.hpp).");
    m.def(
        "downsample_method",
        [](std::size_t in_height, std::size_t in_width, std::size_t out_height, std::size_t out_width) {
            return std::string(method_name(nightloc::downsample_method(in_height, in_width, out_height, out_width)));
        },
        py::arg("in_height"), py::arg("in_width"), py::arg("out_height"), py::arg("out_width"),
        "How prepare_frame downsamples: copy, integral, blocks, weights or unsupported (upsampling).");
}
