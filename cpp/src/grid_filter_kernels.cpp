// Loops of the grid filter, the same source compiled for each SIMD path with target attributes
// (the pattern of heatmap_kernels.cpp): scalar (plain loops, no auto-vectorization), the baseline
// (SSE2 on x86-64, NEON on AArch64), AVX2 and AVX-512F. Element-wise loops are left to the
// compiler's vectorizer; the measurement kernel (an exp per cell and a sum) is written with GCC/
// Clang vector types of 16 lanes (lowered to each target's registers). No FMA contraction
// (-ffp-contract=off) and a fixed lane order for sums: every path returns the same values.
#include "grid_filter_kernels.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>

#include "sad_kernels.hpp"  // NIGHTLOC_X86_KERNELS

#define NL_INLINE inline __attribute__((always_inline))

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

typedef float F16 __attribute__((vector_size(64)));
typedef std::int32_t I16 __attribute__((vector_size(64)));
typedef double D16 __attribute__((vector_size(128)));

// (vectors by reference: never passed or returned by value, no ABI questions between targets)
NL_INLINE void exp2_vector(const F16& y, F16& out) {
    const F16 r = (y + kRound) - kRound;
    const F16 f = y - r;
    F16 p = f * kC5 + kC4;
    p = p * f + kC3;
    p = p * f + kC2;
    p = p * f + kC1;
    p = p * f + kC0;
    const I16 bits = (__builtin_convertvector(r, I16) + 127) * (1 << 23);
    F16 scale;
    std::memcpy(&scale, &bits, sizeof(scale));
    out = p * scale;
}

// ---------------------------------------------------------------------------------------------
// bodies shared by every path

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
// of 64 (four independent 16-lane sums hide the adds' latency), then of 16, the last one shifted
// back to end at the row's end (its overlap is recomputed, to the same values); rows shorter than
// 16 element by element. Every element is the same sequence of operations.
NL_INLINE void taps_row_one(const float* const* in, const float* taps, std::size_t n_taps, float* out, std::size_t i) {
    float acc = 0.f;
    for (std::size_t t = 0; t < n_taps; ++t) acc = acc + taps[t] * in[t][i];
    out[i] = acc;
}

template <bool Vector>
NL_INLINE void taps_row(const float* const* in, const float* taps, std::size_t n_taps, float* out, std::size_t cols) {
    if (!Vector || cols < 16) {
        for (std::size_t i = 0; i < cols; ++i) taps_row_one(in, taps, n_taps, out, i);
        return;
    }
    std::size_t i = 0;
    for (; i + 64 <= cols; i += 64) {
        F16 a0 = {}, a1 = {}, a2 = {}, a3 = {};
        for (std::size_t t = 0; t < n_taps; ++t) {
            const float g = taps[t];
            F16 x0, x1, x2, x3;
            std::memcpy(&x0, in[t] + i, sizeof(x0));
            std::memcpy(&x1, in[t] + i + 16, sizeof(x1));
            std::memcpy(&x2, in[t] + i + 32, sizeof(x2));
            std::memcpy(&x3, in[t] + i + 48, sizeof(x3));
            a0 = a0 + g * x0;
            a1 = a1 + g * x1;
            a2 = a2 + g * x2;
            a3 = a3 + g * x3;
        }
        std::memcpy(out + i, &a0, sizeof(a0));
        std::memcpy(out + i + 16, &a1, sizeof(a1));
        std::memcpy(out + i + 32, &a2, sizeof(a2));
        std::memcpy(out + i + 48, &a3, sizeof(a3));
    }
    if (i == cols) return;
    for (;;) {  // 16 at a time from i on
        if (i + 16 > cols) i = cols - 16;
        F16 a = {};
        for (std::size_t t = 0; t < n_taps; ++t) {
            F16 x;
            std::memcpy(&x, in[t] + i, sizeof(x));
            a = a + taps[t] * x;
        }
        std::memcpy(out + i, &a, sizeof(a));
        if (i + 16 >= cols) return;
        i += 16;
    }
}

// dst[j][i] = sum_t taps[t] * src[j + t - offset][i] (rows outside [0, rows) count 0).
template <bool Vector>
NL_INLINE void conv_rows_body(const float* src, float* dst, std::size_t rows, std::size_t cols, const float* taps,
                              std::size_t n_taps, std::ptrdiff_t offset, const float* zeros) {
    const float* in[kMaxTaps];
    for (std::size_t j = 0; j < rows; ++j) {
        for (std::size_t t = 0; t < n_taps; ++t) {
            const std::ptrdiff_t r = static_cast<std::ptrdiff_t>(j + t) - offset;
            in[t] = r >= 0 && r < static_cast<std::ptrdiff_t>(rows) ? src + static_cast<std::size_t>(r) * cols : zeros;
        }
        taps_row<Vector>(in, taps, n_taps, dst + j * cols, cols);
    }
}

