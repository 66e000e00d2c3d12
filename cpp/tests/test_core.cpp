// C++ tests of the nightloc core, run by ctest. Every SIMD path the CPU supports is checked
// against a brute-force oracle written here (direct modulo indexing, no rolled copies).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"

#include <nightloc/nightloc.hpp>

namespace {

using Bytes = std::vector<std::uint8_t>;

std::uint32_t oracle_sum(const std::uint8_t* q, const std::uint8_t* r, std::size_t h, std::size_t w, std::size_t k) {
    std::uint32_t s = 0;
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x)
            s += static_cast<std::uint32_t>(std::abs(int{q[y * w + (x + k) % w]} - int{r[y * w + x]}));
    return s;
}

Bytes random_bytes(std::mt19937& rng, std::size_t n, int lo = 0, int hi = 255) {
    std::uniform_int_distribution<int> dist(lo, hi);
    Bytes b(n);
    for (auto& v : b) v = static_cast<std::uint8_t>(dist(rng));
    return b;
}

std::vector<std::int32_t> random_shifts(std::mt19937& rng, std::size_t w) {
    std::vector<std::int32_t> all(w);
    for (std::size_t i = 0; i < w; ++i) all[i] = static_cast<std::int32_t>(i);
    std::shuffle(all.begin(), all.end(), rng);
    std::uniform_int_distribution<std::size_t> count(1, w);
    all.resize(std::uniform_int_distribution<int>(0, 2)(rng) == 0 ? w : count(rng));
    return all;
}

void check_case(std::mt19937& rng, std::size_t h, std::size_t w, std::size_t n_refs, std::size_t n_queries,
                const std::vector<std::int32_t>& shifts, int threads, int lo = 0, int hi = 255) {
    const std::size_t px = h * w;
    const Bytes queries = random_bytes(rng, n_queries * px, lo, hi);
    Bytes refs = random_bytes(rng, n_refs * px, lo, hi);
    if (n_refs > 2)
        std::copy(refs.begin(), refs.begin() + static_cast<std::ptrdiff_t>(px),
                  refs.end() - static_cast<std::ptrdiff_t>(px));  // a tie
    // Full table for query 0.
    std::vector<std::uint32_t> table(n_refs * shifts.size());
    nightloc::rotational_sad_sums(queries.data(), refs.data(), n_refs, h, w, shifts.data(), shifts.size(), table.data(),
                                  threads);
    bool table_ok = true;
    for (std::size_t i = 0; i < n_refs; ++i)
        for (std::size_t j = 0; j < shifts.size(); ++j)
            if (table[i * shifts.size() + j] !=
                oracle_sum(queries.data(), refs.data() + i * px, h, w, static_cast<std::size_t>(shifts[j])))
                table_ok = false;
    CHECK(table_ok);
    // Difference matrix.
    std::vector<std::uint32_t> best(n_queries * n_refs);
    std::vector<std::int32_t> best_shift(n_queries * n_refs);
    nightloc::difference_matrix_sums(queries.data(), n_queries, refs.data(), n_refs, h, w, shifts.data(), shifts.size(),
                                     best.data(), best_shift.data(), threads);
    bool matrix_ok = true;
    for (std::size_t q = 0; q < n_queries; ++q) {
        for (std::size_t i = 0; i < n_refs; ++i) {
            std::uint32_t b = 0xffffffffu;
            std::int32_t bs = -1;
            for (std::int32_t s : shifts) {
                std::uint32_t v =
                    oracle_sum(queries.data() + q * px, refs.data() + i * px, h, w, static_cast<std::size_t>(s));
                if (v < b) {
                    b = v;
                    bs = s;
                }
            }
            if (best[q * n_refs + i] != b || best_shift[q * n_refs + i] != bs) matrix_ok = false;
        }
    }
    CHECK(matrix_ok);
    if (!table_ok || !matrix_ok) {
        std::fprintf(stderr, "  case h=%zu w=%zu refs=%zu queries=%zu shifts=%zu threads=%d backend=%s\n", h, w, n_refs,
                     n_queries, shifts.size(), threads, nightloc::simd_backend_name(nightloc::active_simd_backend()));
    }
}

