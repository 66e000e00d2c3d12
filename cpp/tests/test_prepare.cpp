// C++ tests of frame preparation (nightloc/prepare.hpp), run by ctest. Each step is checked
// against an oracle written here from its documented formula (plain loops over the full frame,
// exact integer or rational arithmetic), and every SIMD path the CPU supports must give the same
// bytes as the scalar path. Bit-identity with the Python/OpenCV pipeline is tested in
// tests/preparation/test_prepare_core.py.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <vector>

#include "check.hpp"

#include <nightloc/nightloc.hpp>
#include <nightloc/prepare.hpp>

namespace {

using Bytes = std::vector<std::uint8_t>;
using nightloc::DownsampleMethod;
using nightloc::Equalization;
using nightloc::FrameView;
using nightloc::PixelOrder;
using nightloc::PrepareSettings;

Bytes random_bytes(std::mt19937& rng, std::size_t n, int lo = 0, int hi = 255) {
    std::uniform_int_distribution<int> dist(lo, hi);
    Bytes b(n);
    for (auto& v : b) v = static_cast<std::uint8_t>(dist(rng));
    return b;
}

// A smooth image with noise (real frames repeat nearby levels; random bytes do not).
Bytes smooth_bytes(std::mt19937& rng, std::size_t h, std::size_t w, std::size_t channels) {
    std::uniform_real_distribution<double> phase(0.0, 6.28);
    const double a = phase(rng), b = phase(rng);
    std::uniform_int_distribution<int> noise(0, 3);
    Bytes out(h * w * channels);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x)
            for (std::size_t c = 0; c < channels; ++c) {
                const double v = 110 + 60 * std::sin(0.02 * static_cast<double>(x) + a + static_cast<double>(c)) +
                                 40 * std::cos(0.03 * static_cast<double>(y) + b);
                out[(y * w + x) * channels + c] = static_cast<std::uint8_t>(std::clamp(v, 0.0, 252.0) + noise(rng));
            }
    return out;
}

std::size_t channels_of(PixelOrder order) { return nightloc::pixel_bytes(order); }

// Oracle grey of one pixel (cv2.cvtColor's 15-bit fixed point, written from its definition).
std::uint8_t grey_oracle(const std::uint8_t* p, PixelOrder order) {
    if (order == PixelOrder::grey) return p[0];
    const bool rgb = order == PixelOrder::rgb || order == PixelOrder::rgba;
    const int b = rgb ? p[2] : p[0], g = p[1], r = rgb ? p[0] : p[2];
    return static_cast<std::uint8_t>((b * 3735 + g * 19235 + r * 9798 + 16384) >> 15);
}

// Oracle: the cropped grey image.
Bytes grey_image(const FrameView& f, const PrepareSettings& s, std::size_t& h, std::size_t& w) {
    h = f.height - s.crop_top - s.crop_bottom;
    w = f.width - s.crop_left - s.crop_right;
    const std::size_t c = channels_of(f.order);
    Bytes grey(h * w);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x)
            grey[y * w + x] = grey_oracle(f.data + (y + s.crop_top) * f.row_stride + (x + s.crop_left) * c, f.order);
    return grey;
}

// Oracle: cv2.equalizeHist from its definition (darkest level -> 0, float32 product, round to even).
Bytes equalize_oracle(const Bytes& grey) {
    std::vector<std::int64_t> hist(256, 0);
    for (auto v : grey) ++hist[v];
    int darkest = 0;
    while (hist[static_cast<std::size_t>(darkest)] == 0) ++darkest;
    const auto total = static_cast<std::int64_t>(grey.size());
    if (hist[static_cast<std::size_t>(darkest)] == total) return grey;
    const float scale = 255.f / static_cast<float>(total - hist[static_cast<std::size_t>(darkest)]);
    Bytes out(grey.size());
    for (std::size_t i = 0; i < grey.size(); ++i) {
        std::int64_t above = 0;
        for (int v = darkest + 1; v <= grey[i]; ++v) above += hist[static_cast<std::size_t>(v)];
        const float value = std::nearbyint(static_cast<float>(above) * scale);
        out[i] = static_cast<std::uint8_t>(std::min(255.f, value));
    }
    return out;
}

