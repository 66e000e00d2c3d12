// The neon-dotprod SAD kernel: the NEON copies kernel (sad_neon_body.hpp) accumulating with the
// dot-product extension's udot (ARMv8.2 and later cores: Cortex-A55/A76, Neoverse). This file
// compiles its functions for armv8.2-a+dotprod with a target pragma (GCC's arm_neon.h requires
// that architecture for vdotq_u32); the rest of the library keeps the AArch64 baseline and the
// kernel runs only where getauxval(AT_HWCAP) reports the extension (simd_dispatch.cpp).
#include "matching/sad_kernels.hpp"

#if NIGHTLOC_ARM_KERNELS

#include <arm_neon.h>

#include <cstddef>
#include <cstdint>

#include "matching/ref_pass.hpp"  // (before the pragma: its functions keep the baseline)

#pragma GCC push_options
#pragma GCC target("arch=armv8.2-a+dotprod")

namespace nightloc::detail {
namespace {

// udot adds at most 4 * 255 per chunk to a 32-bit lane: sums stay below 2^32 for every image the
// core accepts (kMaxImagePixels), no flush needed.
struct DotAccumulation {
    using Lanes = uint32x4_t;
    static constexpr std::size_t kFlushChunks = ~std::size_t{0} / 2;
    static inline Lanes zero() { return vdupq_n_u32(0); }
    static inline Lanes add(Lanes acc, uint8x16_t difference) { return vdotq_u32(acc, difference, vdupq_n_u8(1)); }
    static inline std::uint32_t total(Lanes acc) { return vaddvq_u32(acc); }
};

}  // namespace
}  // namespace nightloc::detail

#include "matching/arm/sad_neon_body.hpp"

namespace nightloc::detail {

void sad_copies_neon_dotprod(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies,
                             const std::uint8_t* refs, std::size_t ref_stride, std::size_t n_refs, std::size_t pixels,
                             std::uint32_t* out, std::size_t out_stride) {
    copies_kernel<DotAccumulation>(copies, stride, n_copies, refs, ref_stride, n_refs, pixels, out, out_stride);
}

}  // namespace nightloc::detail

#pragma GCC pop_options

#endif  // NIGHTLOC_ARM_KERNELS