void test_sad_all_backends() {
    std::mt19937 rng(1234);
    for (nightloc::SimdBackend backend : nightloc::supported_simd_backends()) {
        nightloc::set_simd_backend(backend);
        std::printf("SAD kernels on %s\n", nightloc::simd_backend_name(backend));
        // The paper's geometry, all shifts (the AVX-512 all-shift kernel).
        check_case(rng, 24, 48, 37, 3, nightloc::all_shifts(48), 1);
        check_case(rng, 24, 48, 101, 2, nightloc::all_shifts(48), 2);
        // Forward camera: shift 0 only, Nordland size.
        check_case(rng, 32, 64, 19, 5, {0}, 2);
        // Extremes: 0 vs 255 everywhere (largest sums, 16-bit lanes, flushes).
        check_case(rng, 24, 48, 9, 2, nightloc::all_shifts(48), 1, 0, 0);
        check_case(rng, 64, 64, 9, 2, nightloc::all_shifts(64), 1, 255, 255);
        {
            const std::size_t h = 64, w = 64, px = h * w;
            Bytes q(px, 0), r(3 * px, 255);
            std::vector<std::uint32_t> table(3 * w);
            auto shifts = nightloc::all_shifts(static_cast<nightloc::Index>(w));
            nightloc::rotational_sad_sums(q.data(), r.data(), 3, h, w, shifts.data(), w, table.data(), 1);
            bool ok = true;
            for (auto v : table) ok = ok && v == 255u * px;
            CHECK(ok);
        }
        // Random geometries and shift subsets.
        for (int trial = 0; trial < 60; ++trial) {
            std::size_t h = std::uniform_int_distribution<std::size_t>(1, 40)(rng);
            std::size_t w = std::uniform_int_distribution<std::size_t>(1, 90)(rng);
            if (trial % 3 == 0) w = 8 * std::uniform_int_distribution<std::size_t>(1, 12)(rng);
            std::size_t n = std::uniform_int_distribution<std::size_t>(1, 40)(rng);
            std::size_t m = std::uniform_int_distribution<std::size_t>(1, 4)(rng);
            check_case(rng, h, w, n, m, random_shifts(rng, w), 1 + trial % 3);
        }
        // A wide panorama (interleaved layout larger than the fixed buffer) and a tall image.
        check_case(rng, 3, 400, 5, 1, nightloc::all_shifts(400), 1);
        check_case(rng, 200, 16, 5, 1, nightloc::all_shifts(16), 1);
    }
    nightloc::reset_simd_backend();
}

void test_errors() {
    Bytes q(6, 1), r(6, 2);
    std::uint32_t out[2];
    std::int32_t bad_shift[1] = {3};
    CHECK_THROWS(nightloc::rotational_sad_sums(q.data(), r.data(), 1, 2, 3, bad_shift, 1, out, 1),
                 std::invalid_argument);
    std::int32_t dup[2] = {1, 1};
    CHECK_THROWS(nightloc::rotational_sad_sums(q.data(), r.data(), 1, 2, 3, dup, 2, out, 1), std::invalid_argument);
    CHECK_THROWS(nightloc::patch_normalize(q.data(), r.data(), 1, 2, 3, -1, true), std::invalid_argument);
    // A radius past the bound would overflow the 64-bit window sums (and loop 2r+1 times per row).
    CHECK_THROWS(nightloc::patch_normalize(q.data(), r.data(), 1, 2, 3, nightloc::kMaxPatchRadius + 1, true),
                 std::invalid_argument);
    Bytes ramp(2 * 3), wide(2 * 3);
    for (std::size_t i = 0; i < ramp.size(); ++i) ramp[i] = static_cast<std::uint8_t>(40 * i);
    nightloc::patch_normalize(ramp.data(), wide.data(), 1, 2, 3, nightloc::kMaxPatchRadius, true);
    nightloc::patch_normalize(ramp.data(), wide.data(), 1, 2, 3, nightloc::kMaxPatchRadius, false);
    CHECK(wide[0] < wide[5]);  // still a z-score: the darkest pixel below the brightest
}

