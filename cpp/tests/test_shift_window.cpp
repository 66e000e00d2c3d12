// The translation window (nightloc/sad.hpp) on every SIMD path the CPU supports (under qemu: both
// NEON paths), against a brute-force oracle written here: direct indexing with bounds checks over
// every candidate, exact comparison of means by cross products, the documented tie order.
#include <algorithm>
#include <cstdint>
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

struct Best {
    std::uint64_t sum = 0, overlap = 0;
    long rank = -1;
    std::int32_t value = 0, dy = 0;
};

int offset_rank(int v) { return 2 * std::abs(v) - (v < 0 ? 1 : 0); }

bool better(std::uint64_t sum, std::uint64_t overlap, long rank, const Best& b) {
    if (b.rank < 0) return true;
    const std::uint64_t lhs = sum * b.overlap, rhs = b.sum * overlap;
    return lhs < rhs || (lhs == rhs && rank < b.rank);
}

// Sum and overlap of candidate (value, dy): value is a circular shift (columns == 0) or an offset.
void candidate(const std::uint8_t* q, const std::uint8_t* r, int h, int w, bool wrap, int value, int dy,
               std::uint64_t& sum, std::uint64_t& overlap) {
    sum = 0;
    overlap = 0;
    for (int y = 0; y < h; ++y) {
        if (y + dy < 0 || y + dy >= h) continue;
        for (int x = 0; x < w; ++x) {
            int xq = x + value;
            if (wrap) {
                xq %= w;
            } else if (xq < 0 || xq >= w) {
                continue;
            }
            sum += static_cast<std::uint64_t>(std::abs(int{q[(y + dy) * w + xq]} - int{r[y * w + x]}));
            ++overlap;
        }
    }
}

std::vector<int> column_values(const std::vector<std::int32_t>& shifts, const nightloc::ShiftWindow& window) {
    std::vector<int> values;
    if (window.columns == 0) {
        for (auto s : shifts) values.push_back(s);
    } else {
        for (int dx = -static_cast<int>(window.columns); dx <= static_cast<int>(window.columns); ++dx)
            values.push_back(dx);
    }
    return values;
}

// Best over all candidates (column == -1) or over the row offsets of column candidate `column`.
Best oracle_best(const std::uint8_t* q, const std::uint8_t* r, int h, int w, const std::vector<std::int32_t>& shifts,
                 const nightloc::ShiftWindow& window, int column = -1) {
    const std::vector<int> values = column_values(shifts, window);
    const bool wrap = window.columns == 0;
    const int rows = static_cast<int>(window.rows);
    Best best;
    for (int dy = -rows; dy <= rows; ++dy) {
        for (int j = 0; j < static_cast<int>(values.size()); ++j) {
            if (column >= 0 && j != column) continue;
            std::uint64_t sum = 0, overlap = 0;
            candidate(q, r, h, w, wrap, values[static_cast<std::size_t>(j)], dy, sum, overlap);
            const long rank = static_cast<long>(offset_rank(dy)) * static_cast<long>(values.size()) +
                              (wrap ? j : offset_rank(values[static_cast<std::size_t>(j)]));
            if (better(sum, overlap, rank, best)) best = {sum, overlap, rank, values[static_cast<std::size_t>(j)], dy};
        }
    }
    return best;
}

float score_of(const Best& b) {
    return static_cast<float>(static_cast<double>(b.sum) / static_cast<double>(b.overlap));
}

Bytes random_bytes(std::mt19937& rng, std::size_t n, int hi) {
    std::uniform_int_distribution<int> dist(0, hi);
    Bytes b(n);
    for (auto& v : b) v = static_cast<std::uint8_t>(dist(rng));
    return b;
}

