// Internal: the row kernels of heat-map translation and peak search (heatmap.cpp), one table per
// SIMD path. Element-wise IEEE arithmetic in a fixed order: every path gives the same values.
#pragma once

#include <cstddef>

#include "nightloc/simd.hpp"

namespace nightloc::detail {

template <class T>
struct TranslateKernels {
    /// row[c] = a * src[c] + b * src[c - 1] for c in [0, n], src[-1] = src[n] = 0.
    void (*across)(const T* src, std::size_t n, T a, T b, T* row);
    /// out[i] = (out[i] + wy0 * current[i]) + wy1 * previous[i] for i < n.
    void (*combine)(T* out, const T* current, const T* previous, std::size_t n, T wy0, T wy1);
};

struct HeatKernels {
    TranslateKernels<float> f32;
    TranslateKernels<double> f64;
    /// Whether all n values are finite.
    bool (*all_finite)(const float* values, std::size_t n);
    /// Maximum and minimum of n >= 1 finite values.
    void (*max_min)(const float* values, std::size_t n, float& max, float& min);

    template <class T>
    void across(const T* src, std::size_t n, T a, T b, T* row) const;
    template <class T>
    void combine(T* out, const T* current, const T* previous, std::size_t n, T wy0, T wy1) const;
};

template <>
inline void HeatKernels::across<float>(const float* src, std::size_t n, float a, float b, float* row) const {
    f32.across(src, n, a, b, row);
}
template <>
inline void HeatKernels::across<double>(const double* src, std::size_t n, double a, double b, double* row) const {
    f64.across(src, n, a, b, row);
}
template <>
inline void HeatKernels::combine<float>(float* out, const float* current, const float* previous, std::size_t n,
                                        float wy0, float wy1) const {
    f32.combine(out, current, previous, n, wy0, wy1);
}
template <>
inline void HeatKernels::combine<double>(double* out, const double* current, const double* previous, std::size_t n,
                                         double wy0, double wy1) const {
    f64.combine(out, current, previous, n, wy0, wy1);
}

/// The kernels of a path (a supported one: the caller checks).
const HeatKernels& heat_kernels(SimdBackend backend) noexcept;

}  // namespace nightloc::detail
