// Row kernels of frame preparation, compiled once per SIMD path: the plain loops below are
// compiled for the baseline (sse2), for AVX2 and for AVX-512 with target attributes (the rest of
// the library keeps the baseline ISA), and once with auto-vectorization disabled (scalar). The
// equalization table lookup has a hand-written AVX-512 VBMI kernel (vpermi2b: 64 lookups in a
// 256-entry table per two instructions), used on the avx512bw path when the CPU has VBMI. On
// AArch64 the neon paths have NEON kernels for grey conversion, table lookup and prefix sums.
// Integer arithmetic only: every path gives the same bytes.
#include "preparation/prepare_kernels.hpp"

#include <cstring>

#include "common/arch.hpp"
#include "common/simd_paths.hpp"

#if NIGHTLOC_X86_KERNELS
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC bug 105593 in the AVX-512 headers
#endif
#include <immintrin.h>
#endif
#if NIGHTLOC_ARM_KERNELS
#include <arm_neon.h>
#endif

#define NL_INLINE inline __attribute__((always_inline))

namespace nightloc::detail {
namespace {

// cv2.cvtColor's 8-bit BGR -> grey: 15-bit fixed-point weights of ITU-R BT.601 (0.114, 0.587,
// 0.299), rounded to nearest.
constexpr std::uint32_t kBlueWeight = 3735, kGreenWeight = 19235, kRedWeight = 9798, kGreyShift = 15;

template <std::size_t Channels, std::size_t Blue, std::size_t Red>
NL_INLINE void grey_body(const std::uint8_t* src, std::size_t n, std::uint8_t* dst) {
    for (std::size_t x = 0; x < n; ++x) {
        const std::uint8_t* p = src + x * Channels;
        const std::uint32_t v = std::uint32_t{p[Blue]} * kBlueWeight + std::uint32_t{p[1]} * kGreenWeight +
                                std::uint32_t{p[Red]} * kRedWeight + (1u << (kGreyShift - 1));
        dst[x] = static_cast<std::uint8_t>(v >> kGreyShift);
    }
}

NL_INLINE void grey_dispatch(const std::uint8_t* src, std::size_t n, PixelOrder order, std::uint8_t* dst) {
    switch (order) {
        case PixelOrder::bgr:
            grey_body<3, 0, 2>(src, n, dst);
            break;
        case PixelOrder::rgb:
            grey_body<3, 2, 0>(src, n, dst);
            break;
        case PixelOrder::bgra:
            grey_body<4, 0, 2>(src, n, dst);
            break;
        case PixelOrder::rgba:
            grey_body<4, 2, 0>(src, n, dst);
            break;
        case PixelOrder::grey:
            std::memcpy(dst, src, n);
            break;
    }
}

NL_INLINE void accumulate_body(const std::uint8_t* src, std::size_t n, std::uint16_t* band) {
    for (std::size_t x = 0; x < n; ++x) band[x] = static_cast<std::uint16_t>(band[x] + src[x]);
}

// band[x] += lut[src[x]]: the table lookups eight pixels at a time into a row buffer (one 64-bit
// store per eight), then the vectorizable add. (A fused scalar loop is slower: every 16-bit
// store may alias the byte tables, so the compiler reloads them; docs/performance.md.)
NL_INLINE void accumulate_lut_body(const std::uint8_t* src, std::size_t n, const std::uint8_t* lut,
                                   std::uint16_t* band) {
    std::uint8_t mapped[256];
    for (std::size_t start = 0; start < n; start += sizeof(mapped)) {
        const std::size_t count = n - start < sizeof(mapped) ? n - start : sizeof(mapped);
        const std::uint8_t* in = src + start;
        std::size_t x = 0;
        for (; x + 8 <= count; x += 8) {
            std::uint64_t v;
            std::memcpy(&v, in + x, 8);
            std::uint64_t out = 0;
            for (unsigned k = 0; k < 8; ++k) out |= std::uint64_t{lut[(v >> (8 * k)) & 0xff]} << (8 * k);
            std::memcpy(mapped + x, &out, 8);
        }
        for (; x < count; ++x) mapped[x] = lut[in[x]];
        std::uint16_t* b = band + start;
        for (x = 0; x < count; ++x) b[x] = static_cast<std::uint16_t>(b[x] + mapped[x]);
    }
}

NL_INLINE void prefix_body(const std::uint16_t* band, std::size_t n, std::uint32_t* prefix) {
    std::uint32_t running = 0;
    prefix[0] = 0;
    for (std::size_t x = 0; x < n; ++x) {
        running += band[x];
        prefix[x + 1] = running;
    }
}

// Eight sub-histograms, one per byte of a 64-bit load: equal neighbouring pixels (smooth
// images) land in different counters, so the increments do not wait on each other through
// memory (docs/performance.md: 4 against 8 sub-histograms).
void histogram_row(const std::uint8_t* src, std::size_t n, std::uint32_t* counts) {
    static_assert(kHistogramCopies == 8, "one sub-histogram per byte of a 64-bit word");
    std::size_t x = 0;
    for (; x + 8 <= n; x += 8) {
        std::uint64_t v;
        std::memcpy(&v, src + x, 8);
        ++counts[v & 0xff];
        ++counts[256 + ((v >> 8) & 0xff)];
        ++counts[512 + ((v >> 16) & 0xff)];
        ++counts[768 + ((v >> 24) & 0xff)];
        ++counts[1024 + ((v >> 32) & 0xff)];
        ++counts[1280 + ((v >> 40) & 0xff)];
        ++counts[1536 + ((v >> 48) & 0xff)];
        ++counts[1792 + (v >> 56)];
    }
    for (; x < n; ++x) ++counts[src[x]];
}

#define NL_DEFINE_ROW_KERNELS(suffix, attributes)                                                                    \
    attributes void grey_row_##suffix(const std::uint8_t* src, std::size_t n, PixelOrder order, std::uint8_t* dst) { \
        grey_dispatch(src, n, order, dst);                                                                           \
    }                                                                                                                \
    attributes void accumulate_row_##suffix(const std::uint8_t* src, std::size_t n, std::uint16_t* band) {           \
        accumulate_body(src, n, band);                                                                               \
    }                                                                                                                \
    attributes void accumulate_lut_row_##suffix(const std::uint8_t* src, std::size_t n, const std::uint8_t* lut,     \
                                                std::uint16_t* band) {                                               \
        accumulate_lut_body(src, n, lut, band);                                                                      \
    }                                                                                                                \
    attributes void prefix_row_##suffix(const std::uint16_t* band, std::size_t n, std::uint32_t* prefix) {           \
        prefix_body(band, n, prefix);                                                                                \
    }

