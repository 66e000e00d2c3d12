// Internal: the SAD kernels of each SIMD path and the query layouts they read.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/arch.hpp"
#include "common/kernel_signatures.hpp"

namespace nightloc::detail {

/// Byte alignment and padding granule of the query copies (one zmm register).
inline constexpr std::size_t kChunk = 64;

inline std::size_t round_up(std::size_t value, std::size_t granule) {
    return (value + granule - 1) / granule * granule;
}

void sad_copies_scalar(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies, const std::uint8_t* refs,
                       std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                       std::size_t out_stride);

#if NIGHTLOC_ARM_KERNELS
/// NEON: vabdq_u8 + vpadalq_u8 into 16-bit lanes (flushed to 32 bits before they can overflow).
void sad_copies_neon(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies, const std::uint8_t* refs,
                     std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                     std::size_t out_stride);
/// NEON with the dot-product extension (ARMv8.2 udot): vabdq_u8 + vdotq_u32 against ones.
void sad_copies_neon_dotprod(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies,
                             const std::uint8_t* refs, std::size_t ref_stride, std::size_t n_refs, std::size_t pixels,
                             std::uint32_t* out, std::size_t out_stride);
#endif

#if NIGHTLOC_X86_KERNELS
void sad_copies_sse2(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies, const std::uint8_t* refs,
                     std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                     std::size_t out_stride);
void sad_copies_avx2(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies, const std::uint8_t* refs,
                     std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                     std::size_t out_stride);
void sad_copies_avx512bw(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies, const std::uint8_t* refs,
                         std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                         std::size_t out_stride);

/// AVX-512BW all-shift kernel (vdbpsadbw, 16-bit sums accumulated with vpaddw).
void sad_all_shifts_avx512bw(const std::uint8_t* interleaved, std::size_t width, const std::uint8_t* refs,
                             std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                             std::size_t out_stride, const std::uint16_t* selected, std::uint32_t* best_sums,
                             std::int32_t* best_shifts);

/// The same, accumulating with AVX-512 VNNI's vpdpwssd (needs a CPU with avx512vnni); same results.
void sad_all_shifts_avx512vnni(const std::uint8_t* interleaved, std::size_t width, const std::uint8_t* refs,
                               std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                               std::size_t out_stride, const std::uint16_t* selected, std::uint32_t* best_sums,
                               std::int32_t* best_shifts);

/// AVX-512BW offsets kernels (vdbpsadbw; vpaddw or VNNI vpdpwssd accumulation, same results). Each
/// vdbpsadbw on copy m gives offsets e0 + 2m, +1 on the low half of an 8-pixel group and
/// e0 + 2m - 2, -1 on the high half, as in the all-shift kernel, without wrapping.
void sad_offsets_avx512bw(const std::uint8_t* layout, std::size_t n_copies, std::size_t first, std::size_t n_slots,
                          const std::uint8_t* refs, std::size_t ref_stride, std::size_t n_refs, std::size_t pixels,
                          std::uint32_t* out, std::size_t out_stride);
void sad_offsets_avx512vnni(const std::uint8_t* layout, std::size_t n_copies, std::size_t first, std::size_t n_slots,
                            const std::uint8_t* refs, std::size_t ref_stride, std::size_t n_refs, std::size_t pixels,
                            std::uint32_t* out, std::size_t out_stride);
/// The all-shift and offsets kernels of the AVX-512 variant in use (nightloc::avx512_sad_variant(),
/// avx512_variant.cpp).
AllShiftKernel avx512_all_shift_kernel();
OffsetsKernel avx512_offsets_kernel();
#endif

}  // namespace nightloc::detail
