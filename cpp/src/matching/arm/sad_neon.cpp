// AArch64 NEON kernels of the rotational SAD (see sad_kernels.hpp for the data layouts). NEON is
// part of the AArch64 baseline; the dot-product variant (sad_neon_dotprod.cpp) is chosen at run
// time from the kernel's hardware capabilities (simd_dispatch.cpp), so the same binary runs on
// every AArch64 CPU.
//
// Per 16 byte comparisons: one vabdq_u8 (|q - r| in 16 bytes), then
//  - neon:         vpadalq_u8 adds the byte pairs into eight 16-bit lanes (flushed to 32 bits
//                  before they can overflow);
//  - neon-dotprod: udot against a vector of ones adds groups of four bytes into four 32-bit lanes.
// Two vector instructions per 16 bytes in both: up to 16 byte comparisons per cycle on a core
// with two vector pipes (Cortex-A72, A76). Each step compares 2 query copies with 8 references,
// so 10 loads feed 256 byte comparisons (Cortex-A72 has a single load pipe).
#include "matching/sad_kernels.hpp"

#if NIGHTLOC_ARM_KERNELS

#include <arm_neon.h>

#include <cstddef>
#include <cstdint>

#include "matching/ref_pass.hpp"

namespace nightloc::detail {
namespace {

// vpadalq_u8 adds at most 2 * 255 to a 16-bit lane per chunk: flush after 127 full chunks, so
// that a block plus the partial last chunk stays below 65536 (128 * 510 = 65280).
struct PairwiseAccumulation {
    using Lanes = uint16x8_t;
    static constexpr std::size_t kFlushChunks = 127;
    static inline Lanes zero() { return vdupq_n_u16(0); }
    static inline Lanes add(Lanes acc, uint8x16_t difference) { return vpadalq_u8(acc, difference); }
    static inline std::uint32_t total(Lanes acc) { return vaddlvq_u16(acc); }
};

}  // namespace
}  // namespace nightloc::detail

#include "matching/arm/sad_neon_body.hpp"

namespace nightloc::detail {

void sad_copies_neon(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies, const std::uint8_t* refs,
                     std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                     std::size_t out_stride) {
    copies_kernel<PairwiseAccumulation>(copies, stride, n_copies, refs, ref_stride, n_refs, pixels, out, out_stride);
}

}  // namespace nightloc::detail

#endif  // NIGHTLOC_ARM_KERNELS
