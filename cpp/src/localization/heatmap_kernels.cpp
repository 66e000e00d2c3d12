// Row kernels of heat-map translation and peak search, the same loops compiled for each SIMD
// path with target attributes (see prepare_kernels.cpp for the pattern): scalar (no
// auto-vectorization), the baseline (sse2 on x86-64, NEON on AArch64), AVX2 and AVX-512F. No FMA contraction
// (-ffp-contract=off): each path rounds exactly like the scalar one.
#include "localization/heatmap_kernels.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>

#include "common/arch.hpp"
#include "common/float_kernel_table.hpp"

#define NL_INLINE inline __attribute__((always_inline))

namespace nightloc::detail {
namespace {

// R(r, c) = a * src[r, c] + b * src[r, c - 1] for c in [0, n] (zero beyond the row).
template <class T>
NL_INLINE void across_body(const T* src, std::size_t n, T a, T b, T* row) {
    row[0] = a * src[0] + b * T(0);
    for (std::size_t c = 1; c < n; ++c) row[c] = a * src[c] + b * src[c - 1];
    row[n] = a * T(0) + b * src[n - 1];
}

// One output row from the R rows of weights wy0 (current) and wy1 (previous).
template <class T>
NL_INLINE void combine_body(T* out, const T* current, const T* previous, std::size_t n, T wy0, T wy1) {
    for (std::size_t i = 0; i < n; ++i) out[i] = (out[i] + wy0 * current[i]) + wy1 * previous[i];
}

// The whole translation: each source row interpolated along x once (kept for the next output
// row, which needs it with the other y weight), then the output rows in order.
template <class T>
NL_INLINE void translate_body(const T* src, std::size_t src_stride, T* out, std::size_t out_stride, std::size_t height,
                              std::size_t width, const Translation<T>& t, T* scratch) {
    const auto W = static_cast<std::ptrdiff_t>(width), H = static_cast<std::ptrdiff_t>(height);
    // output columns i whose source column c = i - ix lies in [0, width]
    const std::ptrdiff_t i_lo = t.ix > 0 ? t.ix : 0, i_hi = W + t.ix + 1 < W ? W + t.ix + 1 : W;
    // output rows j with a source row j - iy or j - iy - 1 in [0, height)
    const std::ptrdiff_t j_lo = t.iy > 0 ? t.iy : 0, j_hi = H + t.iy + 1 < H ? H + t.iy + 1 : H;
    if (i_lo >= i_hi || j_lo >= j_hi) return;
    const auto c0 = static_cast<std::size_t>(i_lo - t.ix), n = static_cast<std::size_t>(i_hi - i_lo);
    T* current = scratch;
    T* previous = scratch + width + 1;
    T* zeros = scratch + 2 * (width + 1);
    for (std::size_t c = 0; c <= width; ++c) zeros[c] = T(0);
    auto across = [&](std::ptrdiff_t r, T* row) {  // R(r, .) into row; false beyond the grid
        if (r < 0 || r >= H) return false;
        across_body(src + static_cast<std::size_t>(r) * src_stride, width, t.a, t.b, row);
        return true;
    };
    bool previous_valid = across(j_lo - t.iy - 1, previous);
    for (std::ptrdiff_t j = j_lo; j < j_hi; ++j) {
        const bool current_valid = across(j - t.iy, current);
        combine_body(out + static_cast<std::size_t>(j) * out_stride + static_cast<std::size_t>(i_lo),
                     (current_valid ? current : zeros) + c0, (previous_valid ? previous : zeros) + c0, n, t.wy0, t.wy1);
        T* swap = current;
        current = previous;
        previous = swap;
        previous_valid = current_valid;
    }
}

NL_INLINE void interpolate_body(const float* __restrict data, const std::int32_t* __restrict index, std::size_t slots,
                                std::size_t n, const float* __restrict values, float* __restrict heat) {
    for (std::size_t c = 0; c < n; ++c) heat[c] = 0.f;
    for (std::size_t k = 0; k < slots; ++k) {
        const float* d = data + k * n;
        const std::int32_t* idx = index + k * n;
        for (std::size_t c = 0; c < n; ++c) heat[c] += d[c] * values[idx[c]];
    }
}

// Plain loops (the scalar path) and the same with GCC/Clang vector extensions (16 lanes, lowered
// to the instruction set of each target; without -ffast-math a compiler does not reorder one
// running float reduction by itself). Maxima, minima and comparisons are exact: every path
// returns the same values.
NL_INLINE bool all_finite_plain(const float* values, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
        if (!std::isfinite(values[i])) return false;
    }
    return true;
}

NL_INLINE void max_min_plain(const float* values, std::size_t n, float& max, float& min) {
    float h = values[0], o = values[0];
    for (std::size_t i = 1; i < n; ++i) {
        h = values[i] > h ? values[i] : h;
        o = values[i] < o ? values[i] : o;
    }
    max = h;
    min = o;
}

NL_INLINE std::size_t find_first_plain(const float* values, std::size_t n, float target) {
    for (std::size_t i = 0; i < n; ++i) {
        if (values[i] == target) return i;
    }
    return n;
}

// Lanes = floats per register of the target (4 SSE2, 8 AVX2, 16 AVX-512): wider vector types
// than the target has are split element by element. Vectors are copied in with memcpy, never
// passed or returned (no ABI questions between targets).
template <std::size_t Lanes>
struct LaneTypes {
    typedef float Floats __attribute__((vector_size(4 * Lanes)));
    typedef std::int32_t Ints __attribute__((vector_size(4 * Lanes)));
};

template <std::size_t Lanes>
NL_INLINE bool all_finite_lanes(const float* values, std::size_t n) {
    typename LaneTypes<Lanes>::Ints bad = {};
    std::size_t i = 0;
    for (; i + Lanes <= n; i += Lanes) {
        typename LaneTypes<Lanes>::Ints bits;
        std::memcpy(&bits, values + i, sizeof(bits));
        bad |= (bits & 0x7f800000) == 0x7f800000;  // exponent all ones: infinity or NaN
    }
    for (std::size_t l = 0; l < Lanes; ++l) {
        if (bad[l]) return false;
    }
    return all_finite_plain(values + i, n - i);
}

template <std::size_t Lanes>
NL_INLINE void max_min_lanes(const float* values, std::size_t n, float& max, float& min) {
    if (n < Lanes) return max_min_plain(values, n, max, min);
    typename LaneTypes<Lanes>::Floats hi, lo;
    std::memcpy(&hi, values, sizeof(hi));
    lo = hi;
    std::size_t i = Lanes;
    for (; i + Lanes <= n; i += Lanes) {
        typename LaneTypes<Lanes>::Floats v;
        std::memcpy(&v, values + i, sizeof(v));
        hi = v > hi ? v : hi;
        lo = v < lo ? v : lo;
    }
    float h = hi[0], o = lo[0];
    for (std::size_t l = 1; l < Lanes; ++l) {
        h = hi[l] > h ? hi[l] : h;
        o = lo[l] < o ? lo[l] : o;
    }
    for (; i < n; ++i) {
        h = values[i] > h ? values[i] : h;
        o = values[i] < o ? values[i] : o;
    }
    max = h;
    min = o;
}

template <std::size_t Lanes>
NL_INLINE std::size_t find_first_lanes(const float* values, std::size_t n, float target) {
    std::size_t i = 0;
    for (; i + Lanes <= n; i += Lanes) {
        typename LaneTypes<Lanes>::Floats v;
        std::memcpy(&v, values + i, sizeof(v));
        const typename LaneTypes<Lanes>::Ints hit = v == target;
        bool any = false;
        for (std::size_t l = 0; l < Lanes; ++l) any |= hit[l] != 0;
        if (any) break;
    }
    return i + find_first_plain(values + i, n - i, target);
}

#define NL_DEFINE_HEAT_KERNELS(suffix, attributes, variant)                                                      \
    attributes void translate_f32_##suffix(const float* src, std::size_t src_stride, float* out,                 \
                                           std::size_t out_stride, std::size_t height, std::size_t width,        \
                                           const Translation<float>& t, float* scratch) {                        \
        translate_body(src, src_stride, out, out_stride, height, width, t, scratch);                             \
    }                                                                                                            \
    attributes void translate_f64_##suffix(const double* src, std::size_t src_stride, double* out,               \
                                           std::size_t out_stride, std::size_t height, std::size_t width,        \
                                           const Translation<double>& t, double* scratch) {                      \
        translate_body(src, src_stride, out, out_stride, height, width, t, scratch);                             \
    }                                                                                                            \
    attributes void interpolate_##suffix(const float* data, const std::int32_t* index, std::size_t slots,        \
                                         std::size_t n, const float* values, float* heat) {                      \
        interpolate_body(data, index, slots, n, values, heat);                                                   \
    }                                                                                                            \
    attributes bool all_finite_##suffix(const float* values, std::size_t n) {                                    \
        return all_finite_##variant(values, n);                                                                  \
    }                                                                                                            \
    attributes void max_min_##suffix(const float* values, std::size_t n, float& max, float& min) {               \
        max_min_##variant(values, n, max, min);                                                                  \
    }                                                                                                            \
    attributes std::size_t find_first_##suffix(const float* values, std::size_t n, float target) {               \
        return find_first_##variant(values, n, target);                                                          \
    }                                                                                                            \
    const HeatKernels kernels_##suffix{{translate_f32_##suffix}, {translate_f64_##suffix}, interpolate_##suffix, \
                                       all_finite_##suffix,      max_min_##suffix,         find_first_##suffix};

#if defined(__GNUC__) && !defined(__clang__)
#define NL_NO_VECTORIZE __attribute__((optimize("no-tree-vectorize")))
#else
#define NL_NO_VECTORIZE
#endif

NL_DEFINE_HEAT_KERNELS(scalar, NL_NO_VECTORIZE, plain)
NL_DEFINE_HEAT_KERNELS(baseline, , lanes<4>)
#if NIGHTLOC_X86_KERNELS
NL_DEFINE_HEAT_KERNELS(avx2, __attribute__((target("avx2"))), lanes<8>)
NL_DEFINE_HEAT_KERNELS(avx512, __attribute__((target("avx512f"))), lanes<16>)
#endif

}  // namespace

const HeatKernels& heat_kernels(SimdBackend backend) noexcept {
#if NIGHTLOC_X86_KERNELS
    static const FloatKernelTables<HeatKernels> tables{kernels_scalar, kernels_baseline, &kernels_avx2,
                                                       &kernels_avx512};
#else
    static const FloatKernelTables<HeatKernels> tables{kernels_scalar, kernels_baseline, nullptr, nullptr};
#endif
    return tables.of(backend);
}

}  // namespace nightloc::detail
