// Internal: the signatures of the SAD kernels, the contract between the kernels of each SIMD path
// (matching/sad_kernels.hpp) and the path registry's entries (common/simd_paths.hpp). It lives
// below both, so that the registry's interface names kernels without including a stage.
#pragma once

#include <cstddef>
#include <cstdint>

namespace nightloc::detail {

/// "Copies" kernels. `copies` holds n_copies rolled (or offset) versions of one query, copy j at
/// copies + j * stride (stride a multiple of 64, base 64-byte aligned), each `pixels` bytes
/// followed by zero padding up to stride. For every reference i (refs + i * ref_stride, the
/// first `pixels` bytes compared; ref_stride >= pixels):
///     out[i * out_stride + j] = sum_{p < pixels} |copy_j[p] - ref_i[p]|.
using CopiesKernel = void (*)(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies,
                              const std::uint8_t* refs, std::size_t ref_stride, std::size_t n_refs, std::size_t pixels,
                              std::uint32_t* out, std::size_t out_stride);

/// Widest panorama the all-shift kernels take (their per-reference state lives on the stack).
inline constexpr std::size_t kAllShiftMaxWidth = 384;

/// "All-shift" kernels, for width % 8 == 0, width <= kAllShiftMaxWidth. `interleaved` holds the
/// query rolled by the even shifts 0, 2, ..., width-2 (width/2 copies), chunk-major: bytes
/// [(c * width/2 + m) * 64, +64) are chunk c of the copy rolled by 2m, zero beyond `pixels`. Sums
/// for shift k of reference i are
///  - table mode (out != nullptr): written to out[i * out_stride + k] for all k in [0, width);
///  - min mode (out == nullptr): minimised over the shifts whose bit is set in `selected`
///    (width/8 16-bit masks: bit 4l + d of mask g selects shift 8g + 2l + d, d < 2), lowest
///    shift winning ties; written to best_sums[i] and best_shifts[i].
using AllShiftKernel = void (*)(const std::uint8_t* interleaved, std::size_t width, const std::uint8_t* refs,
                                std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                                std::size_t out_stride, const std::uint16_t* selected, std::uint32_t* best_sums,
                                std::int32_t* best_shifts);

/// Most copies an offsets kernel takes (its partial sums live on the stack).
inline constexpr std::size_t kMaxOffsetCopies = 256;

/// "Offsets" kernels, for non-wrapping column offsets, width % 8 == 0. `layout` holds n_copies
/// (<= kMaxOffsetCopies) zero-filled copies of one query band, copy m offset by e0 + 2m columns
/// (dst(r, c) = Q(r, c + e0 + 2m), 0 outside the image), chunk-major: chunk c of copy m at
/// (c * n_copies + m) * 64, zero beyond `pixels`. For every reference i (refs + i * ref_stride)
/// and slot j < n_slots, the offset e0 + first + j (first + n_slots <= 2 * n_copies - 2):
///     out[i * out_stride + j] = sum_{p < pixels} |copy_offset[p] - ref_i[p]|.
using OffsetsKernel = void (*)(const std::uint8_t* layout, std::size_t n_copies, std::size_t first, std::size_t n_slots,
                               const std::uint8_t* refs, std::size_t ref_stride, std::size_t n_refs, std::size_t pixels,
                               std::uint32_t* out, std::size_t out_stride);

}  // namespace nightloc::detail