// dst[j][i] = sum_t taps[t] * src[j][i + t - offset] (columns outside [0, cols) count 0);
// `padded` holds cols + n_taps floats of scratch.
template <bool Vector>
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
        taps_row<Vector>(in, taps, n_taps, dst + j * cols, cols);
    }
}

NL_INLINE void transpose_body(const float* __restrict src, float* __restrict dst, std::size_t rows, std::size_t cols) {
    constexpr std::size_t kBlock = 16;
    for (std::size_t r0 = 0; r0 < rows; r0 += kBlock) {
        const std::size_t r1 = r0 + kBlock < rows ? r0 + kBlock : rows;
        for (std::size_t c0 = 0; c0 < cols; c0 += kBlock) {
            const std::size_t c1 = c0 + kBlock < cols ? c0 + kBlock : cols;
            for (std::size_t c = c0; c < c1; ++c)
                for (std::size_t r = r0; r < r1; ++r) dst[c * rows + r] = src[r * cols + c];
        }
    }
}

NL_INLINE void heading_one(const float* work, std::size_t bins, std::size_t n, std::size_t b, const float* taps,
                           const std::size_t* offsets, std::size_t n_taps, float a, float f, float* belief,
                           std::size_t c) {
    float acc = 0.f;
    for (std::size_t t = 0; t < n_taps; ++t) acc = acc + taps[t] * work[((b + bins - offsets[t]) % bins) * n + c];
    belief[b * n + c] = acc * a + f;
}

NL_INLINE void heading_conv_plain(const float* work, std::size_t bins, std::size_t n, std::size_t c0, std::size_t m,
                                  const float* taps, const std::size_t* offsets, std::size_t n_taps, float a, float f,
                                  float* belief) {
    for (std::size_t b = 0; b < bins; ++b)
        for (std::size_t c = c0; c < c0 + m; ++c) heading_one(work, bins, n, b, taps, offsets, n_taps, a, f, belief, c);
}

NL_INLINE void heading_conv_vector(const float* work, std::size_t bins, std::size_t n, std::size_t c0, std::size_t m,
                                   const float* taps, const std::size_t* offsets, std::size_t n_taps, float a, float f,
                                   float* belief) {
    const float* in[kMaxTaps];
    for (std::size_t b = 0; b < bins; ++b) {
        for (std::size_t t = 0; t < n_taps; ++t) in[t] = work + ((b + bins - offsets[t]) % bins) * n;
        float* out = belief + b * n;
        std::size_t c = c0;
        for (; c + 16 <= c0 + m; c += 16) {
            F16 acc = {};
            for (std::size_t t = 0; t < n_taps; ++t) {
                F16 x;
                std::memcpy(&x, in[t] + c, sizeof(x));
                acc = acc + taps[t] * x;
            }
            const F16 v = acc * a + f;
            std::memcpy(out + c, &v, sizeof(v));
        }
        for (; c < c0 + m; ++c) heading_one(work, bins, n, b, taps, offsets, n_taps, a, f, belief, c);
    }
}

NL_INLINE void scale_add_body(float* __restrict values, std::size_t n, float a, float f) {
    for (std::size_t c = 0; c < n; ++c) values[c] = values[c] * a + f;
}

NL_INLINE void sum_slices_body(const float* __restrict in, std::size_t bins, std::size_t n, float* __restrict out) {
    for (std::size_t c = 0; c < n; ++c) out[c] = 0.f;
    for (std::size_t b = 0; b < bins; ++b) {
        const float* x = in + b * n;
        for (std::size_t c = 0; c < n; ++c) out[c] = out[c] + x[c];
    }
}

// The prior of cell c in bin b: the pending heading blur of the source, scaled, plus the floor.
NL_INLINE float prior_one(const UpdateArgs& u, std::size_t b, std::size_t c) {
    float acc = 0.f;
    for (std::size_t t = 0; t < u.n_taps; ++t) {
        acc = acc + u.taps[t] * u.source[((b + u.bins - u.offsets[t]) % u.bins) * u.n + c];
    }
    return acc * u.a + u.f;
}