// Overlap of input cell i with output cell o along an axis of n_in -> n_out cells, in units of
// 1 / n_out input cells: [o * n_in, (o + 1) * n_in) against [i * n_out, (i + 1) * n_out).
long long overlap(std::size_t o, std::size_t i, std::size_t n_in, std::size_t n_out) {
    const auto lo = static_cast<long long>(std::max(o * n_in, i * n_out));
    const auto hi = static_cast<long long>(std::min((o + 1) * n_in, (i + 1) * n_out));
    return std::max(0LL, hi - lo);
}

// Exact area mean of output cell (a, b): the overlaps are integers in units of 1 / oh and 1 / ow,
// so the weighted sum is exact; one division at the end.
double exact_mean(const Bytes& img, std::size_t h, std::size_t w, std::size_t oh, std::size_t ow, std::size_t a,
                  std::size_t b) {
    long double total = 0;
    for (std::size_t y = a * h / oh; y < std::min(h, ((a + 1) * h + oh - 1) / oh); ++y) {
        for (std::size_t x = b * w / ow; x < std::min(w, ((b + 1) * w + ow - 1) / ow); ++x) {
            total += static_cast<long double>(overlap(a, y, h, oh) * overlap(b, x, w, ow)) * img[y * w + x];
        }
    }
    return static_cast<double>(total / (static_cast<long double>(h) * static_cast<long double>(w)));
}

PrepareSettings settings_for(std::size_t oh, std::size_t ow, Equalization eq, bool normalize) {
    PrepareSettings s;
    s.height = oh;
    s.width = ow;
    s.equalize = eq;
    s.patch_normalize = normalize;
    return s;
}

FrameView grey_view(const Bytes& pixels, std::size_t h, std::size_t w) {
    return {pixels.data(), h, w, w, PixelOrder::grey};
}

Bytes run(const FrameView& f, const PrepareSettings& s, nightloc::PrepareWorkspace& ws) {
    Bytes out(s.height * s.width);
    nightloc::prepare_frame(f, s, out.data(), ws);
    return out;
}

void test_grey_and_equalization_oracles() {
    std::mt19937 rng(11);
    nightloc::PrepareWorkspace ws;
    for (PixelOrder order : {PixelOrder::grey, PixelOrder::bgr, PixelOrder::rgb, PixelOrder::bgra, PixelOrder::rgba}) {
        for (std::size_t w : {1u, 7u, 31u, 64u, 65u, 130u, 257u}) {
            const std::size_t h = 5, c = channels_of(order);
            const Bytes frame = random_bytes(rng, h * w * c);
            const FrameView view{frame.data(), h, w, w * c, order};
            std::size_t gh = 0, gw = 0;
            // same size: the "copy" downsample returns the (equalized) grey frame itself
            const Bytes grey = grey_image(view, settings_for(h, w, Equalization::none, false), gh, gw);
            CHECK(run(view, settings_for(h, w, Equalization::none, false), ws) == grey);
            CHECK(run(view, settings_for(h, w, Equalization::global, false), ws) == equalize_oracle(grey));
        }
    }
    // one grey level keeps it; two levels become 0 and 255
    Bytes flat(40 * 30, 77);
    const PrepareSettings same_size = settings_for(30, 40, Equalization::global, false);
    CHECK(run(grey_view(flat, 30, 40), same_size, ws) == flat);
    flat[5] = 200;
    const Bytes two = run(grey_view(flat, 30, 40), same_size, ws);
    CHECK(two[5] == 255 && two[0] == 0);
}

