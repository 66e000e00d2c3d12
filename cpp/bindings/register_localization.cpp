// pybind11 glue for the per-frame path of the robot: frame preparation (nightloc/prepare.hpp)
// and the heat-map sequence kernels (nightloc/heatmap.hpp). Checks every input and releases the
// GIL around the work. The documented API is python/nightloc (preparation.py, sequence.py,
// localizer.py); this is their private engine (see _core.pyi).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <tuple>

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

py::array prepare_frame(const py::array& frame, const std::string& order_name, const std::tuple<std::size_t, std::size_t, std::size_t, std::size_t>& crop,
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

}  // namespace

void register_localization(py::module_& m) {
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
