// C++ tests of the heat-map kernels (nightloc/heatmap.hpp), run by ctest: translation against a
// brute-force bilinear oracle in long double, the documented float32 rounding, sparse weights
// against the CSR definition, the sequence ring and its sum, the peak search against a direct
// scan; every SIMD path the CPU supports must give the same values as the scalar path.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <vector>

#include "check.hpp"

#include <nightloc/heatmap.hpp>
#include <nightloc/simd.hpp>

namespace {

using nightloc::HeatPeak;
using nightloc::HeatSequence;
using nightloc::HeatWeights;
using nightloc::PeakExclusion;

// E(y, x): bilinear interpolation of `map` extended with zeros (cell centres at integers).
long double bilinear(const std::vector<double>& map, std::size_t h, std::size_t w, long double y, long double x) {
    const long double fy = std::floor(y), fx = std::floor(x);
    long double total = 0;
    for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
            const long double r = fy + dy, c = fx + dx;
            if (r < 0 || c < 0 || r >= static_cast<long double>(h) || c >= static_cast<long double>(w)) continue;
            const long double weight = (dy ? y - fy : 1 - (y - fy)) * (dx ? x - fx : 1 - (x - fx));
            total += weight * map[static_cast<std::size_t>(r) * w + static_cast<std::size_t>(c)];
        }
    return total;
}

void test_translation_against_bilinear_oracle() {
    std::mt19937 rng(31);
    std::uniform_real_distribution<double> value(-1.0, 1.0), shift(-18.0, 18.0);
    double worst64 = 0, worst32 = 0;
    for (int trial = 0; trial < 300; ++trial) {
        const std::size_t h = 1 + rng() % 15, w = 1 + rng() % 15, pad = rng() % 3;
        const std::size_t stride = w + pad;
        std::vector<double> map(h * w), src(h * stride, 7.0), out(h * stride, 0.0);
        std::vector<float> src32(h * stride, 7.f), out32(h * stride, 0.f);
        for (std::size_t j = 0; j < h; ++j)
            for (std::size_t i = 0; i < w; ++i) {
                map[j * w + i] = value(rng);
                src[j * stride + i] = map[j * w + i];
                src32[j * stride + i] = static_cast<float>(map[j * w + i]);
            }
        double sx = shift(rng), sy = shift(rng);
        if (trial % 4 == 0) sx = std::round(sx);
        if (trial % 7 == 0) sy = std::round(sy);
        nightloc::add_translated(src.data(), stride, out.data(), stride, h, w, sx, sy);
        nightloc::add_translated(src32.data(), stride, out32.data(), stride, h, w, sx, sy);
        bool padding_untouched = true;
        for (std::size_t j = 0; j < h; ++j) {
            for (std::size_t i = 0; i < w; ++i) {
                const long double expected =
                    bilinear(map, h, w, static_cast<double>(j) - sy, static_cast<double>(i) - sx);
                worst64 = std::max(worst64, static_cast<double>(std::fabs(out[j * stride + i] - expected)));
                worst32 = std::max(worst32, static_cast<double>(std::fabs(out32[j * stride + i] - expected)));
            }
            for (std::size_t i = w; i < stride; ++i) {
                padding_untouched = padding_untouched && out[j * stride + i] == 0.0;
            }
        }
        CHECK(padding_untouched);
    }
    CHECK(worst64 < 1e-14);
    CHECK(worst32 < 1e-6);
    // far shifts (and enormous ones) add nothing; non-finite ones are refused
    std::vector<float> one(12, 1.f), zero(12, 0.f);
    for (double far : {4.0, -5.0, 1e300, -1e300}) {
        nightloc::add_translated(one.data(), 4, zero.data(), 4, 3, 4, far, 0.0);
        nightloc::add_translated(one.data(), 4, zero.data(), 4, 3, 4, 0.0, far < 0 ? -4.0 : 3.0);
    }
    CHECK(zero == std::vector<float>(12, 0.f));
    CHECK_THROWS(nightloc::add_translated(one.data(), 4, zero.data(), 4, 3, 4, std::nan(""), 0.0),
                 std::invalid_argument);
    CHECK_THROWS(nightloc::add_translated(one.data(), 3, zero.data(), 4, 3, 4, 0.0, 0.0), std::invalid_argument);
    CHECK_THROWS(nightloc::add_translated(one.data(), 4, zero.data(), 4, 0, 4, 0.0, 0.0), std::invalid_argument);
}

