// Image normalization: the paper's per-pixel patch normalization (eq. 1) and OpenSeqSLAM's
// block normalization. Pointer-level API over C-contiguous stacks of uint8 images,
// `count` images of `height` x `width` pixels each.
#pragma once

#include <cstddef>
#include <cstdint>

namespace nightloc {

/// Default quantization gain of patch_normalize: output = clip(floor(128 + scale * z + 0.5), 0, 255).
/// With 24 levels per standard deviation, |z| up to 5.3 is represented without clipping.
/// 24 was chosen by measuring how well SAD on the quantized images ranks like SAD on the float
/// z-images (see README, "Patch normalization").
inline constexpr double kDefaultPatchScale = 24.0;

/// Largest patch-normalization radius accepted (a 2049 x 2049 window). It bounds the exact
/// 64-bit window sums (n * sum of squares < 2^63 for any image size) and the per-row work of the
/// wrap-around window; the paper uses 4.
inline constexpr int kMaxPatchRadius = 1024;

/// Patch normalization, Mount & Milford eq. (1): every pixel becomes z = (I - mu) / sigma with
/// mu, sigma the mean and population standard deviation of the (2*radius+1)^2 window around it.
///  - wrap = true: the window wraps around horizontally (360-degree panoramas), so normalization
///    commutes with circular column shifts; rows are clipped at the top and bottom.
///  - wrap = false: the window is clipped at all borders (forward cameras).
/// Quantization: dst = clip(floor(128 + scale * z + 0.5), 0, 255). A flat window (sigma = 0)
/// gives z = 0, i.e. 128, never NaN. Computation is exact integer window sums, then double.
/// Throws std::invalid_argument for zero sizes, radius outside [0, kMaxPatchRadius] or a
/// non-finite/non-positive scale.
void patch_normalize(const std::uint8_t* src, std::uint8_t* dst, std::size_t count, std::size_t height,
                     std::size_t width, int radius, bool wrap, double scale = kDefaultPatchScale);

/// OpenSeqSLAM's patch normalization (mode 1), bit-exact with the Matlab code: each full,
/// non-overlapping side x side block becomes 127 + round(z) (z with the N-1 standard deviation,
/// round half away from zero, saturated to 0..255); a flat block becomes 0 (Matlab's uint8(NaN));
/// pixels in the incomplete blocks at the right and bottom borders are copied unchanged.
/// Throws std::invalid_argument for zero sizes or side < 2.
void block_normalize(const std::uint8_t* src, std::uint8_t* dst, std::size_t count, std::size_t height,
                     std::size_t width, int side);

}  // namespace nightloc
