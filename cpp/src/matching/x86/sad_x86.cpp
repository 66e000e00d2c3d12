// x86 SIMD kernels, each compiled for its instruction set with a target attribute and chosen at
// run time (simd_dispatch.cpp): the rest of the library keeps the baseline ISA, so the same
// binary runs on any x86-64 CPU. See sad_kernels.hpp for the data layouts.
#include "matching/ref_pass.hpp"
#include "matching/sad_kernels.hpp"

#if NIGHTLOC_X86_KERNELS

// GCC 12's AVX-512 headers trip -Wmaybe-uninitialized on their own _mm512_undefined_*()
// placeholders (GCC bug 105593, fixed in GCC 13); nothing in this file reads an undefined value.
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include <immintrin.h>

#define NL_TARGET_SSE2 __attribute__((target("sse2")))
#define NL_TARGET_AVX2 __attribute__((target("avx2")))
#define NL_TARGET_AVX512 __attribute__((target("avx512f,avx512bw")))
#define NL_INLINE inline __attribute__((always_inline))

namespace nightloc::detail {
namespace {

// --------------------------------------------------------------------------------------------
// SSE2: psadbw on 16-byte chunks.

NL_TARGET_SSE2 NL_INLINE std::uint32_t hsum_sse2(__m128i v) {
    __m128i hi = _mm_unpackhi_epi64(v, v);
    return static_cast<std::uint32_t>(_mm_cvtsi128_si32(_mm_add_epi32(v, hi)));
}

// AVX2: vpsadbw on 32-byte chunks.
NL_TARGET_AVX2 NL_INLINE std::uint32_t hsum_avx2(__m256i v) {
    __m128i s = _mm_add_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
    s = _mm_add_epi32(s, _mm_unpackhi_epi64(s, s));
    return static_cast<std::uint32_t>(_mm_cvtsi128_si32(s));
}

NL_TARGET_AVX512 NL_INLINE std::uint32_t hsum_avx512(__m512i v) {
    __m256i s = _mm256_add_epi32(_mm512_castsi512_si256(v), _mm512_extracti64x4_epi64(v, 1));
    __m128i t = _mm_add_epi32(_mm256_castsi256_si128(s), _mm256_extracti128_si256(s, 1));
    t = _mm_add_epi32(t, _mm_unpackhi_epi64(t, t));
    return static_cast<std::uint32_t>(_mm_cvtsi128_si32(t));
}

}  // namespace

// The copies kernel of one instruction set (see sad_kernels.hpp). For each pass of 8 references
// and each copy: one aligned load of each query chunk, compared with the 8 references' chunks.
// Written once as a macro because each instance must carry its own target attribute.
#define NL_DEFINE_COPIES_KERNEL(NAME, TARGET, VEC, V, ZERO, LOAD, SAD, ADD, HSUM)                                    \
    TARGET void NAME(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies, const std::uint8_t* refs, \
                     std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,             \
                     std::size_t out_stride) {                                                                       \
        const std::size_t n_full = pixels / (V);                                                                     \
        const bool has_tail = pixels % (V) != 0;                                                                     \
        RefPass<(V)> pass(pixels, n_copies);                                                                         \
        /* While a pass computes, the next pass's references are prefetched, spread over its copies. */              \
        const std::size_t pass_lines = kRefsPerPass * ref_stride / 64 + 1;                                           \
        const std::size_t lines_per_copy = (pass_lines + n_copies - 1) / n_copies;                                   \
        for (std::size_t first = 0; first < n_refs; first += kRefsPerPass) {                                         \
            pass.load(refs, ref_stride, first, n_refs);                                                              \
            const char* next = reinterpret_cast<const char*>(refs + (first + kRefsPerPass) * ref_stride);            \
            for (std::size_t j = 0; j < n_copies; ++j) {                                                             \
                const std::uint8_t* q = copies + j * stride;                                                         \
                if (first + kRefsPerPass < n_refs) {                                                                 \
                    for (std::size_t l = j * lines_per_copy; l < (j + 1) * lines_per_copy && l < pass_lines; ++l)    \
                        _mm_prefetch(next + 64 * l, _MM_HINT_T0);                                                    \
                }                                                                                                    \
                VEC acc[kRefsPerPass];                                                                               \
                _Pragma("GCC unroll 8") for (std::size_t k = 0; k < kRefsPerPass; ++k) acc[k] = ZERO();              \
                for (std::size_t c = 0; c < n_full; ++c) {                                                           \
                    const VEC qv = LOAD(q + c * (V));                                                                \
                    _Pragma("GCC unroll 8") for (std::size_t k = 0; k < kRefsPerPass; ++k) {                         \
                        acc[k] = ADD(acc[k], SAD(qv, LOAD##U(pass.row[k] + c * (V))));                               \
                    }                                                                                                \
                }                                                                                                    \
                if (has_tail) {                                                                                      \
                    const VEC qv = LOAD(q + n_full * (V));                                                           \
                    _Pragma("GCC unroll 8") for (std::size_t k = 0; k < kRefsPerPass; ++k) {                         \
                        acc[k] = ADD(acc[k], SAD(qv, LOAD##U(pass.tail[k])));                                        \
                    }                                                                                                \
                }                                                                                                    \
                std::uint32_t sums[kRefsPerPass];                                                                    \
                _Pragma("GCC unroll 8") for (std::size_t k = 0; k < kRefsPerPass; ++k) sums[k] = HSUM(acc[k]);       \
                for (std::size_t k = 0; k < pass.count; ++k) out[(first + k) * out_stride + j] = sums[k];            \
            }                                                                                                        \
        }                                                                                                            \
    }

namespace {
NL_TARGET_SSE2 NL_INLINE __m128i load_sse2(const std::uint8_t* p) {
    return _mm_load_si128(reinterpret_cast<const __m128i*>(p));
}
NL_TARGET_SSE2 NL_INLINE __m128i load_sse2U(const std::uint8_t* p) {
    return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
}
NL_TARGET_AVX2 NL_INLINE __m256i load_avx2(const std::uint8_t* p) {
    return _mm256_load_si256(reinterpret_cast<const __m256i*>(p));
}
NL_TARGET_AVX2 NL_INLINE __m256i load_avx2U(const std::uint8_t* p) {
    return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
}
NL_TARGET_AVX512 NL_INLINE __m512i load_avx512(const std::uint8_t* p) { return _mm512_load_si512(p); }
NL_TARGET_AVX512 NL_INLINE __m512i load_avx512U(const std::uint8_t* p) { return _mm512_loadu_si512(p); }
}  // namespace

NL_DEFINE_COPIES_KERNEL(sad_copies_sse2, NL_TARGET_SSE2, __m128i, 16, _mm_setzero_si128, load_sse2, _mm_sad_epu8,
                        _mm_add_epi32, hsum_sse2)
NL_DEFINE_COPIES_KERNEL(sad_copies_avx2, NL_TARGET_AVX2, __m256i, 32, _mm256_setzero_si256, load_avx2, _mm256_sad_epu8,
                        _mm256_add_epi32, hsum_avx2)
NL_DEFINE_COPIES_KERNEL(sad_copies_avx512bw, NL_TARGET_AVX512, __m512i, 64, _mm512_setzero_si512, load_avx512,
                        _mm512_sad_epu8, _mm512_add_epi32, hsum_avx512)

#undef NL_DEFINE_COPIES_KERNEL

namespace {

// --------------------------------------------------------------------------------------------
// AVX-512BW all-shift kernel with vdbpsadbw.
//
// _mm512_dbsad_epu8(a, b, 0xE4) gives, for every 8-byte group of a (reference pixels c..c+7 of
// one row, since width % 8 == 0) and the same bytes t of b (the query rolled by an even shift s):
//   word 0: sum_{i<4} |a[i]   - t[i]|     -> shift s     on pixels c..c+3
//   word 1: sum_{i<4} |a[i]   - t[i+1]|   -> shift s + 1 on pixels c..c+3
//   word 2: sum_{i<4} |a[4+i] - t[2+i]|   -> shift s - 2 on pixels c+4..c+7
//   word 3: sum_{i<4} |a[4+i] - t[3+i]|   -> shift s - 1 on pixels c+4..c+7
// Accumulating copy m (s = 2m) over the image gives four partial sums P_m[0..3]; then
//   sum(2m) = P_m[0] + P_{m+1}[2],  sum(2m+1) = P_m[1] + P_{m+1}[3]   (m + 1 modulo width/2).
// Words hold at most 1020 per chunk; accumulators are flushed to 32 bits every 32 chunks so
// that the 16-bit fold of their two halves cannot overflow (2 * 32 * 1020 < 65536), and so that
// the VNNI variant's packed word totals stay below 32768 (32 * 1020 = 32640).

constexpr std::size_t kFlushChunks = 32;
constexpr std::size_t kMaxGroup = 24;

// Four 16-bit accumulators -> [P_a[0..3], P_b[0..3], P_c[0..3], P_d[0..3]] as 32-bit lanes.
NL_TARGET_AVX512 NL_INLINE __m512i fold_words(__m512i acc) {
    return _mm512_cvtepu16_epi32(_mm256_add_epi16(_mm512_castsi512_si256(acc), _mm512_extracti64x4_epi64(acc, 1)));
}

// A VNNI accumulator (see accumulate below) -> lane pairs summed as in fold_words, as 32-bit
// [P[0], -P[1], P[2], -P[3]] per lane (reduce4 restores the signs).
NL_TARGET_AVX512 NL_INLINE __m512i fold_packed(__m512i acc) {
    const __m512i low = _mm512_and_si512(acc, _mm512_set1_epi32(0x7fff));  // W0, W2 of every group
    const __m512i high = _mm512_srai_epi32(acc, 15);                       // -W1, -W3
    return _mm512_add_epi32(_mm512_unpacklo_epi32(low, high), _mm512_unpackhi_epi32(low, high));
}

template <bool Vnni>
NL_TARGET_AVX512 NL_INLINE __m512i fold(__m512i acc) {
    if constexpr (Vnni) {
        return fold_packed(acc);
    } else {
        return fold_words(acc);
    }
}

// acc += d: 16-bit adds, or with VNNI (vpdpwssd against the word pair (1, -32768)) one 32-bit
// lane per word pair: W0 - 32768 * W1, exact while every word total stays below 32768. vpdpwssd
// runs on port 0 only, so it never competes with vdbpsadbw (port 5) as vpaddw does
// (docs/performance.md: the pairs per cycle). Inline assembly: the instruction needs no compiler
// target flag, so the kernel is compiled once for AVX-512BW and the VNNI variant is chosen at run time.
template <bool Vnni>
NL_TARGET_AVX512 NL_INLINE __m512i accumulate(__m512i acc, __m512i d, __m512i pair_weights) {
    if constexpr (Vnni) {
        __asm__("vpdpwssd %[w], %[d], %[acc]" : [acc] "+v"(acc) : [d] "v"(d), [w] "v"(pair_weights));
        return acc;
    } else {
        (void)pair_weights;
        return _mm512_add_epi16(acc, d);
    }
}

template <bool Vnni>
NL_TARGET_AVX512 NL_INLINE __m512i reduce4(__m512i a, __m512i b, __m512i c, __m512i d) {
    const __m512i fa = fold<Vnni>(a), fb = fold<Vnni>(b), fc = fold<Vnni>(c), fd = fold<Vnni>(d);
    const __m512i ab = _mm512_add_epi32(_mm512_shuffle_i32x4(fa, fb, _MM_SHUFFLE(1, 0, 1, 0)),
                                        _mm512_shuffle_i32x4(fa, fb, _MM_SHUFFLE(3, 2, 3, 2)));
    const __m512i cd = _mm512_add_epi32(_mm512_shuffle_i32x4(fc, fd, _MM_SHUFFLE(1, 0, 1, 0)),
                                        _mm512_shuffle_i32x4(fc, fd, _MM_SHUFFLE(3, 2, 3, 2)));
    const __m512i sums = _mm512_add_epi32(_mm512_shuffle_i32x4(ab, cd, _MM_SHUFFLE(2, 0, 2, 0)),
                                          _mm512_shuffle_i32x4(ab, cd, _MM_SHUFFLE(3, 1, 3, 1)));
    if constexpr (Vnni) {
        return _mm512_mask_sub_epi32(sums, 0xAAAA, _mm512_setzero_si512(), sums);  // -(-P[1]), -(-P[3])
    } else {
        return sums;
    }
}

// Computes P_m[0..3] for copies m0 .. m0+G-1 of one reference into part[m * 4 + p].
template <std::size_t G, bool Vnni>
NL_TARGET_AVX512 NL_INLINE void dbsad_group(const std::uint8_t* interleaved, std::size_t chunk_stride, std::size_t m0,
                                            const std::uint8_t* ref, std::size_t ref_stride, std::size_t pixels,
                                            std::uint32_t* part) {
    static_assert(G >= 1 && G <= kMaxGroup, "group size");
    const std::size_t n_full = pixels / kChunk;
    const std::size_t tail = pixels % kChunk;
    const std::size_t n_chunks = n_full + (tail ? 1 : 0);
    const __mmask64 tail_mask = tail ? (~std::uint64_t{0} >> (64 - tail)) : ~std::uint64_t{0};
    const __m512i pair_weights = _mm512_set1_epi32(static_cast<int>(0x80000001u));  // words (1, -32768)
    __m512i acc[G];
    for (std::size_t c = 0; c < n_chunks;) {
        const bool first_flush = c == 0;
        const std::size_t stop = c + kFlushChunks < n_chunks ? c + kFlushChunks : n_chunks;
#pragma GCC unroll 24
        for (std::size_t g = 0; g < G; ++g) acc[g] = _mm512_setzero_si512();
        for (; c < stop; ++c) {
            const __m512i r = c < n_full ? _mm512_loadu_si512(ref + c * kChunk)
                                         : _mm512_maskz_loadu_epi8(tail_mask, ref + c * kChunk);
            // References stream from memory once per query: fetch two references ahead (a
            // prefetch never faults, also past the end of the array).
            _mm_prefetch(reinterpret_cast<const char*>(ref + 2 * ref_stride + c * kChunk), _MM_HINT_T0);
            const std::uint8_t* base = interleaved + c * chunk_stride + m0 * kChunk;
#pragma GCC unroll 24
            for (std::size_t g = 0; g < G; ++g) {
                acc[g] = accumulate<Vnni>(acc[g], _mm512_dbsad_epu8(r, _mm512_load_si512(base + g * kChunk), 0xE4),
                                          pair_weights);
            }
        }
#pragma GCC unroll 6
        for (std::size_t g = 0; g < G; g += 4) {
            std::uint32_t* p = part + (m0 + g) * 4;
            // G not a multiple of 4 (the offsets kernel): the last reduction repeats acc[G - 1]; its
            // extra lanes land in part beyond copy m0 + G - 1 (slack, or the next group's, stored
            // over by that group's first flush).
            const __m512i sums = reduce4<Vnni>(acc[g], acc[g + 1 < G ? g + 1 : G - 1], acc[g + 2 < G ? g + 2 : G - 1],
                                               acc[g + 3 < G ? g + 3 : G - 1]);
            _mm512_storeu_si512(p, first_flush ? sums : _mm512_add_epi32(_mm512_loadu_si512(p), sums));
        }
    }
}

// Totals of group g (copies 4g..4g+3): lane l holds sum(8g + 2l) and sum(8g + 2l + 1) in its
// dwords 0 and 1 (dwords 2, 3 are not meaningful). part must extend 4 words past the last copy
// with a repeat of copy 0 (the wrap-around of m + 1).
NL_TARGET_AVX512 NL_INLINE __m512i group_totals(const std::uint32_t* part, std::size_t g) {
    const __m512i here = _mm512_loadu_si512(part + 16 * g);
    const __m512i next = _mm512_loadu_si512(part + 16 * g + 4);
    return _mm512_add_epi32(here, _mm512_shuffle_epi32(next, static_cast<_MM_PERM_ENUM>(0xEE)));
}

template <bool Vnni>
NL_TARGET_AVX512 void sad_all_shifts(const std::uint8_t* interleaved, std::size_t width, const std::uint8_t* refs,
                                     std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                                     std::size_t out_stride, const std::uint16_t* selected, std::uint32_t* best_sums,
                                     std::int32_t* best_shifts) {
    const std::size_t n_even = width / 2;    // copies, a multiple of 4 since width % 8 == 0
    const std::size_t n_groups = width / 8;  // groups of 4 copies = 8 shifts
    const std::size_t chunk_stride = n_even * kChunk;
    alignas(64) std::uint32_t part[kAllShiftMaxWidth / 2 * 4 + 16];
    // Gathers the two meaningful dwords of every lane: shifts 8g .. 8g+7 in order.
    const __m512i pack = _mm512_setr_epi32(0, 1, 4, 5, 8, 9, 12, 13, 0, 1, 4, 5, 8, 9, 12, 13);
    const __m512i none = _mm512_set1_epi32(-1);
    for (std::size_t i = 0; i < n_refs; ++i) {
        const std::uint8_t* ref = refs + i * ref_stride;
        for (std::size_t m0 = 0; m0 < n_even;) {
            const std::size_t left = n_even - m0;
            switch (left >= kMaxGroup ? kMaxGroup : left) {
                case 24:
                    dbsad_group<24, Vnni>(interleaved, chunk_stride, m0, ref, ref_stride, pixels, part);
                    m0 += 24;
                    break;
                case 20:
                    dbsad_group<20, Vnni>(interleaved, chunk_stride, m0, ref, ref_stride, pixels, part);
                    m0 += 20;
                    break;
                case 16:
                    dbsad_group<16, Vnni>(interleaved, chunk_stride, m0, ref, ref_stride, pixels, part);
                    m0 += 16;
                    break;
                case 12:
                    dbsad_group<12, Vnni>(interleaved, chunk_stride, m0, ref, ref_stride, pixels, part);
                    m0 += 12;
                    break;
                case 8:
                    dbsad_group<8, Vnni>(interleaved, chunk_stride, m0, ref, ref_stride, pixels, part);
                    m0 += 8;
                    break;
                default:
                    dbsad_group<4, Vnni>(interleaved, chunk_stride, m0, ref, ref_stride, pixels, part);
                    m0 += 4;
                    break;
            }
        }
        _mm_storeu_si128(reinterpret_cast<__m128i*>(part + n_even * 4),
                         _mm_loadu_si128(reinterpret_cast<const __m128i*>(part)));
        if (out != nullptr) {
            std::uint32_t* o = out + i * out_stride;
            for (std::size_t g = 0; g < n_groups; ++g) {
                const __m512i packed = _mm512_permutexvar_epi32(pack, group_totals(part, g));
                _mm256_storeu_si256(reinterpret_cast<__m256i*>(o + 8 * g), _mm512_castsi512_si256(packed));
            }
            continue;
        }
        // Min mode: unselected and meaningless dwords become 0xffffffff, above any real sum.
        __m512i lowest = none;
        for (std::size_t g = 0; g < n_groups; ++g) {
            lowest = _mm512_min_epu32(lowest, _mm512_mask_mov_epi32(none, selected[g], group_totals(part, g)));
        }
        const std::uint32_t best = _mm512_reduce_min_epu32(lowest);
        const __m512i target = _mm512_set1_epi32(static_cast<int>(best));
        std::int32_t shift = -1;
        for (std::size_t g = 0; g < n_groups; ++g) {
            const __mmask16 hit = _mm512_mask_cmpeq_epu32_mask(selected[g], group_totals(part, g), target);
            if (hit) {
                const auto bit = static_cast<std::uint32_t>(__builtin_ctz(hit));
                shift = static_cast<std::int32_t>(8 * g + 2 * (bit / 4) + bit % 4);
                break;
            }
        }
        best_sums[i] = best;
        best_shifts[i] = shift;
    }
}

// Sums P_m[0..3] of every copy m < n_copies of one reference band into part, in groups of at
// most kMaxGroup copies (groups of 13..24 rounded down to a multiple of 4, smaller ones exact).
template <bool Vnni>
NL_TARGET_AVX512 NL_INLINE void offset_partials(const std::uint8_t* layout, std::size_t n_copies,
                                                const std::uint8_t* ref, std::size_t ref_stride, std::size_t pixels,
                                                std::uint32_t* part) {
    const std::size_t chunk_stride = n_copies * kChunk;
    for (std::size_t m0 = 0; m0 < n_copies;) {
        const std::size_t left = n_copies - m0;
        const std::size_t group = left > 12 ? (left >= kMaxGroup ? kMaxGroup : left / 4 * 4) : left;
        switch (group) {
#define NL_OFFSET_GROUP(G)                                                             \
    case G:                                                                            \
        dbsad_group<G, Vnni>(layout, chunk_stride, m0, ref, ref_stride, pixels, part); \
        break;
            NL_OFFSET_GROUP(1)
            NL_OFFSET_GROUP(2)
            NL_OFFSET_GROUP(3)
            NL_OFFSET_GROUP(4)
            NL_OFFSET_GROUP(5)
            NL_OFFSET_GROUP(6)
            NL_OFFSET_GROUP(7)
            NL_OFFSET_GROUP(8)
            NL_OFFSET_GROUP(9)
            NL_OFFSET_GROUP(10)
            NL_OFFSET_GROUP(11)
            NL_OFFSET_GROUP(12)
            NL_OFFSET_GROUP(16)
            NL_OFFSET_GROUP(20)
            default:
                dbsad_group<24, Vnni>(layout, chunk_stride, m0, ref, ref_stride, pixels, part);
                break;
#undef NL_OFFSET_GROUP
        }
        m0 += group;
    }
}

// The offsets kernel (sad_kernels.hpp): P_m for every copy, then slot j (offset e0 + first + j)
// = P_m[d] + P_{m+1}[2 + d] with first + j = 2m + d.
template <bool Vnni>
NL_TARGET_AVX512 void sad_offsets(const std::uint8_t* layout, std::size_t n_copies, std::size_t first,
                                  std::size_t n_slots, const std::uint8_t* refs, std::size_t ref_stride,
                                  std::size_t n_refs, std::size_t pixels, std::uint32_t* out, std::size_t out_stride) {
    alignas(64) std::uint32_t part[(kMaxOffsetCopies + 4) * 4 + 16];
    for (std::size_t i = 0; i < n_refs; ++i) {
        offset_partials<Vnni>(layout, n_copies, refs + i * ref_stride, ref_stride, pixels, part);
        std::uint32_t* o = out + i * out_stride;
        for (std::size_t j = 0; j < n_slots; ++j) {
            const std::size_t r = first + j, m = r / 2, d = r % 2;
            o[j] = part[m * 4 + d] + part[(m + 1) * 4 + 2 + d];
        }
    }
}

}  // namespace

void sad_all_shifts_avx512bw(const std::uint8_t* interleaved, std::size_t width, const std::uint8_t* refs,
                             std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                             std::size_t out_stride, const std::uint16_t* selected, std::uint32_t* best_sums,
                             std::int32_t* best_shifts) {
    sad_all_shifts<false>(interleaved, width, refs, ref_stride, n_refs, pixels, out, out_stride, selected, best_sums,
                          best_shifts);
}

void sad_all_shifts_avx512vnni(const std::uint8_t* interleaved, std::size_t width, const std::uint8_t* refs,
                               std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                               std::size_t out_stride, const std::uint16_t* selected, std::uint32_t* best_sums,
                               std::int32_t* best_shifts) {
    sad_all_shifts<true>(interleaved, width, refs, ref_stride, n_refs, pixels, out, out_stride, selected, best_sums,
                         best_shifts);
}

void sad_offsets_avx512bw(const std::uint8_t* layout, std::size_t n_copies, std::size_t first, std::size_t n_slots,
                          const std::uint8_t* refs, std::size_t ref_stride, std::size_t n_refs, std::size_t pixels,
                          std::uint32_t* out, std::size_t out_stride) {
    sad_offsets<false>(layout, n_copies, first, n_slots, refs, ref_stride, n_refs, pixels, out, out_stride);
}

void sad_offsets_avx512vnni(const std::uint8_t* layout, std::size_t n_copies, std::size_t first, std::size_t n_slots,
                            const std::uint8_t* refs, std::size_t ref_stride, std::size_t n_refs, std::size_t pixels,
                            std::uint32_t* out, std::size_t out_stride) {
    sad_offsets<true>(layout, n_copies, first, n_slots, refs, ref_stride, n_refs, pixels, out, out_stride);
}

}  // namespace nightloc::detail

#endif  // NIGHTLOC_X86_KERNELS