void test_documented_float32_rounding() {
    // out = (out + wy0 * R(j - iy)) + wy1 * R(j - iy - 1), R(r, c) = a * s[c] + b * s[c - 1], in float
    std::mt19937 rng(32);
    std::uniform_real_distribution<float> value(0.f, 3.f);
    const std::size_t h = 9, w = 11;
    std::vector<float> src(h * w), out(h * w), expected(h * w);
    for (auto& v : src) v = value(rng);
    for (auto& v : out) v = value(rng);
    expected = out;
    const double sx = 2.37, sy = -1.61;
    const double ix = std::floor(sx), iy = std::floor(sy);
    const auto a = static_cast<float>(1.0 - (sx - ix)), b = static_cast<float>(sx - ix);
    const auto wy0 = static_cast<float>(1.0 - (sy - iy)), wy1 = static_cast<float>(sy - iy);
    auto s = [&](long r, long c) {
        return r < 0 || c < 0 || r >= long(h) || c >= long(w) ? 0.f : src[r * long(w) + c];
    };
    auto across = [&](long r, long c) { return a * s(r, c) + b * s(r, c - 1); };
    for (long j = 0; j < long(h); ++j)
        for (long i = 0; i < long(w); ++i) {
            const long c = i - long(ix), r = j - long(iy);
            float& e = expected[j * long(w) + i];
            e = (e + wy0 * across(r, c)) + wy1 * across(r - 1, c);
        }
    nightloc::add_translated(src.data(), w, out.data(), w, h, w, sx, sy);
    CHECK(out == expected);
}

// Fails if a*b + c is contracted into a fused multiply-add anywhere in the translation kernels
// (GCC does so by default on AArch64, and on x86 inside AVX2/AVX-512 code): the expected values
// round every product (volatile stores, whatever this file's own flags), the data is checked to
// tell the two roundings apart, and every SIMD path must give the twice-rounded values.
void test_no_fma_contraction() {
    std::mt19937 rng(12);
    std::uniform_real_distribution<float> value(0.f, 1.f);
    const std::size_t h = 16, w = 37;
    std::vector<float> src(h * w), start(h * w);
    for (auto& v : src) v = value(rng);
    for (auto& v : start) v = value(rng);
    const double sx = 0.3, sy = 0.7;  // ix = iy = 0: output (j, i) reads source rows j, j - 1, columns i, i - 1
    const auto a = static_cast<float>(1.0 - sx), b = static_cast<float>(sx);
    const auto wy0 = static_cast<float>(1.0 - sy), wy1 = static_cast<float>(sy);
    auto s = [&](long r, long c) { return r < 0 || c < 0 ? 0.f : src[r * long(w) + c]; };
    auto rounded = [](float x) {  // a product rounded to float and stored: it cannot be fused
        volatile float stored = x;
        return float(stored);
    };
    std::vector<float> twice(h * w), fused(h * w);
    for (long j = 0; j < long(h); ++j) {
        for (long i = 0; i < long(w); ++i) {
            const float r0 = rounded(a * s(j, i)) + rounded(b * s(j, i - 1));
            const float r1 = rounded(a * s(j - 1, i)) + rounded(b * s(j - 1, i - 1));
            const float e = start[j * long(w) + i];
            twice[j * long(w) + i] = (e + rounded(wy0 * r0)) + rounded(wy1 * r1);
            const float f0 = std::fma(a, s(j, i), rounded(b * s(j, i - 1)));
            const float f1 = std::fma(a, s(j - 1, i), rounded(b * s(j - 1, i - 1)));
            fused[j * long(w) + i] = std::fma(wy1, f1, std::fma(wy0, f0, e));
        }
    }
    CHECK(twice != fused);  // the data tells a contracted kernel from an exact one
    for (auto backend : nightloc::supported_simd_backends()) {
        nightloc::set_simd_backend(backend);
        std::vector<float> out = start;
        nightloc::add_translated(src.data(), w, out.data(), w, h, w, sx, sy);
        CHECK(out == twice);
        if (out != twice) std::fprintf(stderr, "  contraction on path %s\n", nightloc::simd_backend_name(backend));
    }
    nightloc::reset_simd_backend();
}

