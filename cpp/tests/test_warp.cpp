// C++ tests of min-warping (warp.hpp), run by ctest: the costs bit for bit against a direct
// evaluation of the header's definition (one hypothesis, one column at a time), a known answer
// (a frame against itself turned by k columns), threads, and bad input.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "check.hpp"

#include <nightloc/warp.hpp>

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Case {
    std::size_t n = 4, h = 6, w = 12, scales = 3, directions = 8, moves = 5;
    std::vector<std::uint8_t> images, stacks;
    std::vector<std::int32_t> row_begin, row_end, level, sign;
    nightloc::WarpGeometry geometry() const {
        nightloc::WarpGeometry g;
        g.height = h;
        g.width = w;
        g.scales = scales;
        g.directions = directions;
        g.moves = moves;
        g.row_begin = row_begin.data();
        g.row_end = row_end.data();
        g.level = level.data();
        g.sign = sign.data();
        return g;
    }
};

Case random_case(std::mt19937& rng) {
    Case t;
    std::uniform_int_distribution<int> byte(0, 255);
    t.images.resize(t.n * t.h * t.w);
    for (auto& v : t.images) v = static_cast<std::uint8_t>(byte(rng));
    t.stacks.resize(t.n * t.scales * t.h * t.w);
    for (auto& v : t.stacks) v = static_cast<std::uint8_t>(byte(rng));
    t.row_begin = {0, 2, 3};
    t.row_end = {6, 5, 3};  // scale 2 is empty: never compared
    std::uniform_int_distribution<int> lev(-1, static_cast<int>(t.scales));
    t.level.resize(t.directions * t.w * t.moves);
    for (auto& v : t.level) v = lev(rng);
    t.sign.resize(t.directions * t.w);
    for (auto& v : t.sign) v = byte(rng) % 2 ? 1 : -1;
    return t;
}

std::size_t wrap(long long v, std::size_t n) {
    const long long m = static_cast<long long>(n);
    return static_cast<std::size_t>(((v % m) + m) % m);
}

// cost(l, c, c') straight from the header: sum over the rows of |stack - image| / rows.
double oracle_cost(const Case& t, std::size_t a, std::size_t b, std::size_t l, std::size_t c, std::size_t q) {
    if (l == t.scales) {
        double least = kInf;
        for (std::size_t k = 0; k < t.scales; ++k) {
            const double v = oracle_cost(t, a, b, k, c, q);
            if (v < least) least = v;
        }
        return least;
    }
    const std::size_t begin = static_cast<std::size_t>(t.row_begin[l]), end = static_cast<std::size_t>(t.row_end[l]);
    if (end == begin) return kInf;
    long long sum = 0;
    for (std::size_t r = begin; r < end; ++r) {
        const int x = t.stacks[((a * t.scales + l) * t.h + r) * t.w + c];
        const int y = t.images[(b * t.h + r) * t.w + q];
        sum += std::abs(x - y);
    }
    return static_cast<double>(sum) * (1.0 / static_cast<double>(end - begin));
}

double oracle(const Case& t, std::size_t a, std::size_t b, long long direction, long long shift) {
    const std::size_t g = wrap(direction, t.directions);
    double total = 0.0;
    std::size_t counted = 0;
    for (std::size_t c = 0; c < t.w; ++c) {
        double best = kInf;
        for (std::size_t m = 0; m < t.moves; ++m) {
            const int l = t.level[(g * t.w + c) * t.moves + m];
            if (l < 0) continue;
            const long long target = static_cast<long long>(c) + shift -
                                     static_cast<long long>(t.sign[g * t.w + c]) * static_cast<long long>(m);
            const double v = oracle_cost(t, a, b, static_cast<std::size_t>(l), c, wrap(target, t.w));
            if (v < best) best = v;
        }
        if (best < kInf) {
            total += best;
            ++counted;
        }
    }
    return counted ? total / static_cast<double>(counted) : kInf;
}

bool same_bits(double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; }

