// Internal: the kernels of heat-map interpolation, translation and peak search (heatmap.cpp),
// one table per SIMD path. Element-wise IEEE arithmetic in a fixed order: every path gives the
// same values.
#pragma once

#include <cstddef>
#include <cstdint>

#include "nightloc/simd.hpp"

namespace nightloc::detail {

/// A translation resolved to integer cell offsets and weights (see nightloc::add_translated).
template <class T>
struct Translation {
    std::ptrdiff_t ix, iy;  // floor of the shifts
    T a, b;                 // x weights of columns c and c - 1
    T wy0, wy1;             // y weights of rows r and r - 1
};

template <class T>
struct TranslateKernel {
    /// out (rows out_stride apart) += src (rows src_stride apart) translated; `scratch` holds
    /// 3 * (width + 1) elements.
    void (*add)(const T* src, std::size_t src_stride, T* out, std::size_t out_stride, std::size_t height,
                std::size_t width, const Translation<T>& t, T* scratch);
};

struct HeatKernels {
    TranslateKernel<float> f32;
    TranslateKernel<double> f64;
    /// heat[c] = sum_{k < K} data[k * n + c] * values[index[k * n + c]] for c < n, summed in k
    /// order from 0 (ELL layout, K slots per cell, unused slots weigh 0).
    void (*interpolate)(const float* data, const std::int32_t* index, std::size_t slots, std::size_t n,
                        const float* values, float* heat);
    /// Whether all n values are finite.
    bool (*all_finite)(const float* values, std::size_t n);
    /// Maximum and minimum of n >= 1 finite values.
    void (*max_min)(const float* values, std::size_t n, float& max, float& min);
    /// Index of the first value equal to `target` (n if none).
    std::size_t (*find_first)(const float* values, std::size_t n, float target);

    template <class T>
    const TranslateKernel<T>& translate() const;
};

template <>
inline const TranslateKernel<float>& HeatKernels::translate<float>() const {
    return f32;
}
template <>
inline const TranslateKernel<double>& HeatKernels::translate<double>() const {
    return f64;
}

/// The kernels of a path (a supported one: the caller checks).
const HeatKernels& heat_kernels(SimdBackend backend) noexcept;

}  // namespace nightloc::detail