std::shared_ptr<HeatWeights> random_weights(std::mt19937& rng, std::size_t h, std::size_t w, std::size_t places) {
    std::vector<std::int32_t> indptr{0}, indices;
    std::vector<float> data;
    std::uniform_real_distribution<float> weight(-0.1f, 1.f);
    for (std::size_t c = 0; c < h * w; ++c) {
        const std::size_t k = rng() % 4;  // 0..3 weights, ascending places
        std::vector<std::int32_t> chosen;
        for (std::size_t p = 0; p < places && chosen.size() < k; ++p)
            if (rng() % places < k + 1) chosen.push_back(static_cast<std::int32_t>(p));
        for (auto p : chosen) {
            indices.push_back(p);
            data.push_back(weight(rng));
        }
        indptr.push_back(static_cast<std::int32_t>(indices.size()));
    }
    return std::make_shared<HeatWeights>(h, w, places, indptr, indices, data);
}

std::vector<float> csr_product(const std::vector<std::int32_t>& indptr, const std::vector<std::int32_t>& indices,
                               const std::vector<float>& data, const std::vector<float>& values) {
    std::vector<float> out(indptr.size() - 1);
    for (std::size_t c = 0; c + 1 < indptr.size(); ++c) {
        float sum = 0.f;
        for (auto k = indptr[c]; k < indptr[c + 1]; ++k) sum += data[k] * values[indices[k]];
        out[c] = sum;
    }
    return out;
}

void test_weights_interpolate_like_the_csr_definition() {
    std::mt19937 rng(33);
    const std::vector<std::int32_t> indptr{0, 2, 2, 5, 6};
    const std::vector<std::int32_t> indices{0, 3, 1, 2, 3, 0};
    const std::vector<float> data{0.25f, 0.75f, 0.1f, 0.3f, 0.6f, 1.f};
    HeatWeights weights(2, 2, 4, indptr, indices, data);
    std::vector<float> values{1.5f, -2.f, 0.125f, 7.f}, heat(4);
    weights.interpolate(values.data(), heat.data());
    CHECK(heat == csr_product(indptr, indices, data, values));
    values[2] = std::numeric_limits<float>::infinity();
    CHECK_THROWS(weights.interpolate(values.data(), heat.data()), std::invalid_argument);
    CHECK_THROWS(HeatWeights(2, 2, 4, {0, 2, 2, 5}, indices, data), std::invalid_argument);     // short indptr
    CHECK_THROWS(HeatWeights(2, 2, 3, indptr, indices, data), std::invalid_argument);           // index 3 of 3
    CHECK_THROWS(HeatWeights(2, 2, 4, {0, 2, 1, 5, 6}, indices, data), std::invalid_argument);  // decreasing
    CHECK_THROWS(HeatWeights(2, 2, 4, indptr, indices, {0.25f, 0.75f, 0.1f, 0.3f, 0.6f}), std::invalid_argument);
    CHECK_THROWS(HeatWeights(0, 2, 4, {0}, {}, {}), std::invalid_argument);
}

std::vector<float> brute_translate_sum(const std::vector<std::vector<float>>& maps, const std::vector<double>& offsets,
                                       std::size_t h, std::size_t w) {
    std::vector<float> out = maps.back();
    for (std::size_t k = 0; k + 1 < maps.size(); ++k)
        nightloc::add_translated(maps[k].data(), w, out.data(), w, h, w, offsets[2 * k], offsets[2 * k + 1]);
    return out;
}