#if defined(__GNUC__) && !defined(__clang__)
#define NL_NO_VECTORIZE __attribute__((optimize("no-tree-vectorize")))
#else
#define NL_NO_VECTORIZE
#endif

NL_DEFINE_ROW_KERNELS(scalar, NL_NO_VECTORIZE)
NL_DEFINE_ROW_KERNELS(baseline, [[maybe_unused]])  // (AArch64 uses some of them)

#if NIGHTLOC_X86_KERNELS
// (grey and table lookups have their own kernels below; the plain add vectorizes well)
__attribute__((target("avx2"))) void accumulate_row_avx2(const std::uint8_t* src, std::size_t n, std::uint16_t* band) {
    accumulate_body(src, n, band);
}
__attribute__((target("avx512f,avx512bw"))) void accumulate_row_avx512(const std::uint8_t* src, std::size_t n,
                                                                       std::uint16_t* band) {
    accumulate_body(src, n, band);
}

#define NL_TARGET_AVX2 __attribute__((target("avx2")))
#define NL_TARGET_AVX512 __attribute__((target("avx512f,avx512bw")))
#define NL_TARGET_VBMI __attribute__((target("avx512f,avx512bw,avx512vbmi")))

// Shuffle controls for pshufb on a 16-byte lane holding 4 pixels of `Channels` bytes from its
// start: "blue-green" puts blue and green of pixel i into the low bytes of the two 16-bit halves
// of dword i, "red" puts red into the low byte of dword i; every other byte is zeroed (0x80).
// Four copies (one per 128-bit lane of a zmm register).
template <std::size_t Channels, std::size_t Blue>
struct LaneShuffles {
    alignas(64) std::uint8_t blue_green[64] = {};
    alignas(64) std::uint8_t red[64] = {};
    constexpr LaneShuffles() {
        for (std::size_t lane = 0; lane < 4; ++lane) {
            for (std::size_t i = 0; i < 4; ++i) {
                const std::size_t at = 16 * lane + 4 * i;
                blue_green[at] = static_cast<std::uint8_t>(Channels * i + Blue);
                blue_green[at + 1] = 0x80;
                blue_green[at + 2] = static_cast<std::uint8_t>(Channels * i + 1);
                blue_green[at + 3] = 0x80;
                red[at] = static_cast<std::uint8_t>(Channels * i + 2 - Blue);
                red[at + 1] = red[at + 2] = red[at + 3] = 0x80;
            }
        }
    }
};

