// Which frame files nightloc_replay reads, and the reader for each (frame_files.hpp).
#include "frame_files.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <memory>
#include <stdexcept>

namespace nightloc_app {

namespace {

std::string suffix_of(const std::string& name) {
    const std::size_t dot = name.rfind('.');
    std::string suffix = dot == std::string::npos ? "" : name.substr(dot);
    for (char& c : suffix) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return suffix;
}

// The suffixes of python/nightloc/io/images.py IMAGE_SUFFIXES: every file nightloc lists as a frame
// (tests/firmware/test_replay.py checks that each is a frame here too).
const char* const kImageSuffixes[] = {".png",  ".jpg",  ".jpeg", ".jpe", ".bmp",  ".dib",  ".tif",
                                      ".tiff", ".webp", ".pgm",  ".ppm", ".pbm",  ".pnm",  ".pxm",
                                      ".sr",   ".ras",  ".jp2",  ".gif", ".apng", ".avif", ".pam"};

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};

}  // namespace

FrameKind frame_kind(const std::string& name) {
    const std::string suffix = suffix_of(name);
    if (suffix == ".pgm" || suffix == ".ppm" || suffix == ".pnm") return FrameKind::pnm;
    if (suffix == ".png") return FrameKind::png;
    return FrameKind::other;
}

bool is_image_name(const std::string& name) {
    const std::string suffix = suffix_of(name);
    return std::any_of(std::begin(kImageSuffixes), std::end(kImageSuffixes),
                       [&](const char* s) { return suffix == s; });
}

std::string png_unavailable(const std::string& log) {
    return "this nightloc_replay was built without libpng, so it reads PGM/PPM frames only: convert the log with "
           "`nightloc export-log " +
           log +
           " NEW_LOG` (PGM/PPM frames, the odometry rows renamed to match) and replay NEW_LOG, or rebuild "
           "nightloc_replay with libpng (Debian/Ubuntu: apt-get install libpng-dev, then cmake -DNIGHTLOC_PNG=ON)";
}

void read_frame(const std::string& path, FrameImage& image) {
    unsigned char head[8] = {0};
    {
        std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
        if (!file) throw std::runtime_error(path + ": cannot be opened: " + std::strerror(errno));
        if (std::fread(head, 1, sizeof head, file.get()) < 2) {
            throw std::runtime_error(path + ": not an image (" +
                                     (std::ferror(file.get()) ? "unreadable" : "too short") + ")");
        }
    }
    static const unsigned char png_signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (std::equal(std::begin(png_signature), std::end(png_signature), head)) {
        read_png(path, image);
    } else if (head[0] == 'P' && head[1] >= '1' && head[1] <= '7') {
        read_pnm(path, image);  // names a PNM kind it does not read
    } else {
        throw std::runtime_error(path + ": not a " + (png_library_version() ? "PNG, PGM or PPM" : "PGM or PPM") +
                                 " image, whatever its name says (convert the log's frames: nightloc export-log)");
    }
}

}  // namespace nightloc_app
