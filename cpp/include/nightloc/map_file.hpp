// Reading the map file that `nightloc build-map` writes (ReferenceMap.save, format 3 or 4), without
// Python, zlib or OpenCV: an uncompressed zip (numpy's .npz) of .npy arrays with a JSON header
// (python/nightloc/io/map_file.py and python/nightloc/localization/filter_tables.py
// describe the layout).
//
//   const nightloc::MapFile map = nightloc::load_map_file("garden.map");
//   nightloc::Localizer localizer(map);                  // nightloc/localizer.hpp
//
// What is checked, each failure a MapFileError naming the file and the problem: a regular,
// readable file; a zip archive whose members are stored (a compressed member is refused, naming
// its method) and whose CRC-32s match; .npy arrays of the expected type and shape; the header's
// format, its version (3, or 4: an experience map, which adds each reference's provenance; older
// maps lack the localizer's tables and are refused with the command that re-saves them; newer ones
// ask for a newer firmware), its parameters, and the SHA-256 checksum of every array the header lists.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "nightloc/grid_filter.hpp"
#include "nightloc/prepare.hpp"

namespace nightloc {

/// The newest map format version, the one an experience map is written as (python reads it:
/// nightloc.io.map_file.MAP_FORMAT_VERSION).
inline constexpr int kMapFormatVersion = 4;
/// The version a map without learned nights is written as (python: DAY_MAP_FORMAT_VERSION): the
/// first with the localizer's tables.
inline constexpr int kDayMapFormatVersion = 3;
/// The oldest version this reader reads: the first with the localizer's tables.
inline constexpr int kMinMapFormatVersion = kDayMapFormatVersion;

/// A map file that cannot be used: the message names the file and the problem.
class MapFileError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// How the map's images were prepared (python: nightloc.PreparationParams, stored in the map: the
/// fields the core holds by the names of setting_fields<PrepareSettings>(), a missing one taking
/// PrepareSettings' default, as Python's PreparationParams does; channel_order and crop, which
/// every map holds).
struct MapPreparation {
    std::size_t width = PrepareSettings{}.width, height = PrepareSettings{}.height;  ///< prepared image size, pixels
    int radius = PrepareSettings{}.radius;                                           ///< patch-normalization radius
    bool wrap = PrepareSettings{}.wrap;                                              ///< 360-degree panoramas
    std::string equalize;  ///< "global", "clahe" or "none" (equalization_name)
    bool patch_normalize = PrepareSettings{}.patch_normalize;
    double scale = PrepareSettings{}.scale;
    std::string channel_order;  ///< "bgr" or "rgb": the order the frames' pixels are given in
    /// crop (top, bottom, left, right): pixels, or fractions of the height / width when `fraction`
    double crop[4] = {0, 0, 0, 0};
    bool crop_fraction[4] = {false, false, false, false};

    /// The core's settings for frames of `frame_height` x `frame_width` pixels (the crop in
    /// pixels: a fraction f of a side of n pixels is round_half_even(f n), as Python's round).
    /// Throws MapFileError for CLAHE (not in the core: firmware cannot prepare for such a map).
    PrepareSettings settings(std::size_t frame_height, std::size_t frame_width) const;
};

/// The default localizer's map-only tables (python: nightloc.localization.filter_tables).
struct MapLocalizerTables {
    GridFilterMap map;                      ///< grid, interpolation weights, places, headings, shifts
    GridFilterSettings settings;            ///< what Python's GridFilter gives the core, key for key
    std::size_t grid_width = 0;             ///< cells along x
    std::size_t grid_height = 0;            ///< cells along y
    std::vector<std::int32_t> closest_ref;  ///< per cell: the nearest reference (lowest index of its place)
};

/// A loaded reference map.
struct MapFile {
    std::string path;
    int format_version = 0;
    std::string nightloc_version;      ///< of the nightloc that wrote it
    std::size_t count = 0;             ///< N references
    std::vector<std::uint8_t> images;  ///< N x height x width prepared images, row-major
    std::vector<double> positions;     ///< N x 2 metres
    std::vector<double> headings;      ///< N radians, or empty (no headings)
    std::vector<std::string> names;    ///< N frame names
    /// N: 0 for the day map's references, else the night each was learned on (format 4, an
    /// experience map; empty for format 3). The localizer needs none of it: a place's learned
    /// appearances stand at its position, so the tables group them with it.
    std::vector<std::int32_t> appearance_night;
    MapPreparation preparation;
    std::size_t frame_width = 0;  ///< of the camera frames the map was built from (0: unknown)
    std::size_t frame_height = 0;
    MapLocalizerTables localizer;
};

/// Loads and checks a map file (see the top of this header). Throws MapFileError.
MapFile load_map_file(const std::string& path);

}  // namespace nightloc
