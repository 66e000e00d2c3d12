// A reader of binary PNM images (netpbm): P5 (grey) and P6 (RGB), 8-bit (maxval 255), for
// nightloc_replay. Comments (# to the end of a line) are allowed in the header.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace nightloc_app {

/// A decoded image: `channels` (1 grey, 3 RGB) bytes per pixel, rows packed.
struct PnmImage {
    std::size_t width = 0, height = 0, channels = 0;
    std::vector<std::uint8_t> pixels;
};

/// Reads `path` into `image` (its buffer reused: no allocation for frames of one size).
/// Throws std::runtime_error naming the file and the problem: not P5/P6 (an ASCII or bitmap
/// PNM, or another format), a malformed header, a 16-bit image (maxval > 255) or maxval other
/// than 255, or pixel data shorter than the header says.
void read_pnm(const std::string& path, PnmImage& image);

}  // namespace nightloc_app
