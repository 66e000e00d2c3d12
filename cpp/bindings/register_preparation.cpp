// pybind11 glue for preparation (nightloc.preparation): patch and block normalization of image
// stacks (nightloc/normalize.hpp) and the per-frame preparation of camera frames
// (nightloc/prepare.hpp: crop, grey, equalize, area-downsample, patch-normalize).
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>

#include "glue.hpp"
#include "nightloc/normalize.hpp"
#include "nightloc/prepare.hpp"
#include "settings_glue.hpp"

namespace {

using nightloc::glue::checked_array;
using nightloc::glue::extent;
using nightloc::glue::shape_text;
using nightloc::glue::without_gil;

// An (n, h, w) uint8 stack to a new stack of the same shape by `work(src, dst, n, h, w)`, run
// without the GIL.
template <class Work>
py::array map_stack(const py::array& images_in, Work&& work) {
    const auto images = checked_array<std::uint8_t>(images_in, "images", 3);
    py::array_t<std::uint8_t> out({images.shape(0), images.shape(1), images.shape(2)});
    const std::size_t n = extent(images, 0), h = extent(images, 1), w = extent(images, 2);
    const std::uint8_t* src = images.data();
    std::uint8_t* dst = out.mutable_data();
    without_gil([&] {
        if (n > 0) work(src, dst, n, h, w);
    });
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

nightloc::PixelOrder order_from_name(const std::string& name) {
    if (name == "grey") return nightloc::PixelOrder::grey;
    if (name == "bgr") return nightloc::PixelOrder::bgr;
    if (name == "rgb") return nightloc::PixelOrder::rgb;
    if (name == "bgra") return nightloc::PixelOrder::bgra;
    if (name == "rgba") return nightloc::PixelOrder::rgba;
    throw py::value_error("unknown pixel order '" + name + "'; expected grey, bgr, rgb, bgra or rgba");
}

const char* method_name(nightloc::DownsampleMethod method) {
    switch (method) {
        case nightloc::DownsampleMethod::copy:
            return "copy";
        case nightloc::DownsampleMethod::integral:
            return "integral";
        case nightloc::DownsampleMethod::blocks:
            return "blocks";
        case nightloc::DownsampleMethod::weights:
            return "weights";
        case nightloc::DownsampleMethod::unsupported:
            return "unsupported";
    }
    return "unsupported";
}

// A view of a uint8 (H, W) or (H, W, C) frame with packed pixels (any row stride).
nightloc::FrameView frame_view(const py::array& frame, nightloc::PixelOrder order) {
    if (!nightloc::glue::has_dtype<std::uint8_t>(frame)) {
        throw py::type_error("frame must have dtype uint8, got " + nightloc::glue::dtype_text(frame));
    }
    const std::size_t channels = nightloc::pixel_bytes(order);
    const bool grey = order == nightloc::PixelOrder::grey;
    if (grey ? frame.ndim() != 2 : (frame.ndim() != 3 || frame.shape(2) != static_cast<py::ssize_t>(channels))) {
        throw py::value_error("frame of shape " + shape_text(frame) + " does not hold " +
                              (grey ? std::string("grey (H, W)") : "(H, W, " + std::to_string(channels) + ")") +
                              " pixels");
    }
    const std::size_t height = extent(frame, 0), width = extent(frame, 1);
    const bool packed = frame.strides(1) == static_cast<py::ssize_t>(channels) && (grey || frame.strides(2) == 1);
    const py::ssize_t row_stride = height > 1 ? frame.strides(0) : static_cast<py::ssize_t>(width * channels);
    if (!packed || row_stride < static_cast<py::ssize_t>(width * channels)) {
        throw py::value_error("frame pixels must be packed row by row (use numpy.ascontiguousarray)");
    }
    return {static_cast<const std::uint8_t*>(frame.data()), height, width, static_cast<std::size_t>(row_stride), order};
}

// `settings` by value: a copy that other Python threads cannot change while the GIL is released.
py::array prepare_frame(const py::array& frame, const std::string& order_name, nightloc::PrepareSettings settings) {
    const nightloc::FrameView view = frame_view(frame, order_from_name(order_name));
    nightloc::validate(settings);
    const auto height = static_cast<py::ssize_t>(settings.height), width = static_cast<py::ssize_t>(settings.width);
    py::array_t<std::uint8_t> out({height, width});
    std::uint8_t* o = out.mutable_data();
    without_gil([&] {
        // one workspace per thread: its buffers (a grey copy of the frame) are reused across frames
        // (std::invalid_argument becomes ValueError)
        thread_local nightloc::PrepareWorkspace workspace;
        nightloc::prepare_frame(view, settings, o, workspace);
    });
    return std::move(out);
}

}  // namespace

void register_preparation(py::module_& m) {
    nightloc::glue::bind_settings<nightloc::PrepareSettings>(
        m, "PrepareSettings",
        "What prepare_frame does, with the core's defaults (nightloc/prepare.hpp); setting a field checks its kind "
        "and range, validate() the rest.");
    m.attr("DEFAULT_PATCH_SCALE") = nightloc::kDefaultPatchScale;
    m.attr("MAX_PATCH_RADIUS") = nightloc::kMaxPatchRadius;
    m.def("patch_normalize", &patch_normalize, py::arg("images"), py::arg("radius"), py::arg("wrap"), py::arg("scale"));
    m.def("block_normalize", &block_normalize, py::arg("images"), py::arg("side"));
    m.def("prepare_frame", &prepare_frame, py::arg("frame"), py::arg("order"), py::arg("settings"),
          "Crop, grey, equalize, area-downsample and patch-normalize one uint8 frame (nightloc/prepare.hpp).");
    m.def(
        "downsample_method",
        [](std::size_t in_height, std::size_t in_width, std::size_t out_height, std::size_t out_width) {
            return std::string(method_name(nightloc::downsample_method(in_height, in_width, out_height, out_width)));
        },
        py::arg("in_height"), py::arg("in_width"), py::arg("out_height"), py::arg("out_width"),
        "How prepare_frame downsamples: copy, integral, blocks, weights or unsupported (upsampling).");
}
