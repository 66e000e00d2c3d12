// The two AVX-512 all-shift kernels (vpaddw and VNNI vpdpwssd accumulation) against a plain
// loop, called directly (internal header): both variants are checked on any CPU that has them,
// whichever one the library picks at run time. Extreme images (0 against 255) reach the largest
// word totals the packed VNNI lanes must hold; tall images cross the 32-chunk flush; pixel
// counts that are not a multiple of 64 take the masked tail.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "check.hpp"
#include "matching/avx512_variant.hpp"
#include "matching/sad_kernels.hpp"
#include "nightloc/sad.hpp"
#include "nightloc/simd.hpp"

#if NIGHTLOC_X86_KERNELS
namespace {

using nightloc::detail::kChunk;
using nightloc::detail::round_up;

struct Case {
    std::size_t height, width, n_refs;
    int fill;  // -1: random bytes; 0: query 0, references 255; 1: query 255, references 0
};

// Sum of |query rolled by k - ref| for every shift k: rolled[y][x] = query[y][(x + k) % width].
std::vector<std::uint32_t> plain_sums(const std::vector<std::uint8_t>& query, const std::uint8_t* ref, std::size_t h,
                                      std::size_t w) {
    std::vector<std::uint32_t> sums(w, 0);
    for (std::size_t k = 0; k < w; ++k) {
        for (std::size_t y = 0; y < h; ++y) {
            for (std::size_t x = 0; x < w; ++x) {
                const int a = query[y * w + (x + k) % w], b = ref[y * w + x];
                sums[k] += static_cast<std::uint32_t>(a > b ? a - b : b - a);
            }
        }
    }
    return sums;
}

// The interleaved layout of sad_kernels.hpp: chunk c of the copy rolled by 2m at (c * w/2 + m) * 64.
std::vector<std::uint8_t> interleave(const std::vector<std::uint8_t>& query, std::size_t h, std::size_t w) {
    const std::size_t pixels = h * w, stride = round_up(pixels, kChunk), n_chunks = stride / kChunk;
    std::vector<std::uint8_t> out(stride * (w / 2) + kChunk, 0), rolled(stride);
    for (std::size_t m = 0; m < w / 2; ++m) {
        std::fill(rolled.begin(), rolled.end(), std::uint8_t{0});
        for (std::size_t y = 0; y < h; ++y) {
            for (std::size_t x = 0; x < w; ++x) rolled[y * w + x] = query[y * w + (x + 2 * m) % w];
        }
        for (std::size_t c = 0; c < n_chunks; ++c)
            std::memcpy(&out[(c * (w / 2) + m) * kChunk], &rolled[c * kChunk], kChunk);
    }
    return out;
}

void check_kernel(nightloc::detail::AllShiftKernel kernel, const char* name, const Case& c, std::mt19937& rng) {
    const std::size_t h = c.height, w = c.width, pixels = h * w;
    std::vector<std::uint8_t> query(pixels), refs(c.n_refs * pixels);
    std::uniform_int_distribution<int> byte(0, 255);
    for (auto& v : query) v = static_cast<std::uint8_t>(c.fill < 0 ? byte(rng) : 255 * c.fill);
    for (auto& v : refs) v = static_cast<std::uint8_t>(c.fill < 0 ? byte(rng) : 255 * (1 - c.fill));

    // The interleaved buffer must be 64-byte aligned: copy it into an aligned allocation.
    const std::vector<std::uint8_t> layout = interleave(query, h, w);
    std::vector<std::uint8_t> storage(layout.size() + kChunk);
    auto* aligned = reinterpret_cast<std::uint8_t*>(round_up(reinterpret_cast<std::uintptr_t>(storage.data()), kChunk));
    std::memcpy(aligned, layout.data(), layout.size());

    std::vector<std::uint32_t> table(c.n_refs * w, 0);
    kernel(aligned, w, refs.data(), pixels, c.n_refs, pixels, table.data(), w, nullptr, nullptr, nullptr);

    // Min mode over the odd shifts only (bit 4l + 1 of each group mask: shift 8g + 2l + 1).
    std::vector<std::uint16_t> odd(w / 8, 0x2222);
    std::vector<std::uint32_t> best(c.n_refs);
    std::vector<std::int32_t> best_shift(c.n_refs);
    kernel(aligned, w, refs.data(), pixels, c.n_refs, pixels, nullptr, 0, odd.data(), best.data(), best_shift.data());

    bool same = true;
    for (std::size_t i = 0; i < c.n_refs; ++i) {
        const std::vector<std::uint32_t> expected = plain_sums(query, refs.data() + i * pixels, h, w);
        if (!std::equal(expected.begin(), expected.end(), table.begin() + static_cast<std::ptrdiff_t>(i * w)))
            same = false;
        std::uint32_t lowest = UINT32_MAX;
        std::int32_t at = -1;
        for (std::size_t k = 1; k < w; k += 2) {
            if (expected[k] < lowest) lowest = expected[k], at = static_cast<std::int32_t>(k);
        }
        if (best[i] != lowest || best_shift[i] != at) same = false;
    }
    if (!same)
        std::fprintf(stderr, "%s: %zux%zu, %zu references, fill %d differs from the plain loop\n", name, h, w, c.n_refs,
                     c.fill);
    CHECK(same);
}

// The offsets kernels (non-wrapping column offsets) against a plain loop: copies at even offsets
// e0 + 2m, zero outside the image, chunk-major; slots e0 + first + j. References are bands of
// taller images (ref_stride > pixels), as the window engine passes them.
void check_offsets_kernel(nightloc::detail::OffsetsKernel kernel, const char* name, std::size_t h, std::size_t w,
                          std::int32_t e0, std::size_t first, std::size_t n_slots, int fill, std::mt19937& rng) {
    const std::size_t pixels = h * w, ref_stride = pixels + 3 * w, n_refs = 3;
    const std::size_t n_copies = (first + n_slots - 1) / 2 + 2;
    std::vector<std::uint8_t> query(pixels), refs(n_refs * ref_stride);
    std::uniform_int_distribution<int> byte(0, 255);
    for (auto& v : query) v = static_cast<std::uint8_t>(fill < 0 ? byte(rng) : 255 * fill);
    for (auto& v : refs) v = static_cast<std::uint8_t>(fill < 0 ? byte(rng) : 255 * (1 - fill));
    const std::size_t stride = round_up(pixels, kChunk), n_chunks = stride / kChunk;
    std::vector<std::uint8_t> storage(stride * n_copies + kChunk, 0), copy(stride);
    auto* layout = reinterpret_cast<std::uint8_t*>(round_up(reinterpret_cast<std::uintptr_t>(storage.data()), kChunk));
    for (std::size_t m = 0; m < n_copies; ++m) {
        const long offset = e0 + 2 * static_cast<long>(m);
        std::fill(copy.begin(), copy.end(), std::uint8_t{0});
        for (std::size_t y = 0; y < h; ++y) {
            for (std::size_t x = 0; x < w; ++x) {
                const long xq = static_cast<long>(x) + offset;
                if (xq >= 0 && xq < static_cast<long>(w)) copy[y * w + x] = query[y * w + static_cast<std::size_t>(xq)];
            }
        }
        for (std::size_t c = 0; c < n_chunks; ++c)
            std::memcpy(layout + (c * n_copies + m) * kChunk, &copy[c * kChunk], kChunk);
    }
    std::vector<std::uint32_t> out(n_refs * n_slots, 0);
    kernel(layout, n_copies, first, n_slots, refs.data() + w, ref_stride, n_refs, pixels, out.data(), n_slots);
    bool same = true;
    for (std::size_t i = 0; i < n_refs; ++i) {
        const std::uint8_t* ref = refs.data() + w + i * ref_stride;
        for (std::size_t j = 0; j < n_slots; ++j) {
            const long offset = e0 + static_cast<long>(first + j);
            std::uint32_t sum = 0;
            for (std::size_t y = 0; y < h; ++y) {
                for (std::size_t x = 0; x < w; ++x) {
                    const long xq = static_cast<long>(x) + offset;
                    const int q =
                        xq >= 0 && xq < static_cast<long>(w) ? query[y * w + static_cast<std::size_t>(xq)] : 0;
                    sum += static_cast<std::uint32_t>(std::abs(q - int{ref[y * w + x]}));
                }
            }
            same = same && out[i * n_slots + j] == sum;
        }
    }
    if (!same)
        std::fprintf(stderr, "%s offsets: %zux%zu e0 %d, %zu slots, fill %d differ\n", name, h, w, e0, n_slots, fill);
    CHECK(same);
}

// The CPU family table: AMD Zen 4 (family 19h) takes vpaddw; Intel, Zen 5 and others are measured.
void test_family_table() {
    const char* why = nullptr;
    CHECK(nightloc::detail::avx512_sad_variant_of_family("GenuineIntel", 0x6, &why) == -1);
    CHECK(nightloc::detail::avx512_sad_variant_of_family("AuthenticAMD", 0x19, &why) ==
          static_cast<int>(nightloc::Avx512SadVariant::vpaddw));
    CHECK(std::string(why).find("Zen 4") != std::string::npos);
    CHECK(nightloc::detail::avx512_sad_variant_of_family("AuthenticAMD", 0x1a, &why) == -1);  // Zen 5: measure
    CHECK(nightloc::detail::avx512_sad_variant_of_family("HygonGenuine", 0x18, &why) == -1);
}

// The whole engine (min mode and table) on the avx512bw path with each variant forced, against
// the plain loop; and the choice made at first use (this process: the start-up measurement).
void test_engine_with_each_variant(std::mt19937& rng) {
    const std::string reason = nightloc::avx512_sad_variant_reason();
    std::printf("default variant: %s (%s)\n", nightloc::avx512_sad_variant_name(nightloc::avx512_sad_variant()),
                reason.c_str());
    CHECK(reason.rfind("measured at first use", 0) == 0 || reason.rfind("this CPU has no AVX-512 VNNI", 0) == 0);
    const std::size_t h = 24, w = 48, px = h * w, n = 21;
    std::vector<std::uint8_t> query(px), refs(n * px);
    for (auto& v : query) v = static_cast<std::uint8_t>(rng());
    for (auto& v : refs) v = static_cast<std::uint8_t>(rng());
    std::vector<std::int32_t> shifts(w);
    for (std::size_t k = 0; k < w; ++k) shifts[k] = static_cast<std::int32_t>(k);
    nightloc::set_simd_backend(nightloc::SimdBackend::avx512bw);
    for (auto variant : {nightloc::Avx512SadVariant::vpaddw, nightloc::Avx512SadVariant::vnni}) {
        if (!nightloc::avx512_sad_variant_supported(variant)) continue;
        nightloc::set_avx512_sad_variant(variant);
        CHECK(nightloc::avx512_sad_variant() == variant);
        std::vector<std::uint32_t> best(n), table(n * w);
        std::vector<std::int32_t> best_shift(n);
        nightloc::difference_matrix_sums(query.data(), 1, refs.data(), n, h, w, shifts.data(), w, best.data(),
                                         best_shift.data(), 1);
        nightloc::rotational_sad_sums(query.data(), refs.data(), n, h, w, shifts.data(), w, table.data(), 1);
        bool same = true;
        for (std::size_t i = 0; i < n; ++i) {
            const std::vector<std::uint32_t> sums = plain_sums(query, refs.data() + i * px, h, w);
            std::size_t at = 0;
            for (std::size_t k = 1; k < w; ++k) at = sums[k] < sums[at] ? k : at;
            same = same && best[i] == sums[at] && best_shift[i] == static_cast<std::int32_t>(at);
            for (std::size_t k = 0; k < w; ++k) same = same && table[i * w + k] == sums[k];
        }
        CHECK(same);
    }
    nightloc::reset_avx512_sad_variant();
    nightloc::reset_simd_backend();
}

}  // namespace

