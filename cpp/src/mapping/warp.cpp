// Min-warping costs (warp.hpp). Per pair: a table of column costs at every magnification, then
// the hypotheses' means over columns. The column costs are integer sums of absolute differences
// accumulated across B's columns (contiguous bytes, so the loop vectorizes lane-wise without
// changing any sum), each divided once by its row count; everything after is comparisons and
// sequential double sums in column order.
#include "nightloc/warp.hpp"

#include <cstdlib>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/parallel.hpp"

namespace nightloc {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

void check_geometry(const WarpGeometry& g) {
    if (g.height == 0 || g.width == 0 || g.scales == 0 || g.directions == 0 || g.moves == 0) {
        throw std::invalid_argument("warp geometry: height, width, scales, directions and moves must be >= 1");
    }
    if (g.scales > 1000 || g.width > 4096 || g.height > 4096) {
        throw std::invalid_argument("warp geometry: at most 1000 scales and 4096 x 4096 pixels");
    }
    if (!g.row_begin || !g.row_end || !g.level || !g.sign) throw std::invalid_argument("warp geometry: null table");
    for (std::size_t l = 0; l < g.scales; ++l) {
        if (g.row_begin[l] < 0 || g.row_end[l] < g.row_begin[l] || static_cast<std::size_t>(g.row_end[l]) > g.height) {
            throw std::invalid_argument("warp geometry: the rows of scale " + std::to_string(l) + " ([" +
                                        std::to_string(g.row_begin[l]) + ", " + std::to_string(g.row_end[l]) +
                                        ")) are not inside [0, " + std::to_string(g.height) + "]");
        }
    }
    const std::size_t cells = g.directions * g.width;
    for (std::size_t i = 0; i < cells; ++i) {
        if (g.sign[i] != 1 && g.sign[i] != -1) throw std::invalid_argument("warp geometry: sign must be +1 or -1");
        for (std::size_t m = 0; m < g.moves; ++m) {
            const std::int32_t v = g.level[i * g.moves + m];
            if (v < -1 || v > static_cast<std::int32_t>(g.scales)) {
                throw std::invalid_argument("warp geometry: level " + std::to_string(v) + " is not in [-1, " +
                                            std::to_string(g.scales) + "]");
            }
        }
    }
}

inline std::size_t wrap(std::int64_t value, std::size_t n) {
    const std::int64_t m = static_cast<std::int64_t>(n);
    const std::int64_t r = value % m;
    return static_cast<std::size_t>(r < 0 ? r + m : r);
}

// Sum of |a[r] - b[r]| over n bytes, n a multiple of 16 (zero padding adds nothing): PSADBW on
// x86-64 (SSE2 is its baseline), a plain loop elsewhere; the same integer either way.
inline std::uint32_t padded_sad(const std::uint8_t* a, const std::uint8_t* b, std::size_t n) {
#if defined(__SSE2__)
    __m128i total = _mm_setzero_si128();
    for (std::size_t r = 0; r < n; r += 16) {
        const __m128i x = _mm_loadu_si128(reinterpret_cast<const __m128i*>(a + r));
        const __m128i y = _mm_loadu_si128(reinterpret_cast<const __m128i*>(b + r));
        total = _mm_add_epi64(total, _mm_sad_epu8(x, y));
    }
    return static_cast<std::uint32_t>(_mm_cvtsi128_si32(total) + _mm_cvtsi128_si32(_mm_srli_si128(total, 8)));
#else
    std::uint32_t sum = 0;
    for (std::size_t r = 0; r < n; ++r) sum += static_cast<std::uint32_t>(a[r] > b[r] ? a[r] - b[r] : b[r] - a[r]);
    return sum;
#endif
}

// cost[(l * W + c) * 2W + c'] for l in 0..L-1 and c' in 0..2W-1 (each row twice, so that a run
// of shifts never wraps). `stack`: frame A magnified, (L, H, W); `image`: frame B, (H, W). `a_rows` (padded) and
// `b_rows` (W x padded) are scratch for one column of A and every column of B, their rows [begin, end) zero-padded to a
// multiple of 16.
void column_costs(const std::uint8_t* stack, const std::uint8_t* image, const WarpGeometry& g, double* cost,
                  std::uint8_t* a_rows, std::uint8_t* b_rows) {
    const std::size_t w = g.width, h = g.height, layers = g.scales;
    for (std::size_t l = 0; l < layers; ++l) {
        double* layer = cost + l * w * 2 * w;
        const std::size_t begin = static_cast<std::size_t>(g.row_begin[l]);
        const std::size_t end = static_cast<std::size_t>(g.row_end[l]);
        if (end == begin) {
            for (std::size_t i = 0; i < 2 * w * w; ++i) layer[i] = kInf;
            continue;
        }
        const std::size_t n = end - begin, padded = (n + 15) / 16 * 16;
        const double scale = 1.0 / static_cast<double>(n);
        for (std::size_t q = 0; q < w; ++q) {
            std::uint8_t* column = b_rows + q * padded;
            for (std::size_t r = 0; r < n; ++r) column[r] = image[(begin + r) * w + q];
            for (std::size_t r = n; r < padded; ++r) column[r] = 0;
        }
        const std::uint8_t* magnified = stack + l * h * w;
        for (std::size_t c = 0; c < w; ++c) {
            for (std::size_t r = 0; r < n; ++r) a_rows[r] = magnified[(begin + r) * w + c];
            for (std::size_t r = n; r < padded; ++r) a_rows[r] = 0;
            double* out = layer + c * 2 * w;
            for (std::size_t q = 0; q < w; ++q) {
                out[q] = static_cast<double>(padded_sad(a_rows, b_rows + q * padded, padded)) * scale;
                out[q + w] = out[q];
            }
        }
    }
}

}  // namespace

