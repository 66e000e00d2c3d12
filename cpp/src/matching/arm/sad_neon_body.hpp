// Internal: the body of the NEON copies kernels (see sad_neon.cpp), included by sad_neon.cpp for
// plain NEON and by sad_neon_dotprod.cpp inside a target region for the dot-product extension.
// Everything here has internal linkage: each file compiles its own copy for its instruction set.
// The including file defines the accumulation `Acc` (Lanes, kFlushChunks, zero, add, total) and
// includes <arm_neon.h> and ref_pass.hpp first.
#pragma once

#include <cstddef>
#include <cstdint>

#define NL_INLINE inline __attribute__((always_inline))

namespace nightloc::detail {
namespace {

constexpr std::size_t kVector = 16;
constexpr std::size_t kCopiesPerPass = 2;

// sums[j][k] = SAD of copy q[j] and reference k of the pass, for Q copies: the n_full full chunks
// from pass.row[k], then (when `tail`) the zero-padded partial chunk from pass.tail[k].
template <class Acc, std::size_t Q>
NL_INLINE void pass_sums(const std::uint8_t* const* q, const RefPass<kVector>& pass, std::size_t n_full, bool tail,
                         std::uint32_t (*sums)[kRefsPerPass]) {
    std::size_t first = 0;
    do {  // blocks of at most kFlushChunks full chunks (n_full = 0: the partial chunk alone)
        const std::size_t last = n_full - first > Acc::kFlushChunks ? first + Acc::kFlushChunks : n_full;
        typename Acc::Lanes acc[Q][kRefsPerPass];
#pragma GCC unroll 16
        for (std::size_t j = 0; j < Q; ++j) {
#pragma GCC unroll 8
            for (std::size_t k = 0; k < kRefsPerPass; ++k) acc[j][k] = Acc::zero();
        }
        for (std::size_t c = first; c < last; ++c) {
            uint8x16_t qv[Q];
#pragma GCC unroll 2
            for (std::size_t j = 0; j < Q; ++j) qv[j] = vld1q_u8(q[j] + c * kVector);
#pragma GCC unroll 8
            for (std::size_t k = 0; k < kRefsPerPass; ++k) {
                const uint8x16_t r = vld1q_u8(pass.row[k] + c * kVector);
#pragma GCC unroll 2
                for (std::size_t j = 0; j < Q; ++j) acc[j][k] = Acc::add(acc[j][k], vabdq_u8(qv[j], r));
            }
        }
        if (last == n_full && tail) {
#pragma GCC unroll 8
            for (std::size_t k = 0; k < kRefsPerPass; ++k) {
                const uint8x16_t r = vld1q_u8(pass.tail[k]);
#pragma GCC unroll 2
                for (std::size_t j = 0; j < Q; ++j) {
                    acc[j][k] = Acc::add(acc[j][k], vabdq_u8(vld1q_u8(q[j] + n_full * kVector), r));
                }
            }
        }
#pragma GCC unroll 2
        for (std::size_t j = 0; j < Q; ++j) {
#pragma GCC unroll 8
            for (std::size_t k = 0; k < kRefsPerPass; ++k) sums[j][k] += Acc::total(acc[j][k]);
        }
        first = last;
    } while (first < n_full);
}

// The copies kernel (see sad_kernels.hpp): for each pass of 8 references, pairs of copies.
template <class Acc>
NL_INLINE void copies_kernel(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies,
                             const std::uint8_t* refs, std::size_t ref_stride, std::size_t n_refs, std::size_t pixels,
                             std::uint32_t* out, std::size_t out_stride) {
    const std::size_t n_full = pixels / kVector;
    const bool tail = pixels % kVector != 0;
    RefPass<kVector> pass(pixels, n_copies);
    // While a pass computes, the next pass's references are prefetched, spread over its copies.
    const std::size_t pass_lines = kRefsPerPass * ref_stride / 64 + 1;
    const std::size_t lines_per_copy = (pass_lines + n_copies - 1) / n_copies;
    for (std::size_t first = 0; first < n_refs; first += kRefsPerPass) {
        pass.load(refs, ref_stride, first, n_refs);
        const char* next = reinterpret_cast<const char*>(refs + (first + kRefsPerPass) * ref_stride);
        for (std::size_t j = 0; j < n_copies;) {
            const std::size_t q_count = n_copies - j >= kCopiesPerPass ? kCopiesPerPass : 1;
            if (first + kRefsPerPass < n_refs) {
                const std::size_t stop = (j + q_count) * lines_per_copy;
                for (std::size_t l = j * lines_per_copy; l < stop && l < pass_lines; ++l) {
                    __builtin_prefetch(next + 64 * l);
                }
            }
            std::uint32_t sums[kCopiesPerPass][kRefsPerPass] = {};
            const std::uint8_t* q[kCopiesPerPass] = {copies + j * stride, copies + (j + 1) * stride};
            if (q_count == 2) {
                pass_sums<Acc, 2>(q, pass, n_full, tail, sums);
            } else {
                pass_sums<Acc, 1>(q, pass, n_full, tail, sums);
            }
            for (std::size_t jj = 0; jj < q_count; ++jj) {
                for (std::size_t k = 0; k < pass.count; ++k) out[(first + k) * out_stride + j + jj] = sums[jj][k];
            }
            j += q_count;
        }
    }
}

}  // namespace
}  // namespace nightloc::detail