template <std::size_t Channels, std::size_t Blue>
constexpr LaneShuffles<Channels, Blue> kLaneShuffles{};

// vpermt2b controls of the VBMI kernel for 3-byte pixels: group g of 16 pixels lies at byte
// `offset[g]` of the 128-byte window (s0, s1) (groups 0, 1) or (s1, s2) (groups 2, 3); the
// controls put blue and green of pixel i at bytes 4i and 4i + 2, red at 4i (other bytes masked).
template <std::size_t Blue>
struct WindowPermutes {
    alignas(64) std::uint8_t blue_green[4][64] = {};
    alignas(64) std::uint8_t red[4][64] = {};
    constexpr WindowPermutes() {
        constexpr std::size_t offset[4] = {0, 48, 32, 80};
        for (std::size_t g = 0; g < 4; ++g) {
            for (std::size_t i = 0; i < 16; ++i) {
                const std::size_t base = offset[g] + 3 * i;
                blue_green[g][4 * i] = static_cast<std::uint8_t>(base + Blue);
                blue_green[g][4 * i + 2] = static_cast<std::uint8_t>(base + 1);
                red[g][4 * i] = static_cast<std::uint8_t>(base + 2 - Blue);
            }
        }
    }
};

template <std::size_t Blue>
constexpr WindowPermutes<Blue> kWindowPermutes{};

// Grey of 8 pixels (dwords) from blue-green and red dword vectors: (bg . (3735, 19235) +
// r . (9798, 0) + 16384) >> 15, with vpmaddwd.
NL_TARGET_AVX2 NL_INLINE __m256i grey_dwords_avx2(__m256i blue_green, __m256i red) {
    const __m256i weights_bg = _mm256_set1_epi32(static_cast<int>(kBlueWeight | (kGreenWeight << 16)));
    const __m256i weights_r = _mm256_set1_epi32(static_cast<int>(kRedWeight));
    const __m256i half = _mm256_set1_epi32(1 << (kGreyShift - 1));
    const __m256i sum = _mm256_add_epi32(_mm256_madd_epi16(blue_green, weights_bg), _mm256_madd_epi16(red, weights_r));
    return _mm256_srli_epi32(_mm256_add_epi32(sum, half), kGreyShift);
}

// AVX2 colour -> grey, 32 pixels per step: each 128-bit lane takes 4 pixels (pshufb within the
// lane), lanes ordered so that the two packs leave the bytes in pixel order.
template <std::size_t Channels, std::size_t Blue>
NL_TARGET_AVX2 void grey_row_avx2_simd(const std::uint8_t* src, std::size_t n, PixelOrder order, std::uint8_t* dst) {
    const auto& m = kLaneShuffles<Channels, Blue>;
    const __m256i shuffle_bg = _mm256_load_si256(reinterpret_cast<const __m256i*>(m.blue_green));
    const __m256i shuffle_r = _mm256_load_si256(reinterpret_cast<const __m256i*>(m.red));
    // the last lane reads 16 bytes from pixel x + 28: 3-byte pixels need 2 pixels of slack
    constexpr std::size_t slack = Channels == 3 ? 2 : 0;
    std::size_t x = 0;
    for (; x + 32 + slack <= n; x += 32) {
        __m256i grey[4];
        for (std::size_t k = 0; k < 4; ++k) {
            const std::uint8_t* low = src + Channels * (x + 4 * k);
            const std::uint8_t* high = src + Channels * (x + 16 + 4 * k);
            const __m256i raw =
                _mm256_inserti128_si256(_mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(low))),
                                        _mm_loadu_si128(reinterpret_cast<const __m128i*>(high)), 1);
            grey[k] = grey_dwords_avx2(_mm256_shuffle_epi8(raw, shuffle_bg), _mm256_shuffle_epi8(raw, shuffle_r));
        }
        const __m256i words01 = _mm256_packus_epi32(grey[0], grey[1]);
        const __m256i words23 = _mm256_packus_epi32(grey[2], grey[3]);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst + x), _mm256_packus_epi16(words01, words23));
    }
    grey_dispatch(src + Channels * x, n - x, order, dst + x);
}