// The measurement of cell c in bin b (the scalar path and every path's tail).
NL_INLINE void measure_one(const UpdateArgs& u, std::size_t b, std::size_t c) {
    const float* values = u.log_lik + b * u.stride;
    float y = 0.f;
    for (std::size_t k = 0; k < u.slots; ++k) y = y + u.data[k * u.n + c] * values[u.index[k * u.n + c]];
    y = y > kLowest ? y : kLowest;
    const float p = prior_one(u, b, c) * exp2_scalar(y);
    u.belief[b * u.n + c] = p;
    u.marginal[c] = (b == 0 ? 0.f : u.marginal[c]) + p;
}

NL_INLINE void measure_plain(const UpdateArgs& u, std::size_t c0, std::size_t m) {
    for (std::size_t b = 0; b < u.bins; ++b)
        for (std::size_t c = c0; c < c0 + m; ++c) measure_one(u, b, c);
}

// V groups of 16 cells from c on, bin b (V independent dependency chains: the exp's polynomial
// and the sums are latency-bound one group at a time).
template <int V>
NL_INLINE void measure_groups(const UpdateArgs& u, std::size_t b, std::size_t c, const float* values,
                              const float* const* in, float* belief) {
    const F16 zero = {}, lowest = zero + kLowest;
    F16 y[V], acc[V];
    for (int v = 0; v < V; ++v) {
        y[v] = zero;
        acc[v] = zero;
    }
    for (std::size_t k = 0; k < u.slots; ++k) {
        for (int v = 0; v < V; ++v) {
            const std::size_t cv = c + 16 * static_cast<std::size_t>(v);
            const std::int32_t* places = u.places4 + 4 * ((cv / 16) * u.slots + k);
            F16 d, x;
            I16 idx;
            std::memcpy(&d, u.data + k * u.n + cv, sizeof(d));
            std::memcpy(&idx, u.index + k * u.n + cv, sizeof(idx));
            if (places[0] >= 0) {  // at most four places among the 16 cells (a triangle's corner): selects
                x = zero + values[places[0]];
                x = idx == places[1] ? zero + values[places[1]] : x;
                x = idx == places[2] ? zero + values[places[2]] : x;
                x = idx == places[3] ? zero + values[places[3]] : x;
            } else {
                for (int l = 0; l < 16; ++l) x[l] = values[idx[l]];
            }
            y[v] = y[v] + d * x;
        }
    }
    for (std::size_t t = 0; t < u.n_taps; ++t) {
        for (int v = 0; v < V; ++v) {
            F16 x;
            std::memcpy(&x, in[t] + c + 16 * static_cast<std::size_t>(v), sizeof(x));
            acc[v] = acc[v] + u.taps[t] * x;
        }
    }
    for (int v = 0; v < V; ++v) {
        const std::size_t cv = c + 16 * static_cast<std::size_t>(v);
        F16 yy = y[v] > lowest ? y[v] : lowest;
        F16 l, mg;
        exp2_vector(yy, l);
        const F16 p = (acc[v] * u.a + u.f) * l;
        std::memcpy(belief + cv, &p, sizeof(p));
        if (b == 0) {
            mg = zero + p;
        } else {
            std::memcpy(&mg, u.marginal + cv, sizeof(mg));
            mg = mg + p;
        }
        std::memcpy(u.marginal + cv, &mg, sizeof(mg));
    }
}

NL_INLINE void measure_vector(const UpdateArgs& u, std::size_t c0, std::size_t m) {
    const float* in[kMaxTaps];
    for (std::size_t b = 0; b < u.bins; ++b) {
        const float* values = u.log_lik + b * u.stride;
        for (std::size_t t = 0; t < u.n_taps; ++t) in[t] = u.source + ((b + u.bins - u.offsets[t]) % u.bins) * u.n;
        float* belief = u.belief + b * u.n;
        // the next chunk of this bin's slices: 48 and more streams 40 KB apart defeat the prefetcher
        for (std::size_t c = c0 + m; c < c0 + 2 * m && c < u.n; c += 16) {
            __builtin_prefetch(u.source + b * u.n + c);
            __builtin_prefetch(belief + c, 1);
        }
        std::size_t c = c0;
        for (; c + 64 <= c0 + m; c += 64) measure_groups<4>(u, b, c, values, in, belief);
        for (; c + 16 <= c0 + m; c += 16) measure_groups<1>(u, b, c, values, in, belief);
        for (; c < c0 + m; ++c) measure_one(u, b, c);
    }
}

NL_INLINE void sum_plain(const float* values, std::size_t n, double* lanes) {
    for (std::size_t c = 0; c < n; ++c) lanes[c % kSumLanes] += static_cast<double>(values[c]);
}

