// The SIMD path registry (internal header simd_paths.hpp): its entries agree with the public path
// list and with the dispatch, every entry names a complete set of kernels, each entry's copies
// kernel gives the sums of a plain loop, and the kernel tables (preparation, float kernels) follow
// the entry.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "check.hpp"
#include "common/float_kernel_table.hpp"
#include "common/simd_paths.hpp"
#include "matching/query_plan.hpp"
#include "matching/sad_kernels.hpp"
#include "nightloc/simd.hpp"
#include "preparation/prepare_kernels.hpp"

namespace {

using nightloc::SimdBackend;
using nightloc::detail::FloatKernelWidth;
using nightloc::detail::SimdPath;

// Position of a path in the public name table (its order: slowest first per architecture).
std::size_t name_index(SimdBackend backend) {
    std::size_t i = 0;
    for (const nightloc::SimdBackendName& entry : nightloc::kSimdBackendNames) {
        if (entry.backend == backend) return i;
        ++i;
    }
    return i;
}

void test_entries_agree_with_the_public_list() {
    const auto paths = nightloc::detail::simd_paths();
    CHECK(paths.begin() != paths.end());
    CHECK(paths.begin()->backend == SimdBackend::scalar);
    std::size_t previous = 0;
    std::vector<SimdBackend> supported;
    for (const SimdPath& path : paths) {
        const std::size_t index = name_index(path.backend);
        CHECK(index < std::size(nightloc::kSimdBackendNames));
        CHECK(path.backend == SimdBackend::scalar || index > previous);  // in the public order, each once
        previous = index;
        CHECK(nightloc::detail::find_simd_path(path.backend) == &path);
        CHECK(&nightloc::detail::simd_path(path.backend) == &path);
        CHECK(path.cpu_supports != nullptr && path.sad_copies != nullptr && path.prepare_kernels != nullptr);
        CHECK((path.sad_all_shifts == nullptr) == (path.sad_offsets == nullptr));
        CHECK(path.alignment >= 1 && path.alignment <= nightloc::detail::kChunk &&
              (path.alignment & (path.alignment - 1)) == 0);
        if (path.cpu_supports()) supported.push_back(path.backend);
    }
    CHECK(supported == nightloc::supported_simd_backends());
    CHECK(supported.back() == nightloc::best_simd_backend());
    // A path of another architecture is not in this build's registry and not supported.
#if NIGHTLOC_X86_KERNELS
    const SimdBackend foreign = SimdBackend::neon;
#else
    const SimdBackend foreign = SimdBackend::avx2;
#endif
    CHECK(nightloc::detail::find_simd_path(foreign) == nullptr);
    CHECK(!nightloc::simd_backend_supported(foreign));
    CHECK(&nightloc::detail::simd_path(foreign) == paths.begin());  // falls back to scalar
}

// Each supported entry's copies kernel against a plain loop: rolled copies of one query, unaligned
// reference stride, a pixel count that is not a multiple of the vector width.
void test_copies_kernels_against_a_plain_loop() {
    std::mt19937 rng(11);
    const std::size_t h = 7, w = 40, pixels = h * w, n_copies = 5, n_refs = 19, ref_stride = pixels + 3;
    const std::size_t stride = nightloc::detail::round_up(pixels, nightloc::detail::kChunk);
    nightloc::detail::AlignedBytes copies;  // 64-byte aligned, zero padding after each copy
    copies.assign_zero(n_copies * stride);
    std::vector<std::uint8_t> query(pixels), refs(n_refs * ref_stride);
    for (auto& v : query) v = static_cast<std::uint8_t>(rng());
    for (auto& v : refs) v = static_cast<std::uint8_t>(rng());
    for (std::size_t j = 0; j < n_copies; ++j) {
        for (std::size_t r = 0; r < h; ++r)
            for (std::size_t c = 0; c < w; ++c) copies.data()[j * stride + r * w + c] = query[r * w + (c + 3 * j) % w];
    }
    std::vector<std::uint32_t> expected(n_refs * n_copies, 0);
    for (std::size_t i = 0; i < n_refs; ++i)
        for (std::size_t j = 0; j < n_copies; ++j)
            for (std::size_t p = 0; p < pixels; ++p) {
                const int a = copies.data()[j * stride + p], b = refs[i * ref_stride + p];
                expected[i * n_copies + j] += static_cast<std::uint32_t>(a > b ? a - b : b - a);
            }
    for (const SimdPath& path : nightloc::detail::simd_paths()) {
        if (!path.cpu_supports()) continue;
        std::vector<std::uint32_t> out(n_refs * n_copies, 0xdeadbeef);
        path.sad_copies(copies.data(), stride, n_copies, refs.data(), ref_stride, n_refs, pixels, out.data(), n_copies);
        std::printf("copies kernel of %s\n", nightloc::simd_backend_name(path.backend));
        CHECK(out == expected);
    }
}

// The preparation and float kernel tables are the ones the entry names.
void test_tables_follow_the_entry() {
    const int scalar = 0, baseline = 1, avx2 = 2, avx512 = 3;
    const nightloc::detail::FloatKernelTables<int> tables{scalar, baseline, &avx2, &avx512};
    for (const SimdPath& path : nightloc::detail::simd_paths()) {
        CHECK(&nightloc::detail::prepare_kernels(path.backend) == &path.prepare_kernels());
        CHECK(tables.of(path.backend) == static_cast<int>(path.float_kernels));
    }
    CHECK(std::string(nightloc::detail::prepare_kernels(SimdBackend::scalar).name) == "scalar");
    CHECK(tables.of(SimdBackend::scalar) == static_cast<int>(FloatKernelWidth::scalar));
}

}  // namespace

int main() {
    test_entries_agree_with_the_public_list();
    test_copies_kernels_against_a_plain_loop();
    test_tables_follow_the_entry();
    return nightloc_test::check_summary();
}