// References at `ref_offset` bytes past a 64-byte boundary (the kernels align the bands of a
// forward window to the references' real address, or stage them), `n_queries` queries.
void check_case(std::mt19937& rng, int h, int w, const std::vector<std::int32_t>& shifts,
                const nightloc::ShiftWindow& window, int hi, const char* path, std::size_t ref_offset = 0,
                std::size_t n_queries = 3) {
    const std::size_t px = static_cast<std::size_t>(h * w), n_refs = 11;
    const Bytes queries = random_bytes(rng, n_queries * px, hi);
    Bytes ref_bytes = random_bytes(rng, n_refs * px, hi);
    std::copy(ref_bytes.begin(), ref_bytes.begin() + static_cast<std::ptrdiff_t>(px),
              ref_bytes.end() - static_cast<std::ptrdiff_t>(px));
    Bytes storage(n_refs * px + 128);
    const auto address = reinterpret_cast<std::uintptr_t>(storage.data());
    std::uint8_t* const refs_at = storage.data() + (64 - address % 64) % 64 + ref_offset;
    std::copy(ref_bytes.begin(), ref_bytes.end(), refs_at);
    struct {
        const std::uint8_t* p;
        const std::uint8_t* data() const { return p; }
    } const refs{refs_at};
    const std::size_t hh = static_cast<std::size_t>(h), ww = static_cast<std::size_t>(w);
    const std::vector<int> values = column_values(shifts, window);

    std::vector<float> scores(n_queries * n_refs);
    std::vector<std::int32_t> best_shifts(scores.size()), best_rows(scores.size());
    for (int threads : {1, 2}) {
        nightloc::difference_matrix(queries.data(), n_queries, refs.data(), n_refs, hh, ww, shifts.data(),
                                    shifts.size(), window, scores.data(), best_shifts.data(), best_rows.data(),
                                    threads);
        bool ok = true;
        for (std::size_t k = 0; k < n_queries; ++k) {
            for (std::size_t i = 0; i < n_refs; ++i) {
                const Best b = oracle_best(queries.data() + k * px, refs.data() + i * px, h, w, shifts, window);
                const std::size_t e = k * n_refs + i;
                ok = ok && scores[e] == score_of(b) && best_shifts[e] == b.value && best_rows[e] == b.dy;
            }
        }
        if (!ok)
            std::fprintf(stderr, "difference matrix differs: %s %dx%d window %zu,%zu\n", path, h, w, window.columns,
                         window.rows);
        CHECK(ok);
    }

    std::vector<float> table(n_refs * values.size());
    std::vector<std::int32_t> table_rows(table.size());
    nightloc::rotational_sad(queries.data(), refs.data(), n_refs, hh, ww, shifts.data(), shifts.size(), window,
                             table.data(), table_rows.data(), 2);
    bool table_ok = true;
    for (std::size_t i = 0; i < n_refs; ++i) {
        for (std::size_t j = 0; j < values.size(); ++j) {
            const Best b = oracle_best(queries.data(), refs.data() + i * px, h, w, shifts, window, static_cast<int>(j));
            table_ok =
                table_ok && table[i * values.size() + j] == score_of(b) && table_rows[i * values.size() + j] == b.dy;
        }
    }
    if (!table_ok) std::fprintf(stderr, "table differs: %s %dx%d\n", path, h, w);
    CHECK(table_ok);

    std::vector<float> m_scores(n_refs);
    std::vector<std::int32_t> m_shifts(n_refs), m_rows(n_refs);
    const std::size_t best = nightloc::match(queries.data(), refs.data(), n_refs, hh, ww, shifts.data(), shifts.size(),
                                             window, m_scores.data(), m_shifts.data(), m_rows.data(), nullptr, 1);
    std::size_t expected = 0;
    Best expected_best;
    for (std::size_t i = 0; i < n_refs; ++i) {
        const Best b = oracle_best(queries.data(), refs.data() + i * px, h, w, shifts, window);
        if (i == 0 || b.sum * expected_best.overlap < expected_best.sum * b.overlap) {
            expected = i;
            expected_best = b;
        }
        CHECK(m_scores[i] == score_of(b) && m_shifts[i] == b.value && m_rows[i] == b.dy);
    }
    CHECK(best == expected);
}

std::vector<std::int32_t> all_shifts(int w) {
    std::vector<std::int32_t> s(static_cast<std::size_t>(w));
    for (int i = 0; i < w; ++i) s[static_cast<std::size_t>(i)] = i;
    return s;
}