// long: the min-warping cost loop nest (pairs x directions x columns x shifts) with its per-thread
// scratch, one parallel region
void warp_costs(const std::uint8_t* images, const std::uint8_t* stacks, std::size_t n_frames,
                const WarpGeometry& geometry, const std::int32_t* pairs, std::size_t n_pairs,
                const std::int32_t* first_direction, std::size_t n_directions, const std::int32_t* first_shift,
                std::size_t n_shifts, double* out, int threads) {
    check_geometry(geometry);
    if (n_frames == 0) throw std::invalid_argument("warp_costs: no frames");
    if (n_directions == 0 || n_shifts == 0) throw std::invalid_argument("warp_costs: n_directions and n_shifts >= 1");
    for (std::size_t p = 0; p < 2 * n_pairs; ++p) {
        if (pairs[p] < 0 || static_cast<std::size_t>(pairs[p]) >= n_frames) {
            throw std::invalid_argument("warp_costs: frame index " + std::to_string(pairs[p]) + " of pair " +
                                        std::to_string(p / 2) + " is not in [0, " + std::to_string(n_frames) + ")");
        }
    }
    const WarpGeometry& g = geometry;
    const std::size_t w = g.width, h = g.height, m_count = g.moves;
    const std::size_t frame_pixels = h * w;
    const std::size_t row_size = 2 * w, layer_size = w * row_size, table = g.scales * layer_size;
    // moves scanned per (direction, column): up to the last allowed one
    std::vector<std::size_t> scanned(g.directions * w, 0);
    for (std::size_t i = 0; i < g.directions * w; ++i) {
        for (std::size_t m = 0; m < m_count; ++m) {
            if (g.level[i * m_count + m] >= 0) scanned[i] = m + 1;
        }
    }
    detail::parallel_for(n_pairs, threads, [&](std::size_t p) {
        // scratch kept by each thread from pair to pair (the cost table is 520 KB at 48 x 24)
        thread_local std::vector<double> cost, best, total;
        thread_local std::vector<std::size_t> counted;
        thread_local std::vector<std::uint8_t> a_rows, b_rows;
        const std::size_t padded = (h + 15) / 16 * 16;
        cost.resize(table);
        best.resize(w);
        total.resize(w);
        counted.resize(w);
        a_rows.resize(padded);
        b_rows.resize(w * padded);
        const std::size_t a = static_cast<std::size_t>(pairs[2 * p]);
        const std::size_t b = static_cast<std::size_t>(pairs[2 * p + 1]);
        column_costs(stacks + a * g.scales * frame_pixels, images + b * frame_pixels, g, cost.data(), a_rows.data(),
                     b_rows.data());
        double* result = out + p * n_directions * n_shifts;
        for (std::size_t d = 0; d < n_directions; ++d) {
            const std::size_t dir = wrap(std::int64_t{first_direction[p]} + static_cast<std::int64_t>(d), g.directions);
            const std::int32_t* levels = g.level + dir * w * m_count;
            const std::int32_t* signs = g.sign + dir * w;
            const std::size_t* counts = scanned.data() + dir * w;
            // shifts in runs of at most W: shift k0 + s of column c moved m reads B's column
            // (c + k0 - sign * m) mod W + s of the doubled row, no wrap inside a run
            for (std::size_t s0 = 0; s0 < n_shifts; s0 += w) {
                const std::size_t run = n_shifts - s0 < w ? n_shifts - s0 : w;
                const std::size_t k0 =
                    wrap(std::int64_t{first_shift[p]} + static_cast<std::int64_t>(s0), w);  // in [0, W)
                for (std::size_t s = 0; s < run; ++s) {
                    total[s] = 0.0;
                    counted[s] = 0;
                }
                for (std::size_t c = 0; c < w; ++c) {
                    for (std::size_t s = 0; s < run; ++s) best[s] = kInf;
                    const std::int32_t* moves = levels + c * m_count;
                    const std::size_t back = signs[c] > 0 ? w - 1 : 1;  // -sign mod W
                    std::size_t start = (c + k0) % w;
                    const double* column = cost.data() + c * row_size;
                    for (std::size_t m = 0; m < counts[c];
                         ++m, start = start + back < w ? start + back : start + back - w) {
                        const std::int32_t layer = moves[m];
                        if (layer < 0) continue;
                        const std::size_t first =
                            static_cast<std::size_t>(layer) < g.scales ? static_cast<std::size_t>(layer) : 0;
                        const std::size_t last = static_cast<std::size_t>(layer) < g.scales ? first + 1 : g.scales;
                        for (std::size_t l = first; l < last; ++l) {  // one scale, or any (on the axis)
                            const double* values = column + l * layer_size + start;
                            for (std::size_t s = 0; s < run; ++s) best[s] = values[s] < best[s] ? values[s] : best[s];
                        }
                    }
                    for (std::size_t s = 0; s < run; ++s) {
                        if (best[s] < kInf) {
                            total[s] += best[s];
                            ++counted[s];
                        }
                    }
                }
                for (std::size_t s = 0; s < run; ++s) {
                    result[d * n_shifts + s0 + s] = counted[s] ? total[s] / static_cast<double>(counted[s]) : kInf;
                }
            }
        }
    });
}

}  // namespace nightloc