NL_TARGET_AVX2 void grey_row_avx2_intrinsics(const std::uint8_t* src, std::size_t n, PixelOrder order,
                                             std::uint8_t* dst) {
    switch (order) {
        case PixelOrder::bgr:
            grey_row_avx2_simd<3, 0>(src, n, order, dst);
            break;
        case PixelOrder::rgb:
            grey_row_avx2_simd<3, 2>(src, n, order, dst);
            break;
        case PixelOrder::bgra:
            grey_row_avx2_simd<4, 0>(src, n, order, dst);
            break;
        case PixelOrder::rgba:
            grey_row_avx2_simd<4, 2>(src, n, order, dst);
            break;
        case PixelOrder::grey:
            std::memcpy(dst, src, n);
            break;
    }
}

NL_TARGET_AVX512 NL_INLINE __m512i grey_dwords_avx512(__m512i blue_green, __m512i red) {
    const __m512i weights_bg = _mm512_set1_epi32(static_cast<int>(kBlueWeight | (kGreenWeight << 16)));
    const __m512i weights_r = _mm512_set1_epi32(static_cast<int>(kRedWeight));
    const __m512i half = _mm512_set1_epi32(1 << (kGreyShift - 1));
    const __m512i sum = _mm512_add_epi32(_mm512_madd_epi16(blue_green, weights_bg), _mm512_madd_epi16(red, weights_r));
    return _mm512_srli_epi32(_mm512_add_epi32(sum, half), kGreyShift);
}

// Four vectors of 16 grey dwords, vector m holding pixels 16m .. 16m+15 (4 per 128-bit lane), to
// 64 bytes in pixel order: the packs interleave the lanes (dword 4L+m of the packed vector holds
// pixels 16m + 4L .. +3), one vpermd restores the order.
NL_TARGET_AVX512 NL_INLINE __m512i pack_grey_avx512(const __m512i grey[4]) {
    const __m512i packed =
        _mm512_packus_epi16(_mm512_packus_epi32(grey[0], grey[1]), _mm512_packus_epi32(grey[2], grey[3]));
    const __m512i order = _mm512_set_epi32(15, 11, 7, 3, 14, 10, 6, 2, 13, 9, 5, 1, 12, 8, 4, 0);
    return _mm512_permutexvar_epi32(order, packed);
}

// AVX-512BW, 4-byte pixels: 16 pixels per vector, pshufb within each 128-bit lane.
template <std::size_t Blue>
NL_TARGET_AVX512 void grey_row_avx512_four(const std::uint8_t* src, std::size_t n, PixelOrder order,
                                           std::uint8_t* dst) {
    const auto& m = kLaneShuffles<4, Blue>;
    const __m512i shuffle_bg = _mm512_load_si512(m.blue_green);
    const __m512i shuffle_r = _mm512_load_si512(m.red);
    std::size_t x = 0;
    for (; x + 64 <= n; x += 64) {
        __m512i grey[4];
        for (std::size_t k = 0; k < 4; ++k) {
            const __m512i raw = _mm512_loadu_si512(src + 4 * (x + 16 * k));
            grey[k] = grey_dwords_avx512(_mm512_shuffle_epi8(raw, shuffle_bg), _mm512_shuffle_epi8(raw, shuffle_r));
        }
        _mm512_storeu_si512(dst + x, pack_grey_avx512(grey));
    }
    grey_dispatch(src + 4 * x, n - x, order, dst + x);
}