NL_INLINE void sum_vector(const float* values, std::size_t n, double* lanes) {
    D16 sum;
    std::memcpy(&sum, lanes, sizeof(sum));
    std::size_t c = 0;
    for (; c + 16 <= n; c += 16) {
        F16 v;
        std::memcpy(&v, values + c, sizeof(v));
        sum += __builtin_convertvector(v, D16);
    }
    std::memcpy(lanes, &sum, sizeof(sum));
    for (; c < n; ++c) lanes[c % kSumLanes] += static_cast<double>(values[c]);
}

#define NL_DEFINE_FILTER_KERNELS(suffix, attributes, variant, vector_on)                                              \
    attributes void box_rows_##suffix(const float* src, float* dst, std::size_t rows, std::size_t cols,               \
                                      const BoxPass& pass, float* acc, const float* zeros) {                          \
        box_rows_body(src, dst, rows, cols, pass, acc, zeros);                                                        \
    }                                                                                                                 \
    attributes void conv_rows_##suffix(const float* src, float* dst, std::size_t rows, std::size_t cols,              \
                                       const float* taps, std::size_t n_taps, std::ptrdiff_t offset,                  \
                                       const float* zeros) {                                                          \
        conv_rows_body<vector_on>(src, dst, rows, cols, taps, n_taps, offset, zeros);                                 \
    }                                                                                                                 \
    attributes void conv_cols_##suffix(const float* src, float* dst, std::size_t rows, std::size_t cols,              \
                                       const float* taps, std::size_t n_taps, std::ptrdiff_t offset, float* padded) { \
        conv_cols_body<vector_on>(src, dst, rows, cols, taps, n_taps, offset, padded);                                \
    }                                                                                                                 \
    attributes void transpose_##suffix(const float* src, float* dst, std::size_t rows, std::size_t cols) {            \
        transpose_body(src, dst, rows, cols);                                                                         \
    }                                                                                                                 \
    attributes void heading_conv_##suffix(const float* work, std::size_t bins, std::size_t n, std::size_t c0,         \
                                          std::size_t m, const float* taps, const std::size_t* offsets,               \
                                          std::size_t n_taps, float a, float f, float* belief) {                      \
        heading_conv_##variant(work, bins, n, c0, m, taps, offsets, n_taps, a, f, belief);                            \
    }                                                                                                                 \
    attributes void measure_##suffix(const UpdateArgs& u, std::size_t c0, std::size_t m) {                            \
        measure_##variant(u, c0, m);                                                                                  \
    }                                                                                                                 \
    attributes void scale_add_##suffix(float* values, std::size_t n, float a, float f) {                              \
        scale_add_body(values, n, a, f);                                                                              \
    }                                                                                                                 \
    attributes void sum_##suffix(const float* values, std::size_t n, double* lanes) {                                 \
        sum_##variant(values, n, lanes);                                                                              \
    }                                                                                                                 \
    attributes void sum_slices_##suffix(const float* in, std::size_t bins, std::size_t n, float* out) {               \
        sum_slices_body(in, bins, n, out);                                                                            \
    }                                                                                                                 \
    const FilterKernels kernels_##suffix{box_rows_##suffix,  conv_rows_##suffix,    conv_cols_##suffix,               \
                                         transpose_##suffix, heading_conv_##suffix, measure_##suffix,                 \
                                         scale_add_##suffix, sum_##suffix,          sum_slices_##suffix};

#if defined(__GNUC__) && !defined(__clang__)
#define NL_NO_VECTORIZE __attribute__((optimize("no-tree-vectorize")))
#else
#define NL_NO_VECTORIZE
#endif

NL_DEFINE_FILTER_KERNELS(scalar, NL_NO_VECTORIZE, plain, false)
NL_DEFINE_FILTER_KERNELS(baseline, , vector, true)
#if NIGHTLOC_X86_KERNELS
NL_DEFINE_FILTER_KERNELS(avx2, __attribute__((target("avx2"))), vector, true)
NL_DEFINE_FILTER_KERNELS(avx512, __attribute__((target("avx512f"))), vector, true)
#endif

}  // namespace

float exp2_approx(float y) noexcept { return exp2_scalar(y); }

const FilterKernels& filter_kernels(SimdBackend backend) noexcept {
    switch (backend) {
        case SimdBackend::scalar:
            return kernels_scalar;
#if NIGHTLOC_X86_KERNELS
        case SimdBackend::sse2:
            return kernels_baseline;
        case SimdBackend::avx2:
            return kernels_avx2;
        case SimdBackend::avx512bw:
            return kernels_avx512;
        default:
            return kernels_scalar;  // another architecture's path: never active here
#else
        // AArch64: the baseline kernels are NEON (the vector types lower to 4-lane registers)
        default:
            return kernels_baseline;
#endif
    }
}

}  // namespace nightloc::detail