void check_errors() {
    const Bytes img(24 * 48, 7);
    std::vector<float> scores(1);
    std::vector<std::int32_t> shifts(1), rows(1);
    const std::vector<std::int32_t> zero{0}, pano = all_shifts(48);
    CHECK_THROWS(nightloc::match(img.data(), img.data(), 1, 24, 48, zero.data(), 1, nightloc::ShiftWindow{0, 24},
                                 scores.data(), shifts.data(), rows.data()),
                 std::invalid_argument);
    CHECK_THROWS(nightloc::match(img.data(), img.data(), 1, 24, 48, zero.data(), 1, nightloc::ShiftWindow{48, 0},
                                 scores.data(), shifts.data(), rows.data()),
                 std::invalid_argument);
    CHECK_THROWS(nightloc::match(img.data(), img.data(), 1, 24, 48, pano.data(), pano.size(),
                                 nightloc::ShiftWindow{2, 0}, scores.data(), shifts.data(), rows.data()),
                 std::invalid_argument);
    CHECK_THROWS(nightloc::window_column_offsets(24, 48, zero.data(), 1, nightloc::ShiftWindow{1000, 0}),
                 std::invalid_argument);
    // The widest window is allowed: one-pixel overlaps at the corners.
    const std::size_t best = nightloc::match(img.data(), img.data(), 1, 24, 48, zero.data(), 1,
                                             nightloc::ShiftWindow{47, 23}, scores.data(), shifts.data(), rows.data());
    CHECK(best == 0 && scores[0] == 0.0f && shifts[0] == 0 && rows[0] == 0);
}

void check_eigen_api() {
    nightloc::ImageStack refs(4, 24, 48);
    std::mt19937 rng(9);
    std::uniform_int_distribution<int> dist(0, 255);
    for (nightloc::Index i = 0; i < refs.pixels.size(); ++i)
        refs.pixels.data()[i] = static_cast<std::uint8_t>(dist(rng));
    // Query: reference 2 moved down 1 row and left 3 columns (a forward camera).
    nightloc::ImageU8 query = refs.image(2);
    for (nightloc::Index y = 0; y < 24; ++y)
        for (nightloc::Index x = 0; x < 48; ++x) query(y, x) = refs.image(2)((y + 23) % 24, (x + 3) % 48);
    const auto result = nightloc::match(query, refs, {0}, nightloc::ShiftWindow{8, 2});
    CHECK(result.best == 2 && result.shifts[2] == -3 && result.rows[2] == 1 && result.scores[2] == 0.0f);
    const auto table = nightloc::shift_table(query, refs, {0}, nightloc::ShiftWindow{8, 2});
    CHECK(table.columns.size() == 17 && table.columns.front() == -8 && table.scores(2, 5) == 0.0f &&
          table.rows(2, 5) == 1);
    nightloc::ImageStack queries(1, 24, 48);
    queries.image(0) = query;
    const auto dm = nightloc::difference_matrix(queries, refs, {0}, nightloc::ShiftWindow{8, 2});
    CHECK(dm.shifts(0, 2) == -3 && dm.rows(0, 2) == 1 && dm.scores(0, 2) == 0.0f);
    const auto plain = nightloc::difference_matrix(queries, refs, {0});
    CHECK(plain.rows.isZero() && plain.shifts.isZero());
}

}  // namespace

int main() {
    std::mt19937 rng(20240601);
    for (nightloc::SimdBackend path : nightloc::supported_simd_backends()) {
        nightloc::set_simd_backend(path);
        const char* name = nightloc::simd_backend_name(path);
        check_case(rng, 24, 48, all_shifts(48), {0, 2}, 255, name);
        check_case(rng, 24, 48, {0}, {8, 2}, 255, name);
        check_case(rng, 24, 48, {7, 0, 30}, {0, 3}, 255, name);
        check_case(rng, 24, 48, {0}, {47, 23}, 255, name);
        check_case(rng, 5, 12, all_shifts(12), {0, 4}, 1, name);  // binary: equal means across overlaps
        check_case(rng, 6, 16, {0}, {5, 3}, 1, name);
        check_case(rng, 3, 7, {0}, {6, 2}, 255, name);
        check_case(rng, 9, 40, {0}, {9, 1}, 3, name);
        check_case(rng, 4, 200, all_shifts(200), {0, 1}, 255, name);
        for (std::size_t offset : {8, 16, 32, 48}) {  // misaligned references: few and many queries
            check_case(rng, 24, 48, {0}, {8, 1}, 255, name, offset);
            check_case(rng, 24, 48, {0}, {8, 3}, 255, name, offset, 7);
            check_case(rng, 6, 16, {0}, {5, 3}, 1, name, offset, 1);
            check_case(rng, 9, 40, {0}, {9, 2}, 3, name, offset, 5);
        }
    }
    nightloc::reset_simd_backend();
    check_errors();
    check_eigen_api();
    return nightloc_test::check_summary();
}