void test_sequence_ring_and_sum() {
    std::mt19937 rng(34);
    const std::size_t h = 13, w = 17, places = 9;
    auto weights = random_weights(rng, h, w, places);
    HeatSequence sequence(weights, 4);
    CHECK(sequence.size() == 0 && sequence.capacity() == 4);
    CHECK_THROWS(sequence.fuse(nullptr), std::logic_error);
    std::uniform_real_distribution<float> value(0.f, 1.f);
    std::vector<std::vector<float>> maps;
    std::vector<double> fills;
    for (int frame = 0; frame < 7; ++frame) {
        std::vector<float> values(places);
        for (auto& v : values) v = value(rng);
        std::vector<float> map(h * w);
        weights->interpolate(values.data(), map.data());
        maps.push_back(map);
        fills.push_back(0.1 * frame);
        sequence.push(values.data(), 0.1 * frame);
        const std::size_t n = std::min<std::size_t>(maps.size(), 4);
        CHECK(sequence.size() == n);
        std::vector<std::vector<float>> window(maps.end() - static_cast<std::ptrdiff_t>(n), maps.end());
        std::vector<double> offsets;
        for (std::size_t k = 0; k + 1 < n; ++k) {
            const auto age = static_cast<double>(n - 1 - k);  // frames between frame k and the newest
            offsets.insert(offsets.end(), {1.7 * age, -0.6 * age});
        }
        const double fill_sum = sequence.fuse(offsets.data());
        double expected_fill = fills.back();
        for (std::size_t k = 0; k + 1 < n; ++k) expected_fill += fills[fills.size() - n + k];
        CHECK(fill_sum == expected_fill);
        const auto expected = brute_translate_sum(window, offsets, h, w);
        CHECK(std::vector<float>(sequence.fused(), sequence.fused() + h * w) == expected);
        for (std::size_t k = 0; k < n; ++k) {
            CHECK(std::vector<float>(sequence.frame(k), sequence.frame(k) + h * w) == window[k]);
            CHECK(sequence.fill(k) == fills[fills.size() - n + k]);
        }
    }
    CHECK_THROWS(sequence.frame(4), std::out_of_range);
    // a refused frame leaves the sequence as it was
    std::vector<float> bad(places, std::nanf(""));
    CHECK_THROWS(sequence.push(bad.data(), 0.0), std::invalid_argument);
    std::vector<float> fine(places, 0.5f);
    CHECK_THROWS(sequence.push(fine.data(), std::numeric_limits<double>::infinity()), std::invalid_argument);
    CHECK(sequence.size() == 4 && sequence.fill(3) == fills.back());
    // a sequence restored frame by frame from frame() and fill() sums the same
    HeatSequence restored(weights, 4);
    for (std::size_t k = 0; k < sequence.size(); ++k) restored.push_map(sequence.frame(k), sequence.fill(k));
    const std::vector<double> offsets{2.5, 1.0, -0.5, 3.25, 1.0, 1.0};
    sequence.fuse(offsets.data());
    restored.fuse(offsets.data());
    CHECK(std::vector<float>(restored.fused(), restored.fused() + h * w) ==
          std::vector<float>(sequence.fused(), sequence.fused() + h * w));
    std::vector<float> nan_map(h * w, std::nanf(""));
    CHECK_THROWS(restored.push_map(nan_map.data(), 0.0), std::invalid_argument);
    CHECK(restored.size() == 4);
    sequence.clear();
    CHECK(sequence.size() == 0);
    CHECK_THROWS(HeatSequence(nullptr, 3), std::invalid_argument);
    CHECK_THROWS(HeatSequence(weights, 0), std::invalid_argument);
}

HeatPeak brute_peak(const std::vector<float>& heat, std::size_t w, const PeakExclusion& ex) {
    HeatPeak p;
    p.cell = 0;
    for (std::size_t c = 1; c < heat.size(); ++c)
        if (heat[c] > heat[p.cell]) p.cell = c;
    p.peak = heat[p.cell];
    p.floor = *std::min_element(heat.begin(), heat.end());
    const long pj = long(p.cell / w), pi = long(p.cell % w);
    for (std::size_t c = 0; c < heat.size(); ++c) {
        const long dj = long(c / w) - pj, di = long(c % w) - pi;
        const bool excluded = std::labs(dj) <= long(ex.rows) && std::labs(di) <= long(ex.cols) &&
                              ex.mask[(dj + long(ex.rows)) * long(2 * ex.cols + 1) + di + long(ex.cols)];
        if (excluded) continue;
        p.second = p.has_second ? std::max(p.second, heat[c]) : heat[c];
        p.has_second = true;
    }
    return p;
}