// AVX-512 VBMI, 3-byte pixels: 64 pixels (192 bytes, three loads) per step; for each group of 16
// pixels one vpermt2b gathers blue and green, another red, straight into the dword layout of
// vpmaddwd (other bytes zeroed by the mask) from the 128-byte window that holds the group.
template <std::size_t Blue>
NL_TARGET_VBMI void grey_row_vbmi_three(const std::uint8_t* src, std::size_t n, PixelOrder order, std::uint8_t* dst) {
    const auto& controls = kWindowPermutes<Blue>;
    __m512i bg[4], r[4];
    for (std::size_t g = 0; g < 4; ++g) {
        bg[g] = _mm512_load_si512(controls.blue_green[g]);
        r[g] = _mm512_load_si512(controls.red[g]);
    }
    const __mmask64 keep_bg = 0x5555555555555555ull;  // bytes 0 and 2 of every dword
    const __mmask64 keep_r = 0x1111111111111111ull;   // byte 0 of every dword
    std::size_t x = 0;
    for (; x + 64 <= n; x += 64) {
        const std::uint8_t* p = src + 3 * x;
        const __m512i s0 = _mm512_loadu_si512(p);
        const __m512i s1 = _mm512_loadu_si512(p + 64);
        const __m512i s2 = _mm512_loadu_si512(p + 128);
        __m512i grey[4];
        for (std::size_t g = 0; g < 4; ++g) {
            const __m512i low = g < 2 ? s0 : s1;
            const __m512i high = g < 2 ? s1 : s2;
            grey[g] = grey_dwords_avx512(_mm512_maskz_permutex2var_epi8(keep_bg, low, bg[g], high),
                                         _mm512_maskz_permutex2var_epi8(keep_r, low, r[g], high));
        }
        _mm512_storeu_si512(dst + x, pack_grey_avx512(grey));
    }
    grey_dispatch(src + 3 * x, n - x, order, dst + x);
}

NL_TARGET_VBMI void grey_row_vbmi(const std::uint8_t* src, std::size_t n, PixelOrder order, std::uint8_t* dst) {
    switch (order) {
        case PixelOrder::bgr:
            grey_row_vbmi_three<0>(src, n, order, dst);
            break;
        case PixelOrder::rgb:
            grey_row_vbmi_three<2>(src, n, order, dst);
            break;
        case PixelOrder::bgra:
            grey_row_avx512_four<0>(src, n, order, dst);
            break;
        case PixelOrder::rgba:
            grey_row_avx512_four<2>(src, n, order, dst);
            break;
        case PixelOrder::grey:
            std::memcpy(dst, src, n);
            break;
    }
}

NL_TARGET_AVX512 void grey_row_avx512_intrinsics(const std::uint8_t* src, std::size_t n, PixelOrder order,
                                                 std::uint8_t* dst) {
    if (order == PixelOrder::bgra) {
        grey_row_avx512_four<0>(src, n, order, dst);
    } else if (order == PixelOrder::rgba) {
        grey_row_avx512_four<2>(src, n, order, dst);
    } else {
        grey_row_avx2_intrinsics(src, n, order, dst);  // 3-byte pixels need VBMI's byte permutes
    }
}

// Column prefix sums, 8 per step: two shifted adds inside each 128-bit lane, the low lane's
// total added to the high lane, the running total of earlier steps added to all.
NL_TARGET_AVX2 void prefix_row_avx2(const std::uint16_t* band, std::size_t n, std::uint32_t* prefix) {
    prefix[0] = 0;
    __m256i carry = _mm256_setzero_si256();
    const __m256i last = _mm256_set1_epi32(7);
    std::size_t x = 0;
    for (; x + 8 <= n; x += 8) {
        __m256i v = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(band + x)));
        v = _mm256_add_epi32(v, _mm256_slli_si256(v, 4));
        v = _mm256_add_epi32(v, _mm256_slli_si256(v, 8));
        v = _mm256_add_epi32(v, _mm256_shuffle_epi32(_mm256_permute2x128_si256(v, v, 0x08), 0xff));
        v = _mm256_add_epi32(v, carry);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(prefix + x + 1), v);
        carry = _mm256_permutevar8x32_epi32(v, last);
    }
    std::uint32_t running = prefix[x];
    for (; x < n; ++x) {
        running += band[x];
        prefix[x + 1] = running;
    }
}