void test_against_the_definition() {
    std::mt19937 rng(11);
    for (int trial = 0; trial < 5; ++trial) {
        const Case t = random_case(rng);
        const std::vector<std::int32_t> pairs = {0, 1, 2, 3, 3, 0, 1, 1};
        const std::vector<std::int32_t> first_direction = {-3, 0, 5, 13};
        const std::vector<std::int32_t> first_shift = {-20, 4, 11, 0};
        const std::size_t n_pairs = 4, n_directions = 5, n_shifts = 7;
        for (int threads : {1, 3}) {
            std::vector<double> out(n_pairs * n_directions * n_shifts, -1.0);
            nightloc::warp_costs(t.images.data(), t.stacks.data(), t.n, t.geometry(), pairs.data(), n_pairs,
                                 first_direction.data(), n_directions, first_shift.data(), n_shifts, out.data(),
                                 threads);
            bool all_same = true;
            for (std::size_t p = 0; p < n_pairs; ++p) {
                for (std::size_t d = 0; d < n_directions; ++d) {
                    for (std::size_t s = 0; s < n_shifts; ++s) {
                        const double expected = oracle(
                            t, static_cast<std::size_t>(pairs[2 * p]), static_cast<std::size_t>(pairs[2 * p + 1]),
                            first_direction[p] + static_cast<long long>(d), first_shift[p] + static_cast<long long>(s));
                        all_same = all_same && same_bits(out[(p * n_directions + d) * n_shifts + s], expected);
                    }
                }
            }
            CHECK(all_same);
        }
    }
}

void test_a_turned_copy() {
    // Frame 1 is frame 0 turned by 5 columns; one scale (the identity), every column kept in
    // place (m = 0 only): the cost is 0 at shift 5 and positive at every other shift.
    Case t;
    t.n = 2;
    t.scales = 1;
    t.moves = 3;
    std::mt19937 rng(2);
    std::uniform_int_distribution<int> byte(0, 255);
    t.images.resize(t.n * t.h * t.w);
    for (std::size_t r = 0; r < t.h; ++r) {
        for (std::size_t c = 0; c < t.w; ++c) t.images[r * t.w + c] = static_cast<std::uint8_t>(byte(rng));
        for (std::size_t c = 0; c < t.w; ++c) t.images[(t.h + r) * t.w + (c + 5) % t.w] = t.images[r * t.w + c];
    }
    t.stacks.assign(t.images.begin(), t.images.end());  // (n, 1, h, w)
    t.row_begin = {0};
    t.row_end = {static_cast<std::int32_t>(t.h)};
    t.level.assign(t.directions * t.w * t.moves, -1);
    for (std::size_t i = 0; i < t.directions * t.w; ++i) t.level[i * t.moves] = 0;
    t.sign.assign(t.directions * t.w, 1);
    const std::vector<std::int32_t> pairs = {0, 1}, first_direction = {2}, first_shift = {0};
    std::vector<double> out(t.w);
    nightloc::warp_costs(t.images.data(), t.stacks.data(), t.n, t.geometry(), pairs.data(), 1, first_direction.data(),
                         1, first_shift.data(), t.w, out.data(), 1);
    CHECK(out[5] == 0.0);
    bool others_positive = true;
    for (std::size_t k = 0; k < t.w; ++k) others_positive = others_positive && (k == 5 || out[k] > 0.0);
    CHECK(others_positive);
}

void test_bad_input() {
    std::mt19937 rng(5);
    Case t = random_case(rng);
    std::vector<double> out(16);
    const std::vector<std::int32_t> ok_pair = {0, 1}, bad_pair = {0, 4}, zero = {0};
    auto run = [&](const Case& c, const std::vector<std::int32_t>& pairs, std::size_t n_dirs) {
        nightloc::warp_costs(c.images.data(), c.stacks.data(), c.n, c.geometry(), pairs.data(), 1, zero.data(), n_dirs,
                             zero.data(), 1, out.data(), 1);
    };
    CHECK_THROWS(run(t, bad_pair, 1), std::invalid_argument);
    CHECK_THROWS(run(t, ok_pair, 0), std::invalid_argument);
    Case rows = t;
    rows.row_end[0] = 7;  // beyond the 6 rows
    CHECK_THROWS(run(rows, ok_pair, 1), std::invalid_argument);
    Case levels = t;
    levels.level[3] = 4;  // beyond L = 3 (the least over the scales)
    CHECK_THROWS(run(levels, ok_pair, 1), std::invalid_argument);
    Case signs = t;
    signs.sign[0] = 0;
    CHECK_THROWS(run(signs, ok_pair, 1), std::invalid_argument);
    run(t, ok_pair, 1);  // the unchanged case runs
    CHECK(out[0] >= 0.0);
}

}  // namespace

int main() {
    test_against_the_definition();
    test_a_turned_copy();
    test_bad_input();
    return nightloc_test::check_summary();
}