void test_peak_against_a_direct_scan() {
    std::mt19937 rng(35);
    std::uniform_real_distribution<float> value(-2.f, 2.f);
    for (int trial = 0; trial < 200; ++trial) {
        const std::size_t h = 1 + rng() % 40, w = 1 + rng() % 40;
        std::vector<float> heat(h * w);
        for (auto& v : heat) v = trial % 5 == 0 ? std::round(value(rng)) : value(rng);  // ties too
        PeakExclusion ex;
        ex.rows = rng() % 6;
        ex.cols = rng() % 6;
        ex.mask.assign((2 * ex.rows + 1) * (2 * ex.cols + 1), 0);
        for (std::size_t a = 0; a <= 2 * ex.rows; ++a)
            for (std::size_t b = 0; b <= 2 * ex.cols; ++b) {
                const double dy = (double(a) - double(ex.rows)) / (double(ex.rows) + 0.5);
                const double dx = (double(b) - double(ex.cols)) / (double(ex.cols) + 0.5);
                ex.mask[a * (2 * ex.cols + 1) + b] = dy * dy + dx * dx <= 1.0;
            }
        const HeatPeak got = nightloc::find_peak(heat.data(), h, w, ex);
        const HeatPeak want = brute_peak(heat, w, ex);
        CHECK(got.finite && got.cell == want.cell && got.peak == want.peak && got.floor == want.floor);
        CHECK(got.has_second == want.has_second && (!got.has_second || got.second == want.second));
    }
    std::vector<float> heat(30, 1.f);
    heat[17] = std::nanf("");
    CHECK(!nightloc::find_peak(heat.data(), 5, 6, PeakExclusion{}).finite);
    heat[17] = -std::numeric_limits<float>::infinity();
    CHECK(!nightloc::find_peak(heat.data(), 5, 6, PeakExclusion{}).finite);
    PeakExclusion wrong;
    wrong.rows = 1;
    CHECK_THROWS(nightloc::find_peak(heat.data(), 5, 6, wrong), std::invalid_argument);
}

void test_every_simd_path_gives_the_same_values() {
    std::mt19937 rng(36);
    std::uniform_real_distribution<double> value(0.0, 1.0), shift(-30.0, 30.0);
    for (int trial = 0; trial < 40; ++trial) {
        const std::size_t h = 1 + rng() % 120, w = 1 + rng() % 120;
        const double sx = shift(rng), sy = shift(rng);
        std::vector<float> src(h * w), base(h * w);
        std::vector<double> src64(h * w), base64(h * w);
        for (std::size_t c = 0; c < h * w; ++c) {
            src64[c] = value(rng);
            base64[c] = value(rng);
            src[c] = static_cast<float>(src64[c]);
            base[c] = static_cast<float>(base64[c]);
        }
        auto weights = random_weights(rng, h, w, 7);
        std::vector<float> values(7);
        for (auto& v : values) v = static_cast<float>(value(rng));
        PeakExclusion ex;
        nightloc::set_simd_backend(nightloc::SimdBackend::scalar);
        std::vector<float> ref32 = base, interp(h * w);
        std::vector<double> ref64 = base64;
        nightloc::add_translated(src.data(), w, ref32.data(), w, h, w, sx, sy);
        nightloc::add_translated(src64.data(), w, ref64.data(), w, h, w, sx, sy);
        weights->interpolate(values.data(), interp.data());
        const HeatPeak ref_peak = nightloc::find_peak(ref32.data(), h, w, ex);
        for (auto backend : nightloc::supported_simd_backends()) {
            nightloc::set_simd_backend(backend);
            std::vector<float> got32 = base, got_interp(h * w);
            std::vector<double> got64 = base64;
            nightloc::add_translated(src.data(), w, got32.data(), w, h, w, sx, sy);
            nightloc::add_translated(src64.data(), w, got64.data(), w, h, w, sx, sy);
            weights->interpolate(values.data(), got_interp.data());
            const HeatPeak peak = nightloc::find_peak(got32.data(), h, w, ex);
            CHECK(got32 == ref32);
            CHECK(got64 == ref64);
            CHECK(got_interp == interp);
            CHECK(peak.cell == ref_peak.cell && peak.second == ref_peak.second && peak.floor == ref_peak.floor);
        }
    }
    nightloc::reset_simd_backend();
}

}  // namespace

int main() {
    test_no_fma_contraction();
    test_translation_against_bilinear_oracle();
    test_documented_float32_rounding();
    test_weights_interpolate_like_the_csr_definition();
    test_sequence_ring_and_sum();
    test_peak_against_a_direct_scan();
    test_every_simd_path_gives_the_same_values();
    return nightloc_test::check_summary();
}