// The same, 16 per step (valignd shifts across the whole vector).
NL_TARGET_AVX512 void prefix_row_avx512(const std::uint16_t* band, std::size_t n, std::uint32_t* prefix) {
    prefix[0] = 0;
    const __m512i zero = _mm512_setzero_si512();
    const __m512i last = _mm512_set1_epi32(15);
    __m512i carry = zero;
    std::size_t x = 0;
    for (; x + 16 <= n; x += 16) {
        __m512i v = _mm512_cvtepu16_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(band + x)));
        v = _mm512_add_epi32(v, _mm512_alignr_epi32(v, zero, 15));
        v = _mm512_add_epi32(v, _mm512_alignr_epi32(v, zero, 14));
        v = _mm512_add_epi32(v, _mm512_alignr_epi32(v, zero, 12));
        v = _mm512_add_epi32(v, _mm512_alignr_epi32(v, zero, 8));
        v = _mm512_add_epi32(v, carry);
        _mm512_storeu_si512(prefix + x + 1, v);
        carry = _mm512_permutexvar_epi32(last, v);
    }
    std::uint32_t running = prefix[x];
    for (; x < n; ++x) {
        running += band[x];
        prefix[x + 1] = running;
    }
}

// band[x] += lut[src[x]] with vpgatherdd from a 32-bit copy of the table, 16 pixels per step.
NL_TARGET_AVX2 void accumulate_lut_row_gather(const std::uint8_t* src, std::size_t n, const std::uint8_t* lut,
                                              std::uint16_t* band) {
    alignas(32) std::int32_t wide[256];
    for (std::size_t v = 0; v < 256; ++v) wide[v] = lut[v];
    std::size_t x = 0;
    for (; x + 16 <= n; x += 16) {
        const __m128i index = _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + x));
        const __m256i v0 = _mm256_i32gather_epi32(wide, _mm256_cvtepu8_epi32(index), 4);
        const __m256i v1 = _mm256_i32gather_epi32(wide, _mm256_cvtepu8_epi32(_mm_srli_si128(index, 8)), 4);
        const __m256i words = _mm256_permute4x64_epi64(_mm256_packus_epi32(v0, v1), 0xd8);
        __m256i* b = reinterpret_cast<__m256i*>(band + x);
        _mm256_storeu_si256(b, _mm256_add_epi16(_mm256_loadu_si256(b), words));
    }
    for (; x < n; ++x) band[x] = static_cast<std::uint16_t>(band[x] + lut[src[x]]);
}

// band[x] += lut[src[x]], 64 pixels per step: two vpermi2b look up the lower and the upper half
// of the table (index bits 0-6), the top bit of the index picks one; the bytes are widened to
// 16 bits and added to the band. The last partial step works on masked loads and stores.
NL_TARGET_VBMI void accumulate_lut_row_vbmi(const std::uint8_t* src, std::size_t n, const std::uint8_t* lut,
                                            std::uint16_t* band) {
    const __m512i t0 = _mm512_loadu_si512(lut);
    const __m512i t1 = _mm512_loadu_si512(lut + 64);
    const __m512i t2 = _mm512_loadu_si512(lut + 128);
    const __m512i t3 = _mm512_loadu_si512(lut + 192);
    std::size_t x = 0;
    for (; x < n; x += 64) {
        const std::size_t left = n - x;
        const __mmask64 bytes = left >= 64 ? ~__mmask64{0} : (__mmask64{1} << left) - 1;
        const __m512i index = _mm512_maskz_loadu_epi8(bytes, src + x);
        const __m512i low = _mm512_permutex2var_epi8(t0, index, t1);
        const __m512i high = _mm512_permutex2var_epi8(t2, index, t3);
        const __m512i value = _mm512_mask_blend_epi8(_mm512_movepi8_mask(index), low, high);
        const __m512i v0 = _mm512_cvtepu8_epi16(_mm512_castsi512_si256(value));
        const __m512i v1 = _mm512_cvtepu8_epi16(_mm512_extracti64x4_epi64(value, 1));
        const auto words0 = static_cast<__mmask32>(bytes);
        const auto words1 = static_cast<__mmask32>(bytes >> 32);
        const __m512i b0 = _mm512_maskz_loadu_epi16(words0, band + x);
        const __m512i b1 = _mm512_maskz_loadu_epi16(words1, band + x + 32);
        _mm512_mask_storeu_epi16(band + x, words0, _mm512_add_epi16(b0, v0));
        _mm512_mask_storeu_epi16(band + x + 32, words1, _mm512_add_epi16(b1, v1));
    }
}