void test_downsample_methods_against_exact_means() {
    std::mt19937 rng(12);
    nightloc::PrepareWorkspace ws;
    struct Case {
        std::size_t h, w, oh, ow;
        DownsampleMethod method;
    };
    const Case cases[] = {
        {480, 640, 24, 48, DownsampleMethod::integral},  {320, 640, 24, 48, DownsampleMethod::integral},
        {333, 1001, 24, 48, DownsampleMethod::integral}, {960, 1920, 24, 48, DownsampleMethod::blocks},
        {48, 96, 24, 48, DownsampleMethod::blocks},      {72, 240, 24, 48, DownsampleMethod::blocks},
        {100, 97, 24, 48, DownsampleMethod::weights},    {30, 50, 24, 48, DownsampleMethod::weights},
        {24, 48, 24, 48, DownsampleMethod::copy},        {49, 1, 1, 1, DownsampleMethod::weights},
        {20, 40, 24, 48, DownsampleMethod::unsupported},
    };
    for (const Case& c : cases) {
        CHECK(nightloc::downsample_method(c.h, c.w, c.oh, c.ow) == c.method);
        if (c.method == DownsampleMethod::unsupported) {
            const Bytes img = random_bytes(rng, c.h * c.w);
            CHECK_THROWS(run(grey_view(img, c.h, c.w), settings_for(c.oh, c.ow, Equalization::none, false), ws),
                         std::invalid_argument);
            continue;
        }
        for (int trial = 0; trial < 2; ++trial) {
            const Bytes img = trial == 0 ? random_bytes(rng, c.h * c.w) : smooth_bytes(rng, c.h, c.w, 1);
            const Bytes got = run(grey_view(img, c.h, c.w), settings_for(c.oh, c.ow, Equalization::none, false), ws);
            double worst = 0;
            bool blocks_exact = true;
            const std::size_t fy = c.h / c.oh, fx = c.w / c.ow;
            for (std::size_t a = 0; a < c.oh; ++a)
                for (std::size_t b = 0; b < c.ow; ++b) {
                    const double mean = exact_mean(img, c.h, c.w, c.oh, c.ow, a, b);
                    worst = std::max(worst, std::abs(got[a * c.ow + b] - mean));
                    if (c.method == DownsampleMethod::blocks) {  // the documented float32 / half-up rounding
                        long long sum = 0;
                        for (std::size_t y = a * fy; y < (a + 1) * fy; ++y)
                            for (std::size_t x = b * fx; x < (b + 1) * fx; ++x) sum += img[y * c.w + x];
                        const auto expected = fy == 2 && fx == 2
                                                  ? static_cast<std::uint8_t>((sum + 2) >> 2)
                                                  : static_cast<std::uint8_t>(std::nearbyint(
                                                        static_cast<float>(sum) * (1.f / static_cast<float>(fy * fx))));
                        blocks_exact = blocks_exact && got[a * c.ow + b] == expected;
                    }
                }
            // rounded to the nearest level (the float32 paths within a hair of a half)
            CHECK(worst <= 0.5 + 1e-4);
            CHECK(blocks_exact);
        }
    }
}

void test_patch_normalization_and_crop() {
    std::mt19937 rng(13);
    nightloc::PrepareWorkspace ws;
    const std::size_t h = 300, w = 500;
    const Bytes frame = smooth_bytes(rng, h, w, 3);
    PrepareSettings s;
    s.crop_top = 10;
    s.crop_bottom = 30;
    s.crop_left = 25;
    s.crop_right = 1;
    s.radius = 3;
    s.scale = 20.0;
    s.patch_normalize = false;
    const FrameView view{frame.data(), h, w, w * 3, PixelOrder::bgr};
    const Bytes small = run(view, s, ws);
    // the crop equals a frame that starts at the crop
    const FrameView cropped{frame.data() + 10 * w * 3 + 25 * 3, h - 40, w - 26, w * 3, PixelOrder::bgr};
    PrepareSettings uncropped = s;
    uncropped.crop_top = uncropped.crop_bottom = uncropped.crop_left = uncropped.crop_right = 0;
    CHECK(run(cropped, uncropped, ws) == small);
    s.patch_normalize = true;
    const Bytes prepared = run(view, s, ws);
    Bytes expected(small.size());
    nightloc::patch_normalize(small.data(), expected.data(), 1, 24, 48, 3, true, 20.0);
    CHECK(prepared == expected);
    // the vector and allocating overloads agree
    CHECK(nightloc::prepare_frame(view, s) == prepared);
}

void test_every_simd_path_gives_the_same_bytes() {
    std::mt19937 rng(14);
    std::uniform_int_distribution<int> pick(0, 4);
    for (int trial = 0; trial < 60; ++trial) {
        const auto order = static_cast<PixelOrder>(pick(rng));
        const std::size_t c = channels_of(order);
        const std::size_t oh = 1 + static_cast<std::size_t>(rng() % 30), ow = 1 + static_cast<std::size_t>(rng() % 60);
        const std::size_t h = oh + static_cast<std::size_t>(rng() % 500);
        const std::size_t w = ow + static_cast<std::size_t>(rng() % 700);
        const std::size_t pad = rng() % 3;  // row padding bytes
        const Bytes frame = trial % 2 ? random_bytes(rng, h * (w * c + pad)) : smooth_bytes(rng, h, w * c + pad, 1);
        PrepareSettings s = settings_for(oh, ow, trial % 3 ? Equalization::global : Equalization::none, trial % 4 == 0);
        s.crop_left = (h > oh + 4 && w > ow + 4 && trial % 5 == 0) ? 3 : 0;
        s.crop_top = s.crop_left;
        const FrameView view{frame.data(), h, w, w * c + pad, order};
        nightloc::set_simd_backend(nightloc::SimdBackend::scalar);
        nightloc::PrepareWorkspace ws;
        const Bytes reference = run(view, s, ws);
        for (auto backend : nightloc::supported_simd_backends()) {
            nightloc::set_simd_backend(backend);
            const Bytes got = run(view, s, ws);
            CHECK(got == reference);
            if (got != reference) {
                std::fprintf(stderr, "  path %s, %zux%zu order %d -> %zux%zu\n", nightloc::simd_backend_name(backend),
                             h, w, static_cast<int>(order), oh, ow);
            }
        }
    }
    nightloc::reset_simd_backend();
}

