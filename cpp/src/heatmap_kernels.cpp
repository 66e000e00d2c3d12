// Row kernels of heat-map translation and peak search, the same loops compiled for each SIMD
// path with target attributes (see prepare_kernels.cpp for the pattern): scalar (no
// auto-vectorization), the baseline (sse2), AVX2 and AVX-512F. No FMA contraction
// (-ffp-contract=off): each path rounds exactly like the scalar one.
#include "heatmap_kernels.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>

#include "sad_kernels.hpp"  // NIGHTLOC_X86_KERNELS

#define NL_INLINE inline __attribute__((always_inline))

namespace nightloc::detail {
namespace {

template <class T>
NL_INLINE void across_body(const T* src, std::size_t n, T a, T b, T* row) {
    row[0] = a * src[0] + b * T(0);
    for (std::size_t c = 1; c < n; ++c) row[c] = a * src[c] + b * src[c - 1];
    row[n] = a * T(0) + b * src[n - 1];
}

template <class T>
NL_INLINE void combine_body(T* out, const T* current, const T* previous, std::size_t n, T wy0, T wy1) {
    for (std::size_t i = 0; i < n; ++i) out[i] = (out[i] + wy0 * current[i]) + wy1 * previous[i];
}

// Lane-parallel loops (16 independent accumulators): without -ffast-math a compiler may not
// reorder one running reduction, but it vectorizes these.
constexpr std::size_t kLanes = 16;

NL_INLINE bool all_finite_body(const float* values, std::size_t n) {
    std::uint32_t bad[kLanes] = {};  // exponent all ones: infinity or NaN
    std::size_t i = 0;
    for (; i + kLanes <= n; i += kLanes) {
        for (std::size_t l = 0; l < kLanes; ++l) {
            std::uint32_t bits;
            std::memcpy(&bits, values + i + l, 4);
            bad[l] |= static_cast<std::uint32_t>((bits & 0x7f800000u) == 0x7f800000u);
        }
    }
    std::uint32_t any = 0;
    for (; i < n; ++i) any |= static_cast<std::uint32_t>(!std::isfinite(values[i]));
    for (std::size_t l = 0; l < kLanes; ++l) any |= bad[l];
    return any == 0;
}

NL_INLINE void max_min_body(const float* values, std::size_t n, float& max, float& min) {
    float hi[kLanes], lo[kLanes];
    for (std::size_t l = 0; l < kLanes; ++l) hi[l] = lo[l] = values[0];
    std::size_t i = 0;
    for (; i + kLanes <= n; i += kLanes) {
        for (std::size_t l = 0; l < kLanes; ++l) {
            const float v = values[i + l];
            hi[l] = v > hi[l] ? v : hi[l];
            lo[l] = v < lo[l] ? v : lo[l];
        }
    }
    float h = hi[0], o = lo[0];
    for (std::size_t l = 1; l < kLanes; ++l) {
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

#define NL_DEFINE_HEAT_KERNELS(suffix, attributes)                                                                 \
    attributes void across_f32_##suffix(const float* src, std::size_t n, float a, float b, float* row) {           \
        across_body(src, n, a, b, row);                                                                             \
    }                                                                                                               \
    attributes void across_f64_##suffix(const double* src, std::size_t n, double a, double b, double* row) {       \
        across_body(src, n, a, b, row);                                                                             \
    }                                                                                                               \
    attributes void combine_f32_##suffix(float* out, const float* current, const float* previous, std::size_t n,   \
                                         float wy0, float wy1) {                                                    \
        combine_body(out, current, previous, n, wy0, wy1);                                                          \
    }                                                                                                               \
    attributes void combine_f64_##suffix(double* out, const double* current, const double* previous,               \
                                         std::size_t n, double wy0, double wy1) {                                   \
        combine_body(out, current, previous, n, wy0, wy1);                                                          \
    }                                                                                                               \
    attributes bool all_finite_##suffix(const float* values, std::size_t n) { return all_finite_body(values, n); } \
    attributes void max_min_##suffix(const float* values, std::size_t n, float& max, float& min) {                 \
        max_min_body(values, n, max, min);                                                                          \
    }                                                                                                               \
    const HeatKernels kernels_##suffix{{across_f32_##suffix, combine_f32_##suffix},                                \
                                       {across_f64_##suffix, combine_f64_##suffix},                                \
                                       all_finite_##suffix, max_min_##suffix};

#if defined(__GNUC__) && !defined(__clang__)
#define NL_NO_VECTORIZE __attribute__((optimize("no-tree-vectorize")))
#else
#define NL_NO_VECTORIZE
#endif

NL_DEFINE_HEAT_KERNELS(scalar, NL_NO_VECTORIZE)
NL_DEFINE_HEAT_KERNELS(baseline, )
#if NIGHTLOC_X86_KERNELS
NL_DEFINE_HEAT_KERNELS(avx2, __attribute__((target("avx2"))))
NL_DEFINE_HEAT_KERNELS(avx512, __attribute__((target("avx512f"))))
#endif

}  // namespace

const HeatKernels& heat_kernels(SimdBackend backend) noexcept {
    switch (backend) {
        case SimdBackend::scalar: return kernels_scalar;
#if NIGHTLOC_X86_KERNELS
        case SimdBackend::sse2: return kernels_baseline;
        case SimdBackend::avx2: return kernels_avx2;
        case SimdBackend::avx512bw: return kernels_avx512;
#else
        default: return kernels_baseline;
#endif
    }
    return kernels_scalar;
}

}  // namespace nightloc::detail
