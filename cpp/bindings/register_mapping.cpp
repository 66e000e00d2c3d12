// pybind11 glue for the teach run (nightloc.mapping): min-warping costs of pairs of frames.
// Checks every input's dtype, shape and layout (the core checks the values) and releases the
// GIL around the work. The documented API is python/nightloc/mapping/warping.py.
#include <cstdint>
#include <stdexcept>
#include <string>

#include "glue.hpp"
#include "nightloc/map_file.hpp"
#include "nightloc/warp.hpp"

namespace {

using nightloc::glue::CArray;
using nightloc::glue::checked_array;
using nightloc::glue::extent;
using nightloc::glue::shape_text;
using nightloc::glue::without_gil;

void require_shape(const py::array& a, const char* name, std::initializer_list<py::ssize_t> shape, const char* axes) {
    py::ssize_t axis = 0;
    for (const py::ssize_t expected : shape) {
        if (a.shape(axis) != expected) {
            throw py::value_error(std::string(name) + " must have shape " + axes + ", got " + shape_text(a));
        }
        ++axis;
    }
}

py::array_t<double> warp_costs(const py::array& images_in, const py::array& stacks_in, const py::array& row_begin_in,
                               const py::array& row_end_in, const py::array& level_in, const py::array& sign_in,
                               const py::array& pairs_in, const py::array& first_direction_in, int n_directions,
                               const py::array& first_shift_in, int n_shifts, int threads) {
    const auto images = checked_array<std::uint8_t>(images_in, "images", 3, "(n, h, w)");
    nightloc::glue::require_images(images, "images");
    const auto stacks = checked_array<std::uint8_t>(stacks_in, "stacks", 4, "(n, scales, h, w)");
    const py::ssize_t n = images.shape(0), h = images.shape(1), w = images.shape(2), scales = stacks.shape(1);
    require_shape(stacks, "stacks", {n, scales, h, w}, "(n, scales, h, w) of the images' n, h, w");
    const auto row_begin = checked_array<std::int32_t>(row_begin_in, "row_begin", 1, "(scales,)");
    const auto row_end = checked_array<std::int32_t>(row_end_in, "row_end", 1, "(scales,)");
    require_shape(row_begin, "row_begin", {scales}, "(scales,)");
    require_shape(row_end, "row_end", {scales}, "(scales,)");
    const auto level = checked_array<std::int32_t>(level_in, "level", 3, "(directions, w, moves)");
    const py::ssize_t directions = level.shape(0), moves = level.shape(2);
    require_shape(level, "level", {directions, w, moves}, "(directions, w, moves) of the images' w");
    const auto sign = checked_array<std::int32_t>(sign_in, "sign", 2, "(directions, w)");
    require_shape(sign, "sign", {directions, w}, "(directions, w)");
    const auto pairs = checked_array<std::int32_t>(pairs_in, "pairs", 2, "(n_pairs, 2)");
    const py::ssize_t n_pairs = pairs.shape(0);
    require_shape(pairs, "pairs", {n_pairs, 2}, "(n_pairs, 2)");
    const auto first_direction = checked_array<std::int32_t>(first_direction_in, "first_direction", 1, "(n_pairs,)");
    const auto first_shift = checked_array<std::int32_t>(first_shift_in, "first_shift", 1, "(n_pairs,)");
    require_shape(first_direction, "first_direction", {n_pairs}, "(n_pairs,)");
    require_shape(first_shift, "first_shift", {n_pairs}, "(n_pairs,)");
    if (n_directions < 1 || n_shifts < 1) {
        throw py::value_error("n_directions and n_shifts must be >= 1, got " + std::to_string(n_directions) + " and " +
                              std::to_string(n_shifts));
    }
    nightloc::WarpGeometry geometry;
    geometry.height = extent(images, 1);
    geometry.width = extent(images, 2);
    geometry.scales = extent(stacks, 1);
    geometry.directions = extent(level, 0);
    geometry.moves = extent(level, 2);
    geometry.row_begin = row_begin.data();
    geometry.row_end = row_end.data();
    geometry.level = level.data();
    geometry.sign = sign.data();
    py::array_t<double> out({n_pairs, static_cast<py::ssize_t>(n_directions), static_cast<py::ssize_t>(n_shifts)});
    double* result = out.mutable_data();
    const std::uint8_t* image_data = images.data();
    const std::uint8_t* stack_data = stacks.data();
    const std::int32_t* pair_data = pairs.data();
    const std::int32_t* direction_data = first_direction.data();
    const std::int32_t* shift_data = first_shift.data();
    const std::size_t frames = extent(images, 0), count = extent(pairs, 0);
    // std::invalid_argument (values out of range) reaches Python as ValueError.
    without_gil([&] {
        nightloc::warp_costs(image_data, stack_data, frames, geometry, pair_data, count, direction_data,
                             static_cast<std::size_t>(n_directions), shift_data, static_cast<std::size_t>(n_shifts),
                             result, threads);
    });
    return out;
}

}  // namespace

void register_mapping(py::module_& m) {
    m.attr("MAP_FORMAT_VERSION") = nightloc::kMapFormatVersion;
    m.attr("DAY_MAP_FORMAT_VERSION") = nightloc::kDayMapFormatVersion;
    m.def("warp_costs", &warp_costs, py::arg("images"), py::arg("stacks"), py::arg("row_begin"), py::arg("row_end"),
          py::arg("level"), py::arg("sign"), py::arg("pairs"), py::arg("first_direction"), py::arg("n_directions"),
          py::arg("first_shift"), py::arg("n_shifts"), py::arg("threads") = 1,
          "Min-warping costs (n_pairs, n_directions, n_shifts) float64 of pairs of prepared panoramas "
          "(nightloc/warp.hpp).");
}
