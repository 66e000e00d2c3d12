// Row kernels of frame preparation, compiled once per SIMD path: the plain loops below are
// compiled for the baseline (sse2), for AVX2 and for AVX-512 with target attributes (the rest of
// the library keeps the baseline ISA), and once with auto-vectorization disabled (scalar). The
// equalization table lookup has a hand-written AVX-512 VBMI kernel (vpermi2b: 64 lookups in a
// 256-entry table per two instructions), used on the avx512bw path when the CPU has VBMI.
// Integer arithmetic only: every path gives the same bytes.
#include "prepare_kernels.hpp"

#include <cstring>

#include "sad_kernels.hpp"  // NIGHTLOC_X86_KERNELS

#if NIGHTLOC_X86_KERNELS
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"  // GCC bug 105593 in the AVX-512 headers
#endif
#include <immintrin.h>
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
        case PixelOrder::bgr: grey_body<3, 0, 2>(src, n, dst); break;
        case PixelOrder::rgb: grey_body<3, 2, 0>(src, n, dst); break;
        case PixelOrder::bgra: grey_body<4, 0, 2>(src, n, dst); break;
        case PixelOrder::rgba: grey_body<4, 2, 0>(src, n, dst); break;
        case PixelOrder::grey: std::memcpy(dst, src, n); break;
    }
}

NL_INLINE void accumulate_body(const std::uint8_t* src, std::size_t n, std::uint16_t* band) {
    for (std::size_t x = 0; x < n; ++x) band[x] = static_cast<std::uint16_t>(band[x] + src[x]);
}

NL_INLINE void accumulate_lut_body(const std::uint8_t* src, std::size_t n, const std::uint8_t* lut,
                                   std::uint16_t* band) {
    for (std::size_t x = 0; x < n; ++x) band[x] = static_cast<std::uint16_t>(band[x] + lut[src[x]]);
}

// Four interleaved sub-histograms, eight pixels per 64-bit load: consecutive equal pixels land in
// different counters, so the increments do not wait on each other.
void histogram_row(const std::uint8_t* src, std::size_t n, std::uint32_t* counts) {
    std::uint32_t* c0 = counts;
    std::uint32_t* c1 = counts + 256;
    std::uint32_t* c2 = counts + 512;
    std::uint32_t* c3 = counts + 768;
    std::size_t x = 0;
    for (; x + 8 <= n; x += 8) {
        std::uint64_t v;
        std::memcpy(&v, src + x, 8);
        ++c0[v & 0xff];
        ++c1[(v >> 8) & 0xff];
        ++c2[(v >> 16) & 0xff];
        ++c3[(v >> 24) & 0xff];
        ++c0[(v >> 32) & 0xff];
        ++c1[(v >> 40) & 0xff];
        ++c2[(v >> 48) & 0xff];
        ++c3[v >> 56];
    }
    for (; x < n; ++x) ++c0[src[x]];
}

#define NL_DEFINE_ROW_KERNELS(suffix, attributes)                                                              \
    attributes void grey_row_##suffix(const std::uint8_t* src, std::size_t n, PixelOrder order,                \
                                      std::uint8_t* dst) {                                                      \
        grey_dispatch(src, n, order, dst);                                                                      \
    }                                                                                                           \
    attributes void accumulate_row_##suffix(const std::uint8_t* src, std::size_t n, std::uint16_t* band) {      \
        accumulate_body(src, n, band);                                                                          \
    }                                                                                                           \
    attributes void accumulate_lut_row_##suffix(const std::uint8_t* src, std::size_t n, const std::uint8_t* lut, \
                                                std::uint16_t* band) {                                          \
        accumulate_lut_body(src, n, lut, band);                                                                 \
    }

#if defined(__GNUC__) && !defined(__clang__)
#define NL_NO_VECTORIZE __attribute__((optimize("no-tree-vectorize")))
#else
#define NL_NO_VECTORIZE
#endif

NL_DEFINE_ROW_KERNELS(scalar, NL_NO_VECTORIZE)
NL_DEFINE_ROW_KERNELS(baseline, )

#if NIGHTLOC_X86_KERNELS
NL_DEFINE_ROW_KERNELS(avx2, __attribute__((target("avx2"))))
NL_DEFINE_ROW_KERNELS(avx512, __attribute__((target("avx512f,avx512bw"))))

// band[x] += lut[src[x]], 64 pixels per step: two vpermi2b look up the lower and the upper half
// of the table (index bits 0-6), the top bit of the index picks one; the bytes are widened to
// 16 bits and added to the band. The last partial step works on masked loads and stores.
__attribute__((target("avx512f,avx512bw,avx512vbmi"))) void accumulate_lut_row_vbmi(const std::uint8_t* src,
                                                                                      std::size_t n,
                                                                                      const std::uint8_t* lut,
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

}  // namespace

const PrepareKernels& prepare_kernels(SimdBackend backend) noexcept {
    static const PrepareKernels scalar{grey_row_scalar, histogram_row, accumulate_row_scalar,
                                       accumulate_lut_row_scalar, "scalar"};
#if NIGHTLOC_X86_KERNELS
    static const PrepareKernels sse2{grey_row_baseline, histogram_row, accumulate_row_baseline,
                                     accumulate_lut_row_baseline, "sse2"};
    static const PrepareKernels avx2{grey_row_avx2, histogram_row, accumulate_row_avx2, accumulate_lut_row_avx2,
                                     "avx2"};
    static const PrepareKernels avx512{grey_row_avx512, histogram_row, accumulate_row_avx512,
                                       accumulate_lut_row_avx512, "avx512bw"};
    static const PrepareKernels avx512_vbmi{grey_row_avx512, histogram_row, accumulate_row_avx512,
                                            accumulate_lut_row_vbmi, "avx512bw+vbmi"};
    switch (backend) {
        case SimdBackend::scalar: return scalar;
        case SimdBackend::sse2: return sse2;
        case SimdBackend::avx2: return avx2;
        case SimdBackend::avx512bw: return cpu_has_vbmi() ? avx512_vbmi : avx512;
    }
    return scalar;
#else
    static const PrepareKernels baseline{grey_row_baseline, histogram_row, accumulate_row_baseline,
                                         accumulate_lut_row_baseline, "baseline"};
    return backend == SimdBackend::scalar ? scalar : baseline;
#endif
}

}  // namespace nightloc::detail