int main() {
    test_family_table();
    if (!__builtin_cpu_supports("avx512f") || !__builtin_cpu_supports("avx512bw")) {
        std::printf("no AVX-512BW on this CPU: nothing to check\n");
        return nightloc_test::check_summary();
    }
    const bool vnni = __builtin_cpu_supports("avx512vnni");
    std::mt19937 rng(7);
    const Case cases[] = {
        {24, 48, 5, -1}, {24, 48, 3, 0},  {24, 48, 3, 1},  // the paper's size; the largest totals
        {5, 8, 4, -1},   {3, 40, 2, -1},                   // one chunk, masked tails
        {64, 64, 2, 0},  {64, 64, 3, -1},                  // 64 chunks: two flushes at the extreme
        {6, 384, 2, -1}, {9, 384, 2, 1},                   // the widest panorama (48 groups of copies)
        {33, 96, 2, 0},                                    // 49.5 chunks, extreme, tail after a flush
    };
    for (const Case& c : cases) {
        check_kernel(nightloc::detail::sad_all_shifts_avx512bw, "avx512bw", c, rng);
        if (vnni) check_kernel(nightloc::detail::sad_all_shifts_avx512vnni, "avx512vnni", c, rng);
    }
    struct OffsetCase {
        std::size_t h, w;
        std::int32_t e0;
        std::size_t first, n_slots;
        int fill;
    };
    const OffsetCase offset_cases[] = {
        {23, 48, -8, 0, 17, -1},  {22, 48, -8, 0, 17, 0},  {23, 48, -8, 0, 17, 1},  // +-8 columns, extremes
        {24, 48, -2, 1, 3, -1},   {24, 48, -6, 1, 11, -1},                          // +-1, +-5 (odd: first 1)
        {24, 48, -48, 1, 95, -1},                                                   // +-47: 49 copies, groups
        {70, 64, -4, 0, 9, 0},    {70, 64, -12, 0, 25, 1},                          // flushes, 14 copies: 12 + 2
        {3, 8, -8, 1, 15, -1},                                                      // one masked chunk
    };
    for (const OffsetCase& c : offset_cases) {
        check_offsets_kernel(nightloc::detail::sad_offsets_avx512bw, "avx512bw", c.h, c.w, c.e0, c.first, c.n_slots,
                             c.fill, rng);
        if (vnni) {
            check_offsets_kernel(nightloc::detail::sad_offsets_avx512vnni, "avx512vnni", c.h, c.w, c.e0, c.first,
                                 c.n_slots, c.fill, rng);
        }
    }
    std::printf("checked the vpaddw kernel%s\n", vnni ? " and the VNNI kernel" : " (no VNNI on this CPU)");
    setenv("NIGHTLOC_AVX512_VNNI", "measure", 1);  // before the first use: exercise the measurement
    test_engine_with_each_variant(rng);
    return nightloc_test::check_summary();
}
#else
int main() {
    std::printf("no x86 kernels in this build: nothing to check\n");
    return nightloc_test::check_summary();
}
#endif