bool cpu_has_vbmi() noexcept { return __builtin_cpu_supports("avx512vbmi"); }
#endif

#if NIGHTLOC_ARM_KERNELS
// NEON colour -> grey, 16 pixels per step: vld3q/vld4q split the channels, each weight is a
// 16 x 16 -> 32-bit multiply(-accumulate) on the widened bytes, and vrshrn adds 2^14 and shifts
// by 15 (the rounding of grey_body) while narrowing. Exact integer arithmetic: the same bytes.
template <std::size_t Channels, std::size_t Blue>
NL_INLINE void grey_row_neon_pixels(const std::uint8_t* src, std::size_t n, PixelOrder order, std::uint8_t* dst) {
    std::size_t x = 0;
    for (; x + 16 <= n; x += 16) {
        uint8x16_t blue, green, red;
        if constexpr (Channels == 3) {
            const uint8x16x3_t p = vld3q_u8(src + 3 * x);
            blue = p.val[Blue], green = p.val[1], red = p.val[2 - Blue];
        } else {
            const uint8x16x4_t p = vld4q_u8(src + 4 * x);
            blue = p.val[Blue], green = p.val[1], red = p.val[2 - Blue];
        }
        const uint16x8_t halves[2][3] = {
            {vmovl_u8(vget_low_u8(blue)), vmovl_u8(vget_low_u8(green)), vmovl_u8(vget_low_u8(red))},
            {vmovl_high_u8(blue), vmovl_high_u8(green), vmovl_high_u8(red)}};
        uint16x8_t grey[2];
        for (std::size_t h = 0; h < 2; ++h) {
            const uint16x8_t* c = halves[h];
            uint32x4_t low = vmull_n_u16(vget_low_u16(c[0]), kBlueWeight);
            low = vmlal_n_u16(low, vget_low_u16(c[1]), kGreenWeight);
            low = vmlal_n_u16(low, vget_low_u16(c[2]), kRedWeight);
            uint32x4_t high = vmull_high_n_u16(c[0], kBlueWeight);
            high = vmlal_high_n_u16(high, c[1], kGreenWeight);
            high = vmlal_high_n_u16(high, c[2], kRedWeight);
            grey[h] = vcombine_u16(vrshrn_n_u32(low, kGreyShift), vrshrn_n_u32(high, kGreyShift));
        }
        vst1q_u8(dst + x, vcombine_u8(vmovn_u16(grey[0]), vmovn_u16(grey[1])));
    }
    grey_dispatch(src + Channels * x, n - x, order, dst + x);
}

void grey_row_neon(const std::uint8_t* src, std::size_t n, PixelOrder order, std::uint8_t* dst) {
    switch (order) {
        case PixelOrder::bgr:
            grey_row_neon_pixels<3, 0>(src, n, order, dst);
            break;
        case PixelOrder::rgb:
            grey_row_neon_pixels<3, 2>(src, n, order, dst);
            break;
        case PixelOrder::bgra:
            grey_row_neon_pixels<4, 0>(src, n, order, dst);
            break;
        case PixelOrder::rgba:
            grey_row_neon_pixels<4, 2>(src, n, order, dst);
            break;
        case PixelOrder::grey:
            std::memcpy(dst, src, n);
            break;
    }
}