void test_band_folding_on_tall_and_wide_frames() {
    // more than 256 rows per output row (the 16-bit band is folded midway), and a frame so wide
    // that fewer rows fit in a band
    std::mt19937 rng(15);
    nightloc::PrepareWorkspace ws;
    const Bytes white(1500 * 6, 255);
    CHECK(run({white.data(), 1500, 6, 6, PixelOrder::grey}, settings_for(2, 3, Equalization::none, false), ws) ==
          Bytes(6, 255));
    const Bytes tall = random_bytes(rng, 1200 * 5);
    const Bytes got = run(grey_view(tall, 1200, 5), settings_for(1, 1, Equalization::none, false), ws);
    long long sum = 0;
    for (auto v : tall) sum += v;
    CHECK(std::abs(got[0] - static_cast<double>(sum) / 6000.0) <= 0.5 + 1e-4);
    const std::size_t wide = 70000;
    const Bytes row = Bytes(wide * 3, 255);
    const Bytes out = run(grey_view(row, 3, wide), settings_for(1, 7, Equalization::none, false), ws);
    CHECK(out == Bytes(7, 255));
}

void test_errors() {
    Bytes img(100 * 100 * 3, 9);
    std::uint8_t out[24 * 48];
    const PrepareSettings ok;
    nightloc::PrepareWorkspace ws;
    const FrameView grey = grey_view(img, 100, 100);
    auto refused = [&](const FrameView& f, const PrepareSettings& s, std::uint8_t* o) {
        try {
            nightloc::prepare_frame(f, s, o, ws);
        } catch (const std::invalid_argument&) {
            return true;
        }
        return false;
    };
    CHECK(refused({nullptr, 100, 100, 100, PixelOrder::grey}, ok, out));
    CHECK(refused({img.data(), 0, 100, 100, PixelOrder::grey}, ok, out));
    CHECK(refused({img.data(), 100, 100, 299, PixelOrder::bgr}, ok, out));  // stride shorter than a row
    CHECK(refused(grey, ok, nullptr));
    PrepareSettings s = ok;
    s.crop_top = 60;
    s.crop_bottom = 40;
    CHECK(refused(grey, s, out));
    s = ok;
    s.crop_top = 90;  // 10 rows left: fewer than the 24 output rows
    CHECK(refused(grey, s, out));
    s = ok;
    s.radius = -1;
    CHECK(refused(grey, s, out));
    s = ok;
    s.scale = 0.0;
    CHECK(refused(grey, s, out));
    s = ok;
    s.width = 0;
    CHECK(refused(grey, s, out));
    // nothing was allocated for a refused frame, and release() frees what a good one used
    CHECK(ws.capacity_bytes() == 0);
    const FrameView bgr{img.data(), 100, 100, 300, PixelOrder::bgr};
    nightloc::prepare_frame(bgr, ok, out, ws);
    CHECK(ws.capacity_bytes() > 0);
    ws.release();
    CHECK(ws.capacity_bytes() == 0);
    nightloc::prepare_frame(bgr, ok, out, ws);  // usable again
    nightloc::PrepareWorkspace moved(std::move(ws));
    nightloc::prepare_frame(bgr, ok, out, moved);
    nightloc::prepare_frame(bgr, ok, out, ws);  // moved-from still works
}

}  // namespace

int main() {
    test_grey_and_equalization_oracles();
    test_downsample_methods_against_exact_means();
    test_patch_normalization_and_crop();
    test_every_simd_path_gives_the_same_bytes();
    test_band_folding_on_tall_and_wide_frames();
    test_errors();
    return nightloc_test::check_summary();
}