void test_patch_normalize() {
    // Flat image: defined value 128, never NaN.
    Bytes flat(24 * 48, 77), out(24 * 48);
    nightloc::patch_normalize(flat.data(), out.data(), 1, 24, 48, 4, true);
    bool all128 = true;
    for (auto v : out) all128 = all128 && v == 128;
    CHECK(all128);
    // A single row 0,0,0,255 with radius 1, no wrap: hand-computed z-scores.
    Bytes row = {0, 0, 0, 255}, z(4);
    nightloc::patch_normalize(row.data(), z.data(), 1, 1, 4, 1, false, 10.0);
    // windows: {0,0}->flat 128; {0,0,0}->128; {0,0,255}: z(0) = (3*0-255)/sqrt(3*65025-65025) = -1/sqrt(2)
    // -> 128 - 7.07 -> 121; {0,255}: z(255) = 1 -> 138.
    CHECK(z[0] == 128 && z[1] == 128 && z[2] == 121 && z[3] == 138);
    // With wrap-around, normalization commutes with circular column shifts.
    std::mt19937 rng(7);
    const std::size_t h = 10, w = 30;
    Bytes img = random_bytes(rng, h * w), rolled(h * w), a(h * w), b(h * w);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) rolled[y * w + (x + 7) % w] = img[y * w + x];
    nightloc::patch_normalize(img.data(), a.data(), 1, h, w, 4, true);
    nightloc::patch_normalize(rolled.data(), b.data(), 1, h, w, 4, true);
    bool commutes = true;
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) commutes = commutes && b[y * w + (x + 7) % w] == a[y * w + x];
    CHECK(commutes);
}

void test_block_normalize() {
    // 2x2 blocks of a 2x5 image: block {0, 10, 20, 30} (column-major 0,20,10,30 in Matlab terms);
    // mean 15, std sqrt(500/3) = 12.91: z = -1.16, -0.39, 0.39, 1.16 -> 126, 127, 127, 128.
    // Second block flat -> 0. Last column (incomplete block) unchanged.
    Bytes img = {0, 10, 5, 5, 99, 20, 30, 5, 5, 98}, out(10);
    nightloc::block_normalize(img.data(), out.data(), 1, 2, 5, 2);
    CHECK(out[0] == 126 && out[1] == 127 && out[5] == 127 && out[6] == 128);
    CHECK(out[2] == 0 && out[3] == 0 && out[7] == 0 && out[8] == 0);
    CHECK(out[4] == 99 && out[9] == 98);
}

void test_eigen_api() {
    nightloc::ImageStack refs(4, 6, 16);
    std::mt19937 rng(3);
    for (nightloc::Index i = 0; i < refs.count(); ++i)
        for (nightloc::Index p = 0; p < refs.pixels.cols(); ++p)
            refs.pixels(i, p) = static_cast<std::uint8_t>(rng() & 0xff);
    nightloc::ImageU8 query(6, 16);
    for (nightloc::Index r = 0; r < 6; ++r)
        for (nightloc::Index c = 0; c < 16; ++c) query(r, (c + 3) % 16) = refs.image(2)(r, c);
    const auto result = nightloc::match(query, refs);
    CHECK(result.best == 2 && result.shifts[2] == 3 && result.scores[2] == 0.0f);
    // headings: 3 of 16 columns = +3/8 pi; shifts past the half turn wrap to negative headings
    CHECK(result.headings.size() == 4 && std::fabs(result.headings[2] - 3.0 * M_PI / 8.0) < 1e-12);
    CHECK(nightloc::shift_heading(8, 16) == M_PI && std::fabs(nightloc::shift_heading(12, 16) + M_PI / 2) < 1e-12);
    CHECK(nightloc::shift_heading(0, 16) == 0.0);
    // the pointer-level per-frame call gives the same as the Eigen one, and refuses an empty stack
    std::vector<float> scores(4);
    std::vector<std::int32_t> shifts(4);
    const std::vector<std::int32_t> all = nightloc::all_shifts(16);
    const std::size_t best =
        nightloc::match(query.data(), refs.data(), 4, 6, 16, all.data(), all.size(), scores.data(), shifts.data());
    bool same = best == 2;
    for (std::size_t i = 0; i < 4; ++i) {
        same = same && scores[i] == result.scores[static_cast<nightloc::Index>(i)] &&
               shifts[i] == result.shifts[static_cast<nightloc::Index>(i)];
    }
    CHECK(same);
    CHECK_THROWS(
        nightloc::match(query.data(), refs.data(), 0, 6, 16, all.data(), all.size(), scores.data(), shifts.data()),
        std::invalid_argument);
    const auto table = nightloc::rotational_sad(query, refs);
    CHECK(table.rows() == 4 && table.cols() == 16 && table(2, 3) == 0.0f);
    const auto dm = nightloc::difference_matrix(refs, refs, {0}, 2);
    bool diag = true;
    for (nightloc::Index i = 0; i < 4; ++i) diag = diag && dm.scores(i, i) == 0.0f && dm.shifts(i, i) == 0;
    CHECK(diag);
}

}  // namespace

int main() {
    test_sad_all_backends();
    test_errors();
    test_patch_normalize();
    test_block_normalize();
    test_eigen_api();
    return nightloc_test::check_summary();
}
