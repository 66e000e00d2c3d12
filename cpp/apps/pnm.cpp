// Binary PNM (P5/P6) reading for nightloc_replay (frame_files.hpp).
#include "frame_files.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>

namespace nightloc_app {

namespace {

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};

// The next header number: whitespace and comments skipped; the byte after it is consumed.
std::size_t header_number(std::FILE* f, const std::string& path, const char* what) {
    int c = std::fgetc(f);
    for (;;) {
        while (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f') c = std::fgetc(f);
        if (c != '#') break;
        while (c != '\n' && c != EOF) c = std::fgetc(f);
    }
    if (c < '0' || c > '9') throw std::runtime_error(path + ": malformed PNM header (no " + std::string(what) + ")");
    std::size_t value = 0;
    while (c >= '0' && c <= '9') {
        if (value > 100000000) throw std::runtime_error(path + ": PNM " + std::string(what) + " is too large");
        value = value * 10 + static_cast<std::size_t>(c - '0');
        c = std::fgetc(f);
    }
    if (c != ' ' && c != '\t' && c != '\n' && c != '\r' && c != '\v' && c != '\f' && c != '#') {
        throw std::runtime_error(path + ": malformed PNM header after the " + std::string(what));
    }
    if (c == '#') {
        while (c != '\n' && c != EOF) c = std::fgetc(f);
    }
    return value;
}

}  // namespace

void read_pnm(const std::string& path, FrameImage& image) {
    std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
    if (!file) throw std::runtime_error(path + ": cannot be opened: " + std::strerror(errno));
    std::FILE* f = file.get();
    char magic[2] = {0, 0};
    if (std::fread(magic, 1, 2, f) != 2 || magic[0] != 'P') {
        throw std::runtime_error(path + ": not a PNM image (PGM P5 or PPM P6 expected)");
    }
    if (magic[1] != '5' && magic[1] != '6') {
        throw std::runtime_error(path + ": PNM type P" + std::string(1, magic[1]) +
                                 " is not supported; binary PGM (P5) or PPM (P6) only");
    }
    image.channels = magic[1] == '5' ? 1 : 3;
    image.width = header_number(f, path, "width");
    image.height = header_number(f, path, "height");
    const std::size_t maxval = header_number(f, path, "maxval");
    if (image.width == 0 || image.height == 0) throw std::runtime_error(path + ": the image has no pixels");
    if (maxval > 255) {
        throw std::runtime_error(path + ": a 16-bit PNM (maxval " + std::to_string(maxval) +
                                 "); the firmware path prepares 8-bit frames only (maxval 255)");
    }
    if (maxval != 255) {
        throw std::runtime_error(path + ": PNM maxval " + std::to_string(maxval) +
                                 "; 8-bit frames with maxval 255 are expected");
    }
    if (image.width * image.height > kMaxFramePixels) {
        throw std::runtime_error(path + ": a " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                                 " image is larger than a camera frame can be");
    }
    const std::size_t bytes = image.width * image.height * image.channels;
    image.pixels.resize(bytes);
    if (std::fread(image.pixels.data(), 1, bytes, f) != bytes) {
        throw std::runtime_error(path + ": truncated pixel data (" + std::to_string(bytes) + " bytes expected)");
    }
}

}  // namespace nightloc_app
