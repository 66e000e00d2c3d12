// The frame files of a log that nightloc_replay reads: binary PNM (netpbm P5 grey, P6 RGB) always,
// PNG through libpng where the program was built with it (CMake option NIGHTLOC_PNG). 8-bit only:
// the core prepares 8-bit frames. Pixels come out as Python's nightloc reads them (an alpha
// channel dropped, a palette expanded to RGB, 1/2/4-bit grey scaled to 8 bits), in RGB order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace nightloc_app {

/// A decoded frame: `channels` (1 grey, 3 RGB) bytes per pixel, rows packed.
struct FrameImage {
    std::size_t width = 0, height = 0, channels = 0;
    std::vector<std::uint8_t> pixels;
};

/// The most pixels a frame may have (a camera frame, not a poster): larger headers are refused
/// before any allocation.
constexpr std::size_t kMaxFramePixels = std::size_t{1} << 28;

/// How a frame file is read, by its name's suffix (case-insensitive).
enum class FrameKind {
    pnm,    ///< .pgm, .ppm, .pnm
    png,    ///< .png
    other,  ///< any other image format nightloc reads (JPEG, BMP, TIFF, ...): not read here
};
FrameKind frame_kind(const std::string& name);

/// True when `name` has a suffix of an image format nightloc reads (Python's IMAGE_SUFFIXES).
bool is_image_name(const std::string& name);

/// The version of the libpng this program was built with, or nullptr when it was built without.
const char* png_library_version();

/// Why a PNG frame of the log `log` cannot be read by a program built without libpng, and the two
/// ways to replay it (export-log, or a build with libpng).
std::string png_unavailable(const std::string& log);

/// Reads `path` into `image` (its buffer reused: no allocation for frames of one size), choosing
/// the decoder by the file's first bytes (P5/P6 or the PNG signature). Throws
/// std::runtime_error naming the file and the problem: another format, an ASCII or bitmap PNM, a
/// malformed header, a 16-bit image, a PNM maxval other than 255, truncated or corrupt data, a
/// PNG where the program has no libpng.
void read_frame(const std::string& path, FrameImage& image);

/// The binary PNM reader (P5/P6, maxval 255; comments allowed in the header).
void read_pnm(const std::string& path, FrameImage& image);

/// The PNG reader (libpng); where the program was built without it, throws the error that names
/// the fix.
void read_png(const std::string& path, FrameImage& image);

}  // namespace nightloc_app
