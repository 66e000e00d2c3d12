// Patch normalization (Mount & Milford eq. 1) and OpenSeqSLAM block normalization.
#include "nightloc/normalize.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace nightloc {
namespace {

void check_stack(std::size_t count, std::size_t height, std::size_t width) {
    (void)count;
    if (height == 0 || width == 0) throw std::invalid_argument("images must have at least one row and one column");
}

// clip(floor(value + 0.5), 0, 255). For value + 0.5 in [1, 255) floor is truncation, which
// (unlike std::floor on baseline x86-64, a libm call) compiles to one instruction.
std::uint8_t quantize(double value) {
    const double shifted = value + 0.5;
    if (!(shifted >= 1.0)) return 0;  // also maps NaN to 0 (cannot happen: sigma > 0 is checked)
    if (shifted >= 255.0) return 255;
    return static_cast<std::uint8_t>(static_cast<int>(shifted));
}

// Window sums for one image, exact in 64-bit integers. Horizontal sums slide along each row
// (with wrap-around the index runs modulo the width, so a window wider than the image counts
// pixels as often as it covers them); vertical sums come from column prefix sums.
struct WindowSums {
    std::vector<std::int64_t> sum, squares, count;                       // per pixel, row-major
    std::vector<std::int64_t> prefix_sum, prefix_squares, prefix_count;  // (height + 1) x width
    std::vector<std::ptrdiff_t> entering, leaving;  // wrap-around column indices of the sliding window

    // long: the exact window sums' three passes over one image (sliding row sums, column prefix
    // sums, window totals), sharing their indices
    void compute(const std::uint8_t* src, std::size_t height, std::size_t width, int radius, bool wrap) {
        const std::size_t pixels = height * width;
        sum.assign(pixels, 0);
        squares.assign(pixels, 0);
        count.assign(pixels, 0);
        const auto w = static_cast<std::ptrdiff_t>(width);
        const auto r = static_cast<std::ptrdiff_t>(radius);
        auto wrapped = [w](std::ptrdiff_t x) { return ((x % w) + w) % w; };
        if (wrap) {  // columns entering and leaving the sliding window, once per image (no division per pixel)
            entering.resize(width);
            leaving.resize(width);
            for (std::ptrdiff_t x = 0; x < w; ++x) {
                entering[static_cast<std::size_t>(x)] = wrapped(x + r + 1);
                leaving[static_cast<std::size_t>(x)] = wrapped(x - r);
            }
        }
        for (std::size_t y = 0; y < height; ++y) {
            const std::uint8_t* row = src + y * width;
            std::int64_t* hs = sum.data() + y * width;
            std::int64_t* hq = squares.data() + y * width;
            std::int64_t* hn = count.data() + y * width;
            if (wrap) {
                std::int64_t s = 0, q = 0;
                for (std::ptrdiff_t dx = -r; dx <= r; ++dx) {
                    const std::int64_t v = row[wrapped(dx)];
                    s += v;
                    q += v * v;
                }
                for (std::ptrdiff_t x = 0; x < w; ++x) {
                    hs[x] = s;
                    hq[x] = q;
                    hn[x] = 2 * r + 1;
                    const std::int64_t in = row[entering[static_cast<std::size_t>(x)]];
                    const std::int64_t out = row[leaving[static_cast<std::size_t>(x)]];
                    s += in - out;
                    q += in * in - out * out;
                }
            } else {
                for (std::ptrdiff_t x = 0; x < w; ++x) {
                    const std::ptrdiff_t lo = x - r < 0 ? 0 : x - r;
                    const std::ptrdiff_t hi = x + r >= w ? w - 1 : x + r;
                    std::int64_t s = 0, q = 0;
                    if (x == 0 || lo == 0) {
                        for (std::ptrdiff_t xx = lo; xx <= hi; ++xx) {
                            s += row[xx];
                            q += std::int64_t{row[xx]} * row[xx];
                        }
                    } else {  // slide from x - 1: drop lo - 1, add hi if it is new
                        const std::int64_t out = row[lo - 1];
                        s = hs[x - 1] - out;
                        q = hq[x - 1] - out * out;
                        if (x + r < w) {
                            s += row[hi];
                            q += std::int64_t{row[hi]} * row[hi];
                        }
                    }
                    hs[x] = s;
                    hq[x] = q;
                    hn[x] = hi - lo + 1;
                }
            }
        }
        // Column prefix sums, then the clipped vertical window.
        prefix_sum.assign((height + 1) * width, 0);
        prefix_squares.assign((height + 1) * width, 0);
        prefix_count.assign((height + 1) * width, 0);
        for (std::size_t y = 0; y < height; ++y) {
            for (std::size_t x = 0; x < width; ++x) {
                prefix_sum[(y + 1) * width + x] = prefix_sum[y * width + x] + sum[y * width + x];
                prefix_squares[(y + 1) * width + x] = prefix_squares[y * width + x] + squares[y * width + x];
                prefix_count[(y + 1) * width + x] = prefix_count[y * width + x] + count[y * width + x];
            }
        }
        const auto h = static_cast<std::ptrdiff_t>(height);
        for (std::ptrdiff_t y = 0; y < h; ++y) {
            const auto y0 = static_cast<std::size_t>(y - r < 0 ? 0 : y - r);
            const auto y1 = static_cast<std::size_t>(y + r >= h ? h : y + r + 1);
            for (std::size_t x = 0; x < width; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * width + x;
                sum[i] = prefix_sum[y1 * width + x] - prefix_sum[y0 * width + x];
                squares[i] = prefix_squares[y1 * width + x] - prefix_squares[y0 * width + x];
                count[i] = prefix_count[y1 * width + x] - prefix_count[y0 * width + x];
            }
        }
    }
};

// One image: z = (x - S/n) / sqrt(Q/n - (S/n)^2) = (n x - S) / sqrt(n Q - S^2), n^2 * variance
// being exact in integers, then quantized.
void patch_normalize_image(const std::uint8_t* src, std::uint8_t* dst, std::size_t height, std::size_t width,
                           int radius, bool wrap, double scale, WindowSums& window) {
    window.compute(src, height, width, radius, wrap);
    const std::size_t pixels = height * width;
    for (std::size_t i = 0; i < pixels; ++i) {
        const std::int64_t n = window.count[i], s = window.sum[i];
        const std::int64_t spread = n * window.squares[i] - s * s;
        double z = 0.0;
        if (spread > 0) z = static_cast<double>(n * src[i] - s) / std::sqrt(static_cast<double>(spread));
        dst[i] = quantize(128.0 + scale * z);
    }
}

// Matlab's round(): half away from zero.
double round_half_away(double v) { return v < 0.0 ? -std::floor(-v + 0.5) : std::floor(v + 0.5); }

}  // namespace