// band[x] += lut[src[x]], 16 pixels per step: the 256-entry table is four 64-byte quarters;
// vqtbl4q looks an index up in the first, each vqtbx4q in the next one after subtracting 64
// (indices outside a quarter leave the lane as it is), then the bytes are widened onto the band.
void accumulate_lut_row_neon(const std::uint8_t* src, std::size_t n, const std::uint8_t* lut, std::uint16_t* band) {
    const uint8x16x4_t quarter[4] = {vld1q_u8_x4(lut), vld1q_u8_x4(lut + 64), vld1q_u8_x4(lut + 128),
                                     vld1q_u8_x4(lut + 192)};
    const uint8x16_t step = vdupq_n_u8(64);
    std::size_t x = 0;
    for (; x + 16 <= n; x += 16) {
        uint8x16_t index = vld1q_u8(src + x);
        uint8x16_t value = vqtbl4q_u8(quarter[0], index);
        index = vsubq_u8(index, step);
        value = vqtbx4q_u8(value, quarter[1], index);
        index = vsubq_u8(index, step);
        value = vqtbx4q_u8(value, quarter[2], index);
        index = vsubq_u8(index, step);
        value = vqtbx4q_u8(value, quarter[3], index);
        vst1q_u16(band + x, vaddw_u8(vld1q_u16(band + x), vget_low_u8(value)));
        vst1q_u16(band + x + 8, vaddw_high_u8(vld1q_u16(band + x + 8), value));
    }
    for (; x < n; ++x) band[x] = static_cast<std::uint16_t>(band[x] + lut[src[x]]);
}

// Column prefix sums, 4 per step: two lane shifts (vextq against zero) and adds, plus the
// running total of earlier steps.
void prefix_row_neon(const std::uint16_t* band, std::size_t n, std::uint32_t* prefix) {
    prefix[0] = 0;
    const uint32x4_t zero = vdupq_n_u32(0);
    uint32x4_t carry = zero;
    std::size_t x = 0;
    for (; x + 4 <= n; x += 4) {
        uint32x4_t v = vmovl_u16(vld1_u16(band + x));
        v = vaddq_u32(v, vextq_u32(zero, v, 3));
        v = vaddq_u32(v, vextq_u32(zero, v, 2));
        v = vaddq_u32(v, carry);
        vst1q_u32(prefix + x + 1, v);
        carry = vdupq_laneq_u32(v, 3);
    }
    std::uint32_t running = prefix[x];
    for (; x < n; ++x) {
        running += band[x];
        prefix[x + 1] = running;
    }
}
#endif

}  // namespace

const PrepareKernels& prepare_kernels_scalar() noexcept {
    static const PrepareKernels kernels{grey_row_scalar,           histogram_row,     accumulate_row_scalar,
                                        accumulate_lut_row_scalar, prefix_row_scalar, "scalar"};
    return kernels;
}

#if NIGHTLOC_X86_KERNELS
const PrepareKernels& prepare_kernels_sse2() noexcept {
    static const PrepareKernels kernels{grey_row_baseline,           histogram_row,       accumulate_row_baseline,
                                        accumulate_lut_row_baseline, prefix_row_baseline, "sse2"};
    return kernels;
}

const PrepareKernels& prepare_kernels_avx2() noexcept {
    static const PrepareKernels kernels{grey_row_avx2_intrinsics,  histogram_row,   accumulate_row_avx2,
                                        accumulate_lut_row_gather, prefix_row_avx2, "avx2"};
    return kernels;
}

const PrepareKernels& prepare_kernels_avx512bw() noexcept {
    static const PrepareKernels avx512{grey_row_avx512_intrinsics, histogram_row,     accumulate_row_avx512,
                                       accumulate_lut_row_gather,  prefix_row_avx512, "avx512bw"};
    static const PrepareKernels avx512_vbmi{grey_row_vbmi,           histogram_row,     accumulate_row_avx512,
                                            accumulate_lut_row_vbmi, prefix_row_avx512, "avx512bw+vbmi"};
    return cpu_has_vbmi() ? avx512_vbmi : avx512;
}
#endif

#if NIGHTLOC_ARM_KERNELS
const PrepareKernels& prepare_kernels_neon() noexcept {
    // (the plain band add is auto-vectorized; the dot product does not help these passes)
    static const PrepareKernels kernels{grey_row_neon,           histogram_row,   accumulate_row_baseline,
                                        accumulate_lut_row_neon, prefix_row_neon, "neon"};
    return kernels;
}
#endif

const PrepareKernels& prepare_kernels(SimdBackend backend) noexcept { return simd_path(backend).prepare_kernels(); }

}  // namespace nightloc::detail
