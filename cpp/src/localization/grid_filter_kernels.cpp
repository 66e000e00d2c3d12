// Loops of the grid filter, the same source compiled for each SIMD path with target attributes
// (the pattern of heatmap_kernels.cpp): scalar (plain loops, no auto-vectorization), the baseline
// (SSE2 on x86-64, NEON on AArch64), AVX2 and AVX-512F. Loops that sum taps, interpolate and
// exponentiate are written with GCC/Clang vector types of the path's own register width (4, 8 or
// 16 floats: a generic vector wider than the target's registers is kept in memory and lowered
// element by element, several times slower than scalar code); simple element-wise loops are left
// to the compiler's vectorizer. No FMA contraction (-ffp-contract=off), every element the same
// sequence of operations and a fixed lane order for sums: every path returns the same values.
#include "localization/grid_filter_kernels.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <utility>

#include "common/arch.hpp"
#include "common/float_kernel_table.hpp"

#define NL_INLINE inline __attribute__((always_inline))
// Loops over a template's few vectors or bins, unrolled: their accumulators stay in registers.
#if defined(__clang__)
#define NL_UNROLL _Pragma("unroll")
#else
#define NL_UNROLL _Pragma("GCC unroll 16")
#endif

namespace nightloc::detail {
namespace {

// 2^f on [-0.5, 0.5], least squares in relative error (float32 Horner: < 2.6e-7 relative).
constexpr float kC0 = 1.000000000e+00f, kC1 = 6.931469440e-01f, kC2 = 2.402231842e-01f, kC3 = 5.550833791e-02f,
                kC4 = 9.666752070e-03f, kC5 = 1.321695396e-03f;
constexpr float kRound = 12582912.f;  // 1.5 * 2^23: (y + kRound) - kRound rounds y to an integer
constexpr float kLowest = -60.f;      // the likelihood's floor, 2^-60

NL_INLINE float exp2_scalar(float y) {
    const float r = (y + kRound) - kRound;
    const float f = y - r;
    float p = kC5;
    p = p * f + kC4;
    p = p * f + kC3;
    p = p * f + kC2;
    p = p * f + kC1;
    p = p * f + kC0;
    const std::int32_t bits = (static_cast<std::int32_t>(r) + 127) * (1 << 23);
    float scale;
    std::memcpy(&scale, &bits, sizeof(scale));
    return p * scale;
}

// Vectors of L float lanes, the path's register width: F floats, I int32, H the half of F (L/2
// floats) and D L/2 doubles (F's bytes). Passed by reference only (no ABI questions between
// targets).
template <int L>
struct Vec;
template <>
struct Vec<4> {
    typedef float F __attribute__((vector_size(16)));
    typedef std::int32_t I __attribute__((vector_size(16)));
    typedef float H __attribute__((vector_size(8)));
    typedef double D __attribute__((vector_size(16)));
};
template <>
struct Vec<8> {
    typedef float F __attribute__((vector_size(32)));
    typedef std::int32_t I __attribute__((vector_size(32)));
    typedef float H __attribute__((vector_size(16)));
    typedef double D __attribute__((vector_size(32)));
};
template <>
struct Vec<16> {
    typedef float F __attribute__((vector_size(64)));
    typedef std::int32_t I __attribute__((vector_size(64)));
    typedef float H __attribute__((vector_size(32)));
    typedef double D __attribute__((vector_size(64)));
};

template <int L>
NL_INLINE void load(typename Vec<L>::F& v, const float* p) {
    std::memcpy(&v, p, sizeof(v));
}

template <int L>
NL_INLINE void store(float* p, const typename Vec<L>::F& v) {
    std::memcpy(p, &v, sizeof(v));
}

template <int L>
NL_INLINE void exp2_vector(const typename Vec<L>::F& y, typename Vec<L>::F& out) {
    using F = typename Vec<L>::F;
    using I = typename Vec<L>::I;
    const F r = (y + kRound) - kRound;
    const F f = y - r;
    F p = f * kC5 + kC4;
    p = p * f + kC3;
    p = p * f + kC2;
    p = p * f + kC1;
    p = p * f + kC0;
    const I bits = (__builtin_convertvector(r, I) + 127) * (1 << 23);
    F scale;
    std::memcpy(&scale, &bits, sizeof(scale));
    out = p * scale;
}

// lo += double(v[0 .. L/2)), hi += double(v[L/2 .. L)).
template <int L>
NL_INLINE void add_double(const typename Vec<L>::F& v, typename Vec<L>::D& lo, typename Vec<L>::D& hi) {
    typename Vec<L>::H a, b;
    std::memcpy(&a, &v, sizeof(a));
    std::memcpy(&b, reinterpret_cast<const char*>(&v) + sizeof(a), sizeof(b));
    lo += __builtin_convertvector(a, typename Vec<L>::D);
    hi += __builtin_convertvector(b, typename Vec<L>::D);
}

// 16 double lanes as 32 / L vectors of L / 2.
template <int L>
struct Lanes {
    typename Vec<L>::D d[32 / L];
    NL_INLINE void read(const double* lanes) { std::memcpy(d, lanes, sizeof(d)); }
    NL_INLINE void write(double* lanes) const { std::memcpy(lanes, d, sizeof(d)); }
    // lanes[i] += values[i] for i < 16
    NL_INLINE void add16(const float* values) {
        for (int v = 0; v < 16 / L; ++v) {
            typename Vec<L>::F x;
            load<L>(x, values + L * v);
            add_double<L>(x, d[2 * v], d[2 * v + 1]);
        }
    }
};

// ---------------------------------------------------------------------------------------------
// bodies shared by every path (L: the path's float lanes; 1 = element by element)

NL_INLINE void box_rows_body(const float* __restrict src, float* __restrict dst, std::size_t rows, std::size_t cols,
                             const BoxPass& pass, float* __restrict acc, const float* __restrict zeros) {
    const std::size_t r = pass.r;
    const auto alpha = static_cast<float>(pass.alpha), inv_w = static_cast<float>(pass.inv_w);
    for (std::size_t i = 0; i < cols; ++i) acc[i] = 0.f;
    for (std::size_t t = 0; t <= r && t < rows; ++t) {
        const float* row = src + t * cols;
        for (std::size_t i = 0; i < cols; ++i) acc[i] = acc[i] + row[i];
    }
    for (std::size_t j = 0; j < rows; ++j) {
        const float* lo = j >= r + 1 ? src + (j - r - 1) * cols : zeros;
        const float* hi = j + r + 1 < rows ? src + (j + r + 1) * cols : zeros;
        const float* gone = j >= r ? src + (j - r) * cols : zeros;
        float* out = dst + j * cols;
        for (std::size_t i = 0; i < cols; ++i) {
            const float a = acc[i];
            const float v = (a + alpha * (lo[i] + hi[i])) * inv_w;
            out[i] = v > 0.f ? v : 0.f;  // a negative rounding residue of the running sum becomes 0
            acc[i] = (a + hi[i]) - gone[i];
        }
    }
}

// out[i] = sum_t taps[t] * in[t][i] for i in [0, cols), summed in float from 0 in t order: blocks
// of V vectors (independent sums hide the adds' latency), then one block of the vectors left,
// the last one shifted back to end at the row's end (its overlap is recomputed, to the same
// values); rows shorter than a vector element by element. Every element is the same sequence of
// operations.
NL_INLINE void taps_one(const float* const* in, const float* taps, std::size_t n_taps, float* out, std::size_t i) {
    float acc = 0.f;
    for (std::size_t t = 0; t < n_taps; ++t) acc = acc + taps[t] * in[t][i];
    out[i] = acc;
}

// V vectors at out + pos[v].
template <int L, int V>
NL_INLINE void taps_block(const float* const* in, const float* taps, std::size_t n_taps, float* out,
                          const std::size_t* pos) {
    using F = typename Vec<L>::F;
    F acc[V];
    NL_UNROLL
    for (int v = 0; v < V; ++v) acc[v] = F{};
    for (std::size_t t = 0; t < n_taps; ++t) {
        const float g = taps[t];
        const float* x = in[t];
        NL_UNROLL
        for (int v = 0; v < V; ++v) {
            F xv;
            load<L>(xv, x + pos[v]);
            acc[v] = acc[v] + g * xv;
        }
    }
    NL_UNROLL
    for (int v = 0; v < V; ++v) store<L>(out + pos[v], acc[v]);
}

// Vectors per block (independent sums hide the adds' latency).
template <int L>
constexpr int kTapVectors = L == 16 ? 4 : 8;

template <int L>
NL_INLINE void taps_row(const float* const* in, const float* taps, std::size_t n_taps, float* out, std::size_t cols) {
    if constexpr (L == 1) {
        for (std::size_t i = 0; i < cols; ++i) taps_one(in, taps, n_taps, out, i);
    } else {
        if (cols < static_cast<std::size_t>(L)) {
            for (std::size_t i = 0; i < cols; ++i) taps_one(in, taps, n_taps, out, i);
            return;
        }
        constexpr int V = kTapVectors<L>;
        constexpr std::size_t width = static_cast<std::size_t>(V * L);
        std::size_t pos[V];
        std::size_t i = 0;
        // whole blocks while more than one block is left (the rest: one block of 1 .. V vectors)
        for (; i + width < cols; i += width) {
            NL_UNROLL
            for (int v = 0; v < V; ++v) pos[v] = i + static_cast<std::size_t>(L * v);
            taps_block<L, V>(in, taps, n_taps, out, pos);
        }
        const std::size_t vectors = (cols - i + L - 1) / L;  // 1 .. V
        for (std::size_t v = 0; v < vectors; ++v) pos[v] = std::min(i + L * v, cols - L);
        switch (vectors) {
            case 1:
                taps_block<L, 1>(in, taps, n_taps, out, pos);
                break;
            case 2:
                taps_block<L, 2>(in, taps, n_taps, out, pos);
                break;
            case 3:
                taps_block<L, 3>(in, taps, n_taps, out, pos);
                break;
            case 4:
                taps_block<L, 4>(in, taps, n_taps, out, pos);
                break;
            case 5:
                if constexpr (V >= 5) taps_block<L, 5>(in, taps, n_taps, out, pos);
                break;
            case 6:
                if constexpr (V >= 6) taps_block<L, 6>(in, taps, n_taps, out, pos);
                break;
            case 7:
                if constexpr (V >= 7) taps_block<L, 7>(in, taps, n_taps, out, pos);
                break;
            default:
                if constexpr (V >= 8) taps_block<L, 8>(in, taps, n_taps, out, pos);
                break;
        }
    }
}

// Two rows at once: out0[i] = sum_t taps[t] * in[t][i] and out1[i] = sum_t taps[t] * in[t + 1][i]
// (in: n_taps + 1 rows), each summed in float from 0 in t order as taps_row does: every loaded
// vector of a source row serves both.
template <int L, int V>
NL_INLINE void taps_block2(const float* const* in, const float* taps, std::size_t n_taps, float* out0, float* out1,
                           const std::size_t* pos) {
    using F = typename Vec<L>::F;
    F acc0[V], acc1[V];
    NL_UNROLL
    for (int v = 0; v < V; ++v) {
        acc0[v] = F{};
        acc1[v] = F{};
    }
    {
        const float g = taps[0];
        NL_UNROLL
        for (int v = 0; v < V; ++v) {
            F xv;
            load<L>(xv, in[0] + pos[v]);
            acc0[v] = acc0[v] + g * xv;
        }
    }
    for (std::size_t t = 1; t < n_taps; ++t) {
        const float g0 = taps[t], g1 = taps[t - 1];
        const float* x = in[t];
        NL_UNROLL
        for (int v = 0; v < V; ++v) {
            F xv;
            load<L>(xv, x + pos[v]);
            acc0[v] = acc0[v] + g0 * xv;
            acc1[v] = acc1[v] + g1 * xv;
        }
    }
    {
        const float g = taps[n_taps - 1];
        NL_UNROLL
        for (int v = 0; v < V; ++v) {
            F xv;
            load<L>(xv, in[n_taps] + pos[v]);
            acc1[v] = acc1[v] + g * xv;
        }
    }
    NL_UNROLL
    for (int v = 0; v < V; ++v) {
        store<L>(out0 + pos[v], acc0[v]);
        store<L>(out1 + pos[v], acc1[v]);
    }
}

NL_INLINE void taps_one2(const float* const* in, const float* taps, std::size_t n_taps, float* out0, float* out1,
                         std::size_t i) {
    taps_one(in, taps, n_taps, out0, i);
    taps_one(in + 1, taps, n_taps, out1, i);
}

// Vectors per block of taps_row2 (two accumulators each), on every path.
constexpr int kTapVectors2 = 4;

template <int L>
NL_INLINE void taps_row2(const float* const* in, const float* taps, std::size_t n_taps, float* out0, float* out1,
                         std::size_t cols) {
    if constexpr (L == 1) {
        for (std::size_t i = 0; i < cols; ++i) taps_one2(in, taps, n_taps, out0, out1, i);
    } else {
        if (cols < static_cast<std::size_t>(L)) {
            for (std::size_t i = 0; i < cols; ++i) taps_one2(in, taps, n_taps, out0, out1, i);
            return;
        }
        constexpr int V = kTapVectors2;
        constexpr std::size_t width = static_cast<std::size_t>(V * L);
        std::size_t pos[V];
        std::size_t i = 0;
        for (; i + width < cols; i += width) {
            NL_UNROLL
            for (int v = 0; v < V; ++v) pos[v] = i + static_cast<std::size_t>(L * v);
            taps_block2<L, V>(in, taps, n_taps, out0, out1, pos);
        }
        const std::size_t vectors = (cols - i + L - 1) / L;  // 1 .. V
        for (std::size_t v = 0; v < vectors; ++v) pos[v] = std::min(i + L * v, cols - L);
        switch (vectors) {
            case 1:
                taps_block2<L, 1>(in, taps, n_taps, out0, out1, pos);
                break;
            case 2:
                taps_block2<L, 2>(in, taps, n_taps, out0, out1, pos);
                break;
            case 3:
                taps_block2<L, 3>(in, taps, n_taps, out0, out1, pos);
                break;
            default:
                taps_block2<L, 4>(in, taps, n_taps, out0, out1, pos);
                break;
        }
    }
}

// dst[j][i] = sum_t taps[t] * src[j + t - offset][i] (rows outside [0, rows) count 0).
template <int L>
NL_INLINE void conv_rows_body(const float* src, float* dst, std::size_t rows, std::size_t cols, const float* taps,
                              std::size_t n_taps, std::ptrdiff_t offset, const float* zeros) {
    const float* in[kMaxTaps];
    for (std::size_t j = 0; j < rows; ++j) {
        for (std::size_t t = 0; t < n_taps; ++t) {
            const std::ptrdiff_t r = static_cast<std::ptrdiff_t>(j + t) - offset;
            in[t] = r >= 0 && r < static_cast<std::ptrdiff_t>(rows) ? src + static_cast<std::size_t>(r) * cols : zeros;
        }
        taps_row<L>(in, taps, n_taps, dst + j * cols, cols);
    }
}

// dst[j][i] = sum_t taps[t] * src[j][i + t - offset] (columns outside [0, cols) count 0);
// `padded` holds cols + n_taps floats of scratch.
template <int L>
NL_INLINE void conv_cols_body(const float* src, float* dst, std::size_t rows, std::size_t cols, const float* taps,
                              std::size_t n_taps, std::ptrdiff_t offset, float* padded) {
    const std::ptrdiff_t lead = offset;  // padded[q] = x[q - lead]: output i reads padded[i + t]
    const std::size_t length = cols + n_taps;
    const float* in[kMaxTaps];
    for (std::size_t t = 0; t < n_taps; ++t) in[t] = padded + t;
    for (std::size_t j = 0; j < rows; ++j) {
        const float* x = src + j * cols;
        const std::ptrdiff_t q0 = lead > 0 ? lead : 0;
        const std::ptrdiff_t q1 =
            std::min(static_cast<std::ptrdiff_t>(length), lead + static_cast<std::ptrdiff_t>(cols));
        const auto lo = static_cast<std::size_t>(std::min(q0, static_cast<std::ptrdiff_t>(length)));
        const auto hi = static_cast<std::size_t>(std::max(q1, static_cast<std::ptrdiff_t>(lo)));
        for (std::size_t q = 0; q < lo; ++q) padded[q] = 0.f;
        for (std::size_t q = lo; q < hi; ++q) padded[q] = x[static_cast<std::ptrdiff_t>(q) - lead];
        for (std::size_t q = hi; q < length; ++q) padded[q] = 0.f;
        taps_row<L>(in, taps, n_taps, dst + j * cols, cols);
    }
}

template <int L>
NL_INLINE void shift_blur_body(const ShiftBlurArgs& a) {
    const float* in[kMaxTaps + 1];
    const float* xin[2][kMaxTaps];
    const std::size_t span = (a.cols + 2 * a.pad + 15) / 16 * 16;  // two row buffers (whole lines)
    for (std::size_t k = 0; k < 2; ++k)
        for (std::size_t t = 0; t < a.n_x; ++t) xin[k][t] = a.buf + k * span + a.pad + t - a.off_x;
    const auto rows = static_cast<std::ptrdiff_t>(a.rows);
    // output rows two at a time: the row pass of both reads each source row once
    for (std::size_t j = 0; j < a.rows; j += 2) {
        const bool pair = j + 1 < a.rows;
        for (std::size_t t = 0; t < a.n_y + (pair ? 1 : 0); ++t) {
            const std::ptrdiff_t r = static_cast<std::ptrdiff_t>(j + t) - a.off_y;
            in[t] = r >= 0 && r < rows ? a.src + static_cast<std::size_t>(r) * a.cols : a.zeros;
        }
        // the source rows that the next pair reads first (the others are cached)
        for (std::size_t k = 1; k <= 2; ++k) {
            const std::ptrdiff_t next = static_cast<std::ptrdiff_t>(j + a.n_y + k) - a.off_y;
            if (next >= 0 && next < rows) {
                const float* p = a.src + static_cast<std::size_t>(next) * a.cols;
                for (std::size_t i = 0; i < a.cols; i += 16) __builtin_prefetch(p + i);
            }
        }
        if (pair) {
            taps_row2<L>(in, a.taps_y, a.n_y, a.buf + a.pad, a.buf + span + a.pad, a.cols);
            taps_row<L>(xin[0], a.taps_x, a.n_x, a.dst + j * a.cols, a.cols);
            taps_row<L>(xin[1], a.taps_x, a.n_x, a.dst + (j + 1) * a.cols, a.cols);
        } else {
            taps_row<L>(in, a.taps_y, a.n_y, a.buf + a.pad, a.cols);
            taps_row<L>(xin[0], a.taps_x, a.n_x, a.dst + j * a.cols, a.cols);
        }
    }
}

NL_INLINE void transpose_body(const float* __restrict src, float* __restrict dst, std::size_t rows, std::size_t cols) {
    constexpr std::size_t kTile = 16;
    for (std::size_t r0 = 0; r0 < rows; r0 += kTile) {
        const std::size_t r1 = r0 + kTile < rows ? r0 + kTile : rows;
        for (std::size_t c0 = 0; c0 < cols; c0 += kTile) {
            const std::size_t c1 = c0 + kTile < cols ? c0 + kTile : cols;
            for (std::size_t c = c0; c < c1; ++c)
                for (std::size_t r = r0; r < r1; ++r) dst[c * rows + r] = src[r * cols + c];
        }
    }
}

NL_INLINE void scale_add_body(float* __restrict values, std::size_t n, float a, float f) {
    for (std::size_t c = 0; c < n; ++c) values[c] = values[c] * a + f;
}

template <int L>
NL_INLINE void heading_conv_body(const float* work, std::size_t bins, std::size_t n, std::size_t c0, std::size_t m,
                                 const float* taps, const std::size_t* offsets, std::size_t n_taps, float a, float f,
                                 float* belief) {
    const float* in[kMaxTaps];
    for (std::size_t b = 0; b < bins; ++b) {
        for (std::size_t t = 0; t < n_taps; ++t) in[t] = work + ((b + bins - offsets[t]) % bins) * n + c0;
        float* out = belief + b * n + c0;
        taps_row<L>(in, taps, n_taps, out, m);
        scale_add_body(out, m, a, f);
    }
}

NL_INLINE void sum_slices_body(const float* __restrict in, std::size_t bins, std::size_t n, float* __restrict out) {
    for (std::size_t c = 0; c < n; ++c) out[c] = 0.f;
    for (std::size_t b = 0; b < bins; ++b) {
        const float* x = in + b * n;
        for (std::size_t c = 0; c < n; ++c) out[c] = out[c] + x[c];
    }
}

// ---------------------------------------------------------------------------------------------
// the measurement

// The log2-likelihood of cell c in bin b's values (the sum of UpdateArgs), not yet floored.
NL_INLINE float log_lik_one(const UpdateArgs& u, std::size_t b, std::size_t c) {
    const float* values = u.log_lik + (b - u.group_b0);
    const std::size_t block = c / kBlock;
    const auto e0 = static_cast<std::size_t>(u.block_start[block]),
               e1 = static_cast<std::size_t>(u.block_start[block + 1]);
    float y = 0.f;
    if (e1 > e0) {
        const std::size_t lane = c % kBlock;
        for (std::size_t e = e0; e < e1; ++e)
            y = y + u.block_weights[e * kBlock + lane] * values[static_cast<std::size_t>(u.block_places[e]) * u.stride];
    } else {
        y = u.sparse_y[(b - u.group_b0) * u.n + c];
    }
    return y;
}

// The measurement of cell c in bin b (the scalar path and every path's short last block).
NL_INLINE void measure_one(const UpdateArgs& u, const float* const* in, std::size_t b, std::size_t c) {
    float y = log_lik_one(u, b, c);
    y = y > kLowest ? y : kLowest;
    float acc = 0.f;
    for (std::size_t t = 0; t < u.n_taps; ++t) acc = acc + u.taps[t] * in[t][c];
    const float p = (acc * u.a + u.f) * exp2_scalar(y);
    u.belief[b * u.n + c] = p;
    u.marginal[c] = (b == 0 ? 0.f : u.marginal[c]) + p;
    if (u.bin_max != nullptr) u.bin_max[b] = p > u.bin_max[b] ? p : u.bin_max[b];
}

// One full block of kBlock cells from c in Q bins from b (in: per bin its n_taps slices): the
// block's weights are read once for all Q bins (each bin alone would stream the map's weights
// from L2 once per bin), and the Q kBlock / L vectors are independent chains.
template <int L, int Q>
NL_INLINE void measure_block(const UpdateArgs& u, std::size_t b, const float* const* in, std::size_t c,
                             typename Vec<L>::F* high) {
    using F = typename Vec<L>::F;
    constexpr int V = static_cast<int>(kBlock) / L;  // vectors per block
    const F zero = {}, lowest = zero + kLowest;
    F y[Q][V];
    NL_UNROLL
    for (int q = 0; q < Q; ++q) NL_UNROLL
    for (int v = 0; v < V; ++v) y[q][v] = zero;
    const float* values = u.log_lik + (b - u.group_b0);
    const std::size_t block = c / kBlock;
    const auto e0 = static_cast<std::size_t>(u.block_start[block]);
    const auto e1 = static_cast<std::size_t>(u.block_start[block + 1]);
    if (e1 > e0) {
        const float* w = u.block_weights + e0 * kBlock;
        for (std::size_t e = e0; e < e1; ++e, w += kBlock) {
            const std::size_t place = static_cast<std::size_t>(u.block_places[e]);
            F x[V];
            NL_UNROLL
            for (int v = 0; v < V; ++v) load<L>(x[v], w + L * v);
            NL_UNROLL
            for (int q = 0; q < Q; ++q) {
                const float g = values[place * u.stride + static_cast<std::size_t>(q)];
                NL_UNROLL
                for (int v = 0; v < V; ++v) y[q][v] = y[q][v] + x[v] * g;
            }
        }
    } else {  // interpolated beforehand (FilterKernels::interpolate)
        NL_UNROLL
        for (int q = 0; q < Q; ++q) {
            const float* yq = u.sparse_y + (b + static_cast<std::size_t>(q) - u.group_b0) * u.n + c;
            NL_UNROLL
            for (int v = 0; v < V; ++v) load<L>(y[q][v], yq + L * v);
        }
    }
    const float a = u.a, f = u.f;
    F mg[V];
    NL_UNROLL
    for (int v = 0; v < V; ++v) {
        if (b == 0) {
            mg[v] = zero;
        } else {
            load<L>(mg[v], u.marginal + c + L * v);
        }
    }
    NL_UNROLL
    for (int q = 0; q < Q; ++q) {
        const std::size_t bq = b + static_cast<std::size_t>(q);
        F acc[V];
        NL_UNROLL
        for (int v = 0; v < V; ++v) acc[v] = zero;
        for (std::size_t t = 0; t < u.n_taps; ++t) {
            const float g = u.taps[t];
            const float* x = in[static_cast<std::size_t>(q) * u.n_taps + t] + c;
            NL_UNROLL
            for (int v = 0; v < V; ++v) {
                F xv;
                load<L>(xv, x + L * v);
                acc[v] = acc[v] + g * xv;
            }
        }
        float* belief = u.belief + bq * u.n + c;
        NL_UNROLL
        for (int v = 0; v < V; ++v) {
            const F yy = y[q][v] > lowest ? y[q][v] : lowest;
            F l;
            exp2_vector<L>(yy, l);
            const F p = (acc[v] * a + f) * l;
            store<L>(belief + L * v, p);
            mg[v] = mg[v] + p;
            high[q] = p > high[q] ? p : high[q];
        }
    }
    NL_UNROLL
    for (int v = 0; v < V; ++v) store<L>(u.marginal + c + L * v, mg[v]);
}

// Bins per pass: 4 (2 with 16-byte registers, whose blocks are 4 vectors).
template <int L>
constexpr int kMeasureBins = L == 4 ? 2 : 4;

template <int L, int Q>
NL_INLINE void measure_bins(const UpdateArgs& u, std::size_t b, const float* const* in, std::size_t c0,
                            std::size_t full) {
    typename Vec<L>::F high[Q] = {};  // the bins' largest values (beliefs are >= 0)
    for (std::size_t c = c0; c < full; c += kBlock) measure_block<L, Q>(u, b, in, c, high);
    if (u.bin_max == nullptr) return;
    for (int q = 0; q < Q; ++q) {
        float m = u.bin_max[b + static_cast<std::size_t>(q)];
        for (int l = 0; l < L; ++l) m = high[q][l] > m ? high[q][l] : m;
        u.bin_max[b + static_cast<std::size_t>(q)] = m;
    }
}

template <int L>
NL_INLINE void measure_body(const UpdateArgs& u, std::size_t b, std::size_t bins, const float* const* in,
                            std::size_t c0, std::size_t m) {
    const std::size_t full = L == 1 ? c0 : c0 + m - m % kBlock;
    if (u.bin_max != nullptr && c0 == 0)
        for (std::size_t q = 0; q < bins; ++q) u.bin_max[b + q] = 0.f;
    if constexpr (L != 1) {
        constexpr std::size_t Q = kMeasureBins<L>;
        std::size_t q = 0;
        for (; q + Q <= bins; q += Q) measure_bins<L, Q>(u, b + q, in + q * u.n_taps, c0, full);
        for (; q < bins; ++q) measure_bins<L, 1>(u, b + q, in + q * u.n_taps, c0, full);
    }
    for (std::size_t q = 0; q < bins; ++q)
        for (std::size_t c = full; c < c0 + m; ++c) measure_one(u, in + q * u.n_taps, b + q, c);
}

// Lane j of interleave's lo output: a[j / 2] for even j, b[j / 2] for odd (hi: from the upper halves).
constexpr int interleave_lane(int j, int lanes, bool upper) {
    return (j % 2 ? lanes : 0) + j / 2 + (upper ? lanes / 2 : 0);
}

// lo = (a0, b0, a1, b1, ...) and hi the same of the upper halves: one two-source shuffle each.
template <int L, int... J>
NL_INLINE void interleave(const typename Vec<L>::F& a, const typename Vec<L>::F& b, typename Vec<L>::F& lo,
                          typename Vec<L>::F& hi, std::integer_sequence<int, J...>) {
#if defined(__clang__)
    lo = __builtin_shufflevector(a, b, interleave_lane(J, L, false)...);
    hi = __builtin_shufflevector(a, b, interleave_lane(J, L, true)...);
#else
    using I = typename Vec<L>::I;
    const I lo_mask = {interleave_lane(J, L, false)...}, hi_mask = {interleave_lane(J, L, true)...};
    lo = __builtin_shuffle(a, b, lo_mask);
    hi = __builtin_shuffle(a, b, hi_mask);
#endif
}

// One stage of transpose_square: rows i and i + H (i without bit H) interleaved.
template <int L, int H>
NL_INLINE void transpose_stage(typename Vec<L>::F* r) {
    NL_UNROLL
    for (int i = 0; i < L; ++i) {
        if (i & H) continue;
        typename Vec<L>::F lo, hi;
        interleave<L>(r[i], r[i + H], lo, hi, std::make_integer_sequence<int, L>{});
        r[i] = lo;
        r[i + H] = hi;
    }
    if constexpr (H > 1) transpose_stage<L, H / 2>(r);
}

// r[i][j] becomes r[j][i] (L x L floats in L registers): log2 L stages of interleaves, pairing
// rows H apart for H = L / 2, ..., 1.
template <int L>
NL_INLINE void transpose_square(typename Vec<L>::F* r) {
    transpose_stage<L, L / 2>(r);
}

// One cell's log2-likelihood in bin q of the group: its ELL slots in slot order, summed in float from 0.
NL_INLINE float interpolate_one(const UpdateArgs& u, std::size_t c, std::size_t q) {
    float acc = 0.f;
    for (std::size_t k = 0; k < u.slots; ++k) {
        acc = acc + u.data[k * u.n + c] * u.log_lik[static_cast<std::size_t>(u.index[k * u.n + c]) * u.stride + q];
    }
    return acc;
}

// Per block that is not dense: its cells' log2-likelihoods in the group's bins. Four cells x
// four bins at a time (every path alike: 4-float vectors): each cell's four bins summed slot by
// slot from its places' rows (contiguous loads), the square transposed in registers, stored bin
// by bin; other bin counts and short blocks cell by cell (the same operations per value).
template <int L>
NL_INLINE void interpolate_body(const UpdateArgs& u, std::size_t bins, float* __restrict y) {
    const std::size_t blocks = (u.n + kBlock - 1) / kBlock;
    const float* rows = u.log_lik;
    for (std::size_t block = 0; block < blocks; ++block) {
        if (u.block_start[block + 1] > u.block_start[block]) continue;  // dense: the measurement interpolates
        const std::size_t c0 = block * kBlock, m = u.n - c0 < kBlock ? u.n - c0 : kBlock;
        if constexpr (L != 1) {
            if (m == kBlock && bins == 4) {
                using F = typename Vec<4>::F;
                for (std::size_t g = 0; g < kBlock; g += 4) {
                    F r[4];
                    NL_UNROLL
                    for (int l = 0; l < 4; ++l) {
                        const std::size_t c = c0 + g + static_cast<std::size_t>(l);
                        F acc = {};
                        for (std::size_t k = 0; k < u.slots; ++k) {
                            const float w = u.data[k * u.n + c];
                            F x;
                            load<4>(x, rows + static_cast<std::size_t>(u.index[k * u.n + c]) * u.stride);
                            acc = acc + w * x;
                        }
                        r[l] = acc;
                    }
                    transpose_square<4>(r);
                    NL_UNROLL
                    for (int j = 0; j < 4; ++j) store<4>(y + static_cast<std::size_t>(j) * u.n + c0 + g, r[j]);
                }
                continue;
            }
        }
        for (std::size_t b = 0; b < bins; ++b)
            for (std::size_t l = 0; l < m; ++l) y[b * u.n + c0 + l] = interpolate_one(u, c0 + l, b);
    }
}

// ---------------------------------------------------------------------------------------------
// the scores of a frame (element-wise loops: the path's vectorizer, the same values)

constexpr std::size_t kMinLanes = 16;  // independent running minima per row (exact in any order)

NL_INLINE bool row_minima_body(const float* __restrict table, std::size_t n, std::size_t S, float* __restrict mins,
                               std::int32_t* __restrict best) {
    std::uint32_t bad = 0;
    for (std::size_t i = 0; i < n * S; ++i) {  // a NaN or an infinity: all exponent bits set
        std::uint32_t bits;
        std::memcpy(&bits, table + i, sizeof(bits));
        bad |= static_cast<std::uint32_t>((bits & 0x7f800000u) == 0x7f800000u);
    }
    if (bad) return true;
    const auto none = static_cast<std::int32_t>(S);
    for (std::size_t i = 0; i < n; ++i) {
        const float* row = table + i * S;
        float low = row[0];
        std::size_t k = 0;
        if (S >= kMinLanes) {  // independent minima (exact in any order): they vectorize
            float lane[kMinLanes];
            for (std::size_t l = 0; l < kMinLanes; ++l) lane[l] = row[l];
            for (k = kMinLanes; k + kMinLanes <= S; k += kMinLanes)
                for (std::size_t l = 0; l < kMinLanes; ++l) lane[l] = row[k + l] < lane[l] ? row[k + l] : lane[l];
            for (std::size_t l = 0; l < kMinLanes; ++l) low = lane[l] < low ? lane[l] : low;
        }
        for (; k < S; ++k) low = row[k] < low ? row[k] : low;
        std::int32_t first = none;  // the first column holding it: a minimum of indices (it vectorizes)
        for (std::size_t c = 0; c < S; ++c) {
            const std::int32_t candidate = row[c] == low ? static_cast<std::int32_t>(c) : none;
            first = candidate < first ? candidate : first;
        }
        mins[i] = low;
        best[i] = first < none ? first : 0;
    }
    return false;
}

NL_INLINE void lerp_rows_body(const float* __restrict table, std::size_t n, std::size_t W,
                              const std::int32_t* __restrict rows, const std::int32_t* __restrict c0s,
                              const double* __restrict fractions, float* __restrict ps, float* __restrict twice) {
    for (std::size_t i = 0; i < n; ++i) {
        const float* row = table + i * W;
        for (std::size_t k = 0; k < W; ++k) twice[k] = twice[W + k] = row[k];  // the row twice: k + 1 needs no wrap
        float* out = ps + static_cast<std::size_t>(rows[i]) * W;
        const float* x = twice + c0s[i];
        const double a = fractions[i], a0 = 1.0 - a;
        for (std::size_t b = 0; b < W; ++b) {
            const auto v = static_cast<float>(a0 * static_cast<double>(x[b]) + a * static_cast<double>(x[b + 1]));
            out[b] = v < out[b] ? v : out[b];
        }
    }
}

// out[b] = float(max(gain (double(v) - s_min), lowest)) with v = float(a0 x0[b] + a x1[b]) in
// double, for b < count: every element the same operations.
NL_INLINE void lerp_log_lik_run(const float* x0, const float* x1, std::size_t count, double a0, double a, double gain,
                                double s_min, double lowest, float* __restrict out) {
    for (std::size_t b = 0; b < count; ++b) {
        const auto v = static_cast<float>(a0 * static_cast<double>(x0[b]) + a * static_cast<double>(x1[b]));
        const double t = gain * (static_cast<double>(v) - s_min);
        out[b] = static_cast<float>(t > lowest ? t : lowest);
    }
}

NL_INLINE void lerp_log_lik_body(const float* __restrict table, std::size_t n, std::size_t W,
                                 const std::int32_t* __restrict rows, const std::uint8_t* __restrict first,
                                 const std::int32_t* __restrict c0s, const double* __restrict fractions, double gain,
                                 double s_min, double lowest, float* __restrict y, std::size_t group_rows,
                                 float* __restrict row_y) {
    for (std::size_t i = 0; i < n; ++i) {
        // bin b reads columns k = c0 + b and k + 1 (mod W), straight from the row: the bins before
        // the wrap, the one across it, the ones after
        const float* row = table + i * W;
        const double a = fractions[i], a0 = 1.0 - a;
        const auto c0 = static_cast<std::size_t>(c0s[i]);
        if (i + 1 < n) __builtin_prefetch(row + W + W - 1);
        const std::size_t before = W - 1 - c0;
        lerp_log_lik_run(row + c0, row + c0 + 1, before, a0, a, gain, s_min, lowest, row_y);
        lerp_log_lik_run(row + W - 1, row, 1, a0, a, gain, s_min, lowest, row_y + before);
        lerp_log_lik_run(row, row + 1, c0, a0, a, gain, s_min, lowest, row_y + before + 1);
        const auto r = static_cast<std::size_t>(rows[i]);
        std::size_t b0 = 0;
        using F4 = Vec<kGroupBins>::F;
        for (; b0 + kGroupBins <= W; b0 += kGroupBins) {  // whole groups: one 4-float chunk each
            float* out = y + ((b0 / kGroupBins) * group_rows + r) * kGroupBins;
            F4 v;
            load<kGroupBins>(v, row_y + b0);
            if (!first[i]) {
                F4 kept;
                load<kGroupBins>(kept, out);
                v = v > kept ? v : kept;
            }
            store<kGroupBins>(out, v);
        }
        for (; b0 < W; ++b0) {
            float* out = y + ((b0 / kGroupBins) * group_rows + r) * kGroupBins + b0 % kGroupBins;
            *out = first[i] || row_y[b0] > *out ? row_y[b0] : *out;
        }
    }
}

NL_INLINE void group_min_body(const float* __restrict y, std::size_t rows, std::size_t B, std::size_t group_rows,
                              float* __restrict low) {
    for (std::size_t b0 = 0; b0 < B; b0 += kGroupBins) {
        const float* group = y + (b0 / kGroupBins) * group_rows * kGroupBins;
        const std::size_t width = B - b0 < kGroupBins ? B - b0 : kGroupBins;
        using F4 = Vec<kGroupBins>::F;
        F4 m = {}, m2 = {};  // two independent chains
        for (std::size_t q = 0; q < kGroupBins; ++q) m[q] = m2[q] = q < width ? low[b0 + q] : 0.f;
        std::size_t r = 0;
        for (; r + 2 <= rows; r += 2) {
            F4 v, v2;
            load<kGroupBins>(v, group + r * kGroupBins);
            load<kGroupBins>(v2, group + (r + 1) * kGroupBins);
            m = v < m ? v : m;
            m2 = v2 < m2 ? v2 : m2;
        }
        if (r < rows) {
            F4 v;
            load<kGroupBins>(v, group + r * kGroupBins);
            m = v < m ? v : m;
        }
        m = m2 < m ? m2 : m;
        for (std::size_t q = 0; q < width; ++q) low[b0 + q] = m[q];
    }
}

NL_INLINE void column_max_body(const float* __restrict values, std::size_t rows, std::size_t B,
                               float* __restrict high) {
    for (std::size_t r = 0; r < rows; ++r) {
        const float* v = values + r * B;
        for (std::size_t b = 0; b < B; ++b) high[b] = v[b] > high[b] ? v[b] : high[b];
    }
}

NL_INLINE void log_lik_body(const float* __restrict score, std::size_t rows, std::size_t B, double gain, double s_min,
                            double lowest, float* __restrict y, std::size_t group_rows, std::size_t first_row) {
    for (std::size_t g = 0; g * kGroupBins < B; ++g) {
        const std::size_t b0 = g * kGroupBins, width = B - b0 < kGroupBins ? B - b0 : kGroupBins;
        float* out = y + (g * group_rows + first_row) * kGroupBins;
        for (std::size_t r = 0; r < rows; ++r) {
            for (std::size_t q = 0; q < width; ++q) {
                const double v = gain * (static_cast<double>(score[r * B + b0 + q]) - s_min);
                out[r * kGroupBins + q] = static_cast<float>(v > lowest ? v : lowest);
            }
        }
    }
}

NL_INLINE void scale_sums_body(const std::uint32_t* __restrict sums, std::size_t n, double divisor,
                               float* __restrict scores) {
    for (std::size_t k = 0; k < n; ++k) scores[k] = static_cast<float>(static_cast<double>(sums[k]) / divisor);
}

NL_INLINE float max_value_body(const float* __restrict values, std::size_t n) {
    float high = values[0];
    std::size_t c = 0;
    if (n >= kMinLanes) {  // independent maxima (exact in any order): they vectorize
        float lane[kMinLanes];
        for (std::size_t l = 0; l < kMinLanes; ++l) lane[l] = values[l];
        for (c = kMinLanes; c + kMinLanes <= n; c += kMinLanes)
            for (std::size_t l = 0; l < kMinLanes; ++l) lane[l] = values[c + l] > lane[l] ? values[c + l] : lane[l];
        for (std::size_t l = 0; l < kMinLanes; ++l) high = lane[l] > high ? lane[l] : high;
    }
    for (; c < n; ++c) high = values[c] > high ? values[c] : high;
    return high;
}

template <int L>
NL_INLINE void sum_body(const float* values, std::size_t n, double* lanes) {
    std::size_t c = 0;
    if constexpr (L != 1) {
        Lanes<L> s;
        s.read(lanes);
        for (; c + 16 <= n; c += 16) s.add16(values + c);
        s.write(lanes);
    }
    for (; c < n; ++c) lanes[c % kSumLanes] += static_cast<double>(values[c]);
}

#define NL_DEFINE_FILTER_KERNELS(suffix, attributes, lanes)                                                           \
    attributes void box_rows_##suffix(const float* src, float* dst, std::size_t rows, std::size_t cols,               \
                                      const BoxPass& pass, float* acc, const float* zeros) {                          \
        box_rows_body(src, dst, rows, cols, pass, acc, zeros);                                                        \
    }                                                                                                                 \
    attributes void conv_rows_##suffix(const float* src, float* dst, std::size_t rows, std::size_t cols,              \
                                       const float* taps, std::size_t n_taps, std::ptrdiff_t offset,                  \
                                       const float* zeros) {                                                          \
        conv_rows_body<lanes>(src, dst, rows, cols, taps, n_taps, offset, zeros);                                     \
    }                                                                                                                 \
    attributes void conv_cols_##suffix(const float* src, float* dst, std::size_t rows, std::size_t cols,              \
                                       const float* taps, std::size_t n_taps, std::ptrdiff_t offset, float* padded) { \
        conv_cols_body<lanes>(src, dst, rows, cols, taps, n_taps, offset, padded);                                    \
    }                                                                                                                 \
    attributes void shift_blur_##suffix(const ShiftBlurArgs& a) { shift_blur_body<lanes>(a); }                        \
    attributes void transpose_##suffix(const float* src, float* dst, std::size_t rows, std::size_t cols) {            \
        transpose_body(src, dst, rows, cols);                                                                         \
    }                                                                                                                 \
    attributes void heading_conv_##suffix(const float* work, std::size_t bins, std::size_t n, std::size_t c0,         \
                                          std::size_t m, const float* taps, const std::size_t* offsets,               \
                                          std::size_t n_taps, float a, float f, float* belief) {                      \
        heading_conv_body<lanes>(work, bins, n, c0, m, taps, offsets, n_taps, a, f, belief);                          \
    }                                                                                                                 \
    attributes void measure_##suffix(const UpdateArgs& u, std::size_t b, std::size_t bins, const float* const* in,    \
                                     std::size_t c0, std::size_t m) {                                                 \
        measure_body<lanes>(u, b, bins, in, c0, m);                                                                   \
    }                                                                                                                 \
    attributes void interpolate_##suffix(const UpdateArgs& u, std::size_t bins, float* y) {                           \
        interpolate_body<lanes>(u, bins, y);                                                                          \
    }                                                                                                                 \
    attributes bool row_minima_##suffix(const float* table, std::size_t n, std::size_t S, float* mins,                \
                                        std::int32_t* best) {                                                         \
        return row_minima_body(table, n, S, mins, best);                                                              \
    }                                                                                                                 \
    attributes void lerp_rows_##suffix(const float* table, std::size_t n, std::size_t W, const std::int32_t* rows,    \
                                       const std::int32_t* c0, const double* fraction, float* ps, float* twice) {     \
        lerp_rows_body(table, n, W, rows, c0, fraction, ps, twice);                                                   \
    }                                                                                                                 \
    attributes void lerp_log_lik_##suffix(const float* table, std::size_t n, std::size_t W, const std::int32_t* rows, \
                                          const std::uint8_t* first, const std::int32_t* c0, const double* fraction,  \
                                          double gain, double s_min, double lowest, float* y, std::size_t group_rows, \
                                          float* row_y) {                                                             \
        lerp_log_lik_body(table, n, W, rows, first, c0, fraction, gain, s_min, lowest, y, group_rows, row_y);         \
    }                                                                                                                 \
    attributes void group_min_##suffix(const float* y, std::size_t rows, std::size_t B, std::size_t group_rows,       \
                                       float* low) {                                                                  \
        group_min_body(y, rows, B, group_rows, low);                                                                  \
    }                                                                                                                 \
    attributes void column_max_##suffix(const float* values, std::size_t rows, std::size_t B, float* high) {          \
        column_max_body(values, rows, B, high);                                                                       \
    }                                                                                                                 \
    attributes void log_lik_##suffix(const float* score, std::size_t rows, std::size_t B, double gain, double s_min,  \
                                     double lowest, float* y, std::size_t group_rows, std::size_t first_row) {        \
        log_lik_body(score, rows, B, gain, s_min, lowest, y, group_rows, first_row);                                  \
    }                                                                                                                 \
    attributes void scale_sums_##suffix(const std::uint32_t* sums, std::size_t n, double divisor, float* scores) {    \
        scale_sums_body(sums, n, divisor, scores);                                                                    \
    }                                                                                                                 \
    attributes float max_value_##suffix(const float* values, std::size_t n) { return max_value_body(values, n); }     \
    attributes void sum_##suffix(const float* values, std::size_t n, double* lanes_out) {                             \
        sum_body<lanes>(values, n, lanes_out);                                                                        \
    }                                                                                                                 \
    attributes void sum_slices_##suffix(const float* in, std::size_t bins, std::size_t n, float* out) {               \
        sum_slices_body(in, bins, n, out);                                                                            \
    }                                                                                                                 \
    const FilterKernels kernels_##suffix{                                                                             \
        box_rows_##suffix,     conv_rows_##suffix, conv_cols_##suffix,   shift_blur_##suffix, transpose_##suffix,     \
        heading_conv_##suffix, measure_##suffix,   interpolate_##suffix, row_minima_##suffix, lerp_rows_##suffix,     \
        lerp_log_lik_##suffix, group_min_##suffix, column_max_##suffix,  log_lik_##suffix,    scale_sums_##suffix,    \
        max_value_##suffix,    sum_##suffix,       sum_slices_##suffix};

#if defined(__GNUC__) && !defined(__clang__)
#define NL_NO_VECTORIZE __attribute__((optimize("no-tree-vectorize")))
#else
#define NL_NO_VECTORIZE
#endif

NL_DEFINE_FILTER_KERNELS(scalar, NL_NO_VECTORIZE, 1)
NL_DEFINE_FILTER_KERNELS(baseline, , 4)
#if NIGHTLOC_X86_KERNELS
NL_DEFINE_FILTER_KERNELS(avx2, __attribute__((target("avx2"))), 8)
NL_DEFINE_FILTER_KERNELS(avx512, __attribute__((target("avx512f"))), 16)
#endif

}  // namespace

float exp2_approx(float y) noexcept { return exp2_scalar(y); }

const FilterKernels& filter_kernels(SimdBackend backend) noexcept {
#if NIGHTLOC_X86_KERNELS
    static const FloatKernelTables<FilterKernels> tables{kernels_scalar, kernels_baseline, &kernels_avx2,
                                                         &kernels_avx512};
#else
    static const FloatKernelTables<FilterKernels> tables{kernels_scalar, kernels_baseline, nullptr, nullptr};
#endif
    return tables.of(backend);
}

}  // namespace nightloc::detail