void patch_normalize(const std::uint8_t* src, std::uint8_t* dst, std::size_t count, std::size_t height,
                     std::size_t width, int radius, bool wrap, double scale) {
    check_stack(count, height, width);
    if (radius < 0 || radius > kMaxPatchRadius) {
        throw std::invalid_argument("radius must be in [0, " + std::to_string(kMaxPatchRadius) + "], got " +
                                    std::to_string(radius));
    }
    if (!(scale > 0.0) || !std::isfinite(scale)) {
        throw std::invalid_argument("scale must be a positive finite number");
    }
    const std::size_t pixels = height * width;
    WindowSums window;
    for (std::size_t i = 0; i < count; ++i) {
        patch_normalize_image(src + i * pixels, dst + i * pixels, height, width, radius, wrap, scale, window);
    }
}

void block_normalize(const std::uint8_t* src, std::uint8_t* dst, std::size_t count, std::size_t height,
                     std::size_t width, int side) {
    check_stack(count, height, width);
    if (side < 2) throw std::invalid_argument("block side must be >= 2, got " + std::to_string(side));
    const auto s = static_cast<std::size_t>(side);
    const std::size_t pixels = height * width;
    const double n = static_cast<double>(s * s);
    for (std::size_t i = 0; i < count; ++i) {
        const std::uint8_t* in = src + i * pixels;
        std::uint8_t* out = dst + i * pixels;
        if (out != in) {
            for (std::size_t p = 0; p < pixels; ++p) out[p] = in[p];  // incomplete border blocks stay as they are
        }
        for (std::size_t by = 0; by + s <= height; by += s) {
            for (std::size_t bx = 0; bx + s <= width; bx += s) {
                std::int64_t total = 0;
                for (std::size_t y = by; y < by + s; ++y)
                    for (std::size_t x = bx; x < bx + s; ++x) total += in[y * width + x];
                const double mean = static_cast<double>(total) / n;
                double squares = 0.0;
                // Column-major order, as Matlab's p(:) (the sum is exact for 8x8 blocks anyway).
                for (std::size_t x = bx; x < bx + s; ++x) {
                    for (std::size_t y = by; y < by + s; ++y) {
                        const double d = static_cast<double>(in[y * width + x]) - mean;
                        squares += d * d;
                    }
                }
                const double sd = std::sqrt(squares / (n - 1.0));
                for (std::size_t y = by; y < by + s; ++y) {
                    for (std::size_t x = bx; x < bx + s; ++x) {
                        std::uint8_t value = 0;  // flat block: z = 0/0 = NaN, and Matlab's uint8(NaN) is 0
                        if (sd > 0.0) {
                            const double z = (static_cast<double>(in[y * width + x]) - mean) / sd;
                            const double v = 127.0 + round_half_away(z);
                            value = v <= 0.0 ? 0 : (v >= 255.0 ? 255 : static_cast<std::uint8_t>(v));
                        }
                        out[y * width + x] = value;
                    }
                }
            }
        }
    }
}

}  // namespace nightloc
