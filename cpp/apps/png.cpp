// PNG reading for nightloc_replay (frame_files.hpp) through libpng, where the program is built with
// it (NIGHTLOC_HAVE_PNG); otherwise read_png names the two ways to replay the log.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "frame_files.hpp"

#if NIGHTLOC_HAVE_PNG
#include <png.h>

#include <csetjmp>
#endif

namespace nightloc_app {

#if NIGHTLOC_HAVE_PNG

namespace {

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};

// libpng reports errors through this handler, which returns to decode()'s setjmp with the message.
struct PngFailure {
    char message[200] = "corrupt PNG data";
};

void on_error(png_structp png, png_const_charp message) {
    auto* failure = static_cast<PngFailure*>(png_get_error_ptr(png));
    std::snprintf(failure->message, sizeof failure->message, "%s", message);
    png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}  // as OpenCV: warnings (e.g. a bad sRGB chunk) ignored

// The decoding between setjmp and libpng's longjmp: only trivially destructible objects live in
// this frame, so the jump skips no destructor. Returns "" or the problem.
std::string decode(std::FILE* file, FrameImage& image, std::vector<png_bytep>& rows) {
    PngFailure failure;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &failure, on_error, on_warning);
    if (png == nullptr) return "libpng could not start (out of memory)";
    png_infop info = png_create_info_struct(png);
    if (info == nullptr) {
        png_destroy_read_struct(&png, nullptr, nullptr);
        return "libpng could not start (out of memory)";
    }
    const char* volatile problem = nullptr;  // set before a jump of our own
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        return problem != nullptr ? problem : failure.message;
    }
    png_init_io(png, file);
    png_read_info(png, info);
    const int depth = png_get_bit_depth(png, info), colour = png_get_color_type(png, info);
    const std::size_t width = png_get_image_width(png, info), height = png_get_image_height(png, info);
    if (depth == 16) {
        problem = "a 16-bit PNG; the firmware path prepares 8-bit frames only";
        png_longjmp(png, 1);
    }
    if (width * height > kMaxFramePixels) {
        problem = "the image is larger than a camera frame can be";
        png_longjmp(png, 1);
    }
    // The pixels as OpenCV decodes them for nightloc (IMREAD_ANYCOLOR): a palette expanded to
    // RGB, grey below 8 bits scaled to 8, an alpha channel (or a tRNS chunk) dropped, no gamma.
    if (colour == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if ((colour & PNG_COLOR_MASK_COLOR) == 0 && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    png_set_strip_alpha(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    const std::size_t channels = png_get_channels(png, info);
    if ((channels != 1 && channels != 3) || png_get_rowbytes(png, info) != width * channels) {
        problem = "an unexpected PNG layout after decoding";
        png_longjmp(png, 1);
    }
    image.width = width;
    image.height = height;
    image.channels = channels;
    image.pixels.resize(width * height * channels);  // bounded by kMaxFramePixels above
    rows.resize(height);
    for (std::size_t r = 0; r < height; ++r) rows[r] = image.pixels.data() + r * width * channels;
    png_read_image(png, rows.data());
    png_read_end(png, nullptr);
    png_destroy_read_struct(&png, &info, nullptr);
    return "";
}

}  // namespace

const char* png_library_version() { return PNG_LIBPNG_VER_STRING; }

void read_png(const std::string& path, FrameImage& image) {
    std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
    if (!file) throw std::runtime_error(path + ": cannot be opened: " + std::strerror(errno));
    std::vector<png_bytep> rows;
    const std::string problem = decode(file.get(), image, rows);
    if (!problem.empty()) throw std::runtime_error(path + ": " + problem);
}

#else

const char* png_library_version() { return nullptr; }

void read_png(const std::string& path, FrameImage&) { throw std::runtime_error(path + ": " + png_unavailable("LOG")); }

#endif

}  // namespace nightloc_app
