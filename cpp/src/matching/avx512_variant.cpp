// The choice between the two accumulations of the AVX-512 all-shift and offsets SAD kernels
// (avx512_variant.hpp). vpdpwssd (VNNI) runs on another execution port than vdbpsadbw on Intel
// cores, where the faster of the two changes with the host and its load; on AMD Zen 4 vpaddw is
// faster by a wide margin (docs/performance.md). So a CPU family whose faster variant is known
// comes from a table; every other CPU with VNNI is measured once, at first use.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "matching/avx512_variant.hpp"

#include "common/arch.hpp"
#include "matching/query_plan.hpp"
#include "matching/sad_kernels.hpp"
#include "nightloc/simd.hpp"

#if NIGHTLOC_X86_KERNELS
#include <cpuid.h>
#endif

namespace nightloc {
namespace {

struct Choice {
    Avx512SadVariant variant = Avx512SadVariant::vpaddw;
    std::string reason;
};

constexpr int kNotForced = -1;
std::atomic<int> g_forced{kNotForced};

#if NIGHTLOC_X86_KERNELS

bool cpu_has_avx512bw() noexcept { return simd_backend_supported(SimdBackend::avx512bw); }
bool cpu_has_vnni() noexcept { return cpu_has_avx512bw() && __builtin_cpu_supports("avx512vnni"); }

struct CpuIdentity {
    std::string vendor;  // "GenuineIntel", "AuthenticAMD", ...
    unsigned family = 0, model = 0;
    std::string text() const {
        char buffer[96];
        std::snprintf(buffer, sizeof buffer, "%s family %xh model %xh", vendor.c_str(), family, model);
        return buffer;
    }
};

CpuIdentity cpu_identity() {
    CpuIdentity id;
    unsigned a = 0, b = 0, c = 0, d = 0;
    if (__get_cpuid(0, &a, &b, &c, &d)) {
        char vendor[13];
        std::memcpy(vendor, &b, 4);
        std::memcpy(vendor + 4, &d, 4);
        std::memcpy(vendor + 8, &c, 4);
        vendor[12] = '\0';
        id.vendor = vendor;
    }
    if (__get_cpuid(1, &a, &b, &c, &d)) {
        const unsigned base_family = (a >> 8) & 0xf, base_model = (a >> 4) & 0xf;
        id.family = base_family == 0xf ? base_family + ((a >> 20) & 0xff) : base_family;
        id.model = base_family == 0x6 || base_family == 0xf ? base_model | (((a >> 16) & 0xf) << 4) : base_model;
    }
    return id;
}

// Both variants on a small paper-sized problem (48x24, all 48 shifts, 64 references: 3.5 M byte
// comparisons per call), alternating, best of 15 rounds of 4 calls. VNNI must win by 2 %: where
// the two are this close (Intel), the faster one in the engine depends on the number of references
// (docs/performance.md), and noise would otherwise flip the choice from run to run.
Choice measure(const CpuIdentity& cpu) {
    constexpr std::size_t kHeight = 24, kWidth = 48, kPixels = kHeight * kWidth, kRefs = 64;
    const std::size_t stride = detail::round_up(kPixels, detail::kChunk);
    detail::AlignedBytes layout;
    layout.assign_zero(stride * kWidth / 2);
    std::vector<std::uint8_t> query(kPixels), refs(kRefs * kPixels), rolled(stride);
    std::uint32_t state = 12345;
    auto next_byte = [&state] {
        state = state * 1664525u + 1013904223u;
        return static_cast<std::uint8_t>(state >> 24);
    };
    for (auto& v : query) v = next_byte();
    for (auto& v : refs) v = next_byte();
    detail::interleave_query(query.data(), kHeight, kWidth, rolled.data(), layout.data());
    const std::vector<std::uint16_t> selected(kWidth / 8, 0x3333);  // every shift
    std::vector<std::uint32_t> sums(kRefs);
    std::vector<std::int32_t> shifts(kRefs);
    auto seconds = [&](detail::AllShiftKernel kernel) {
        const auto start = std::chrono::steady_clock::now();
        for (int call = 0; call < 4; ++call) {
            kernel(layout.data(), kWidth, refs.data(), kPixels, kRefs, kPixels, nullptr, 0, selected.data(),
                   sums.data(), shifts.data());
        }
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    seconds(detail::sad_all_shifts_avx512bw);  // warm-up: caches, and the AVX-512 clock licence
    seconds(detail::sad_all_shifts_avx512vnni);
    double vpaddw = std::numeric_limits<double>::infinity(), vnni = vpaddw;
    for (int round = 0; round < 15; ++round) {
        if (round % 2 == 0) {
            vpaddw = std::min(vpaddw, seconds(detail::sad_all_shifts_avx512bw));
            vnni = std::min(vnni, seconds(detail::sad_all_shifts_avx512vnni));
        } else {
            vnni = std::min(vnni, seconds(detail::sad_all_shifts_avx512vnni));
            vpaddw = std::min(vpaddw, seconds(detail::sad_all_shifts_avx512bw));
        }
    }
    const bool vnni_wins = vnni * 1.02 < vpaddw;
    const double lead = 100.0 * (vpaddw / vnni - 1.0);  // how much faster vnni was, in percent
    char measured[160];
    std::snprintf(measured, sizeof measured, ": vnni %.1f %% %s than vpaddw on %zu references%s",
                  lead >= 0 ? lead : -lead, lead >= 0 ? "faster" : "slower", kRefs,
                  vnni_wins ? "" : " (it must win by 2 %)");
    return {vnni_wins ? Avx512SadVariant::vnni : Avx512SadVariant::vpaddw,
            "measured at first use on " + cpu.text() + measured};
}

Choice choose() {
    if (!cpu_has_avx512bw())
        return {Avx512SadVariant::vpaddw, "this CPU has no AVX-512BW (the avx512bw path is unused)"};
    if (!cpu_has_vnni()) return {Avx512SadVariant::vpaddw, "this CPU has no AVX-512 VNNI"};
    const CpuIdentity cpu = cpu_identity();
    const char* env = std::getenv("NIGHTLOC_AVX512_VNNI");
    const std::string request = env != nullptr ? env : "";
    if (request == "0") return {Avx512SadVariant::vpaddw, "NIGHTLOC_AVX512_VNNI=0"};
    if (request == "1") return {Avx512SadVariant::vnni, "NIGHTLOC_AVX512_VNNI=1"};
    if (request == "measure") return measure(cpu);
    const char* why = nullptr;
    const int listed = detail::avx512_sad_variant_of_family(cpu.vendor.c_str(), cpu.family, &why);
    if (listed >= 0) return {static_cast<Avx512SadVariant>(listed), "CPU table: " + cpu.text() + " (" + why + ")"};
    return measure(cpu);
}

#else

bool cpu_has_avx512bw() noexcept { return false; }
bool cpu_has_vnni() noexcept { return false; }
Choice choose() { return {Avx512SadVariant::vpaddw, "not an x86-64 build (no avx512bw path)"}; }

#endif

const Choice& default_choice() {
    static const Choice choice = choose();  // once per process (thread-safe)
    return choice;
}

}  // namespace

const char* avx512_sad_variant_name(Avx512SadVariant variant) noexcept {
    return variant == Avx512SadVariant::vnni ? "vnni" : "vpaddw";
}

bool avx512_sad_variant_supported(Avx512SadVariant variant) noexcept {
    return variant == Avx512SadVariant::vnni ? cpu_has_vnni() : cpu_has_avx512bw();
}

Avx512SadVariant avx512_sad_variant() {
    const int forced = g_forced.load(std::memory_order_acquire);
    return forced != kNotForced ? static_cast<Avx512SadVariant>(forced) : default_choice().variant;
}

std::string avx512_sad_variant_reason() {
    if (g_forced.load(std::memory_order_acquire) != kNotForced) return "forced by set_avx512_sad_variant";
    return default_choice().reason;
}

void set_avx512_sad_variant(Avx512SadVariant variant) {
    if (!avx512_sad_variant_supported(variant)) {
        throw std::invalid_argument(std::string("the AVX-512 SAD variant '") + avx512_sad_variant_name(variant) +
                                    "' is not supported on this CPU");
    }
    g_forced.store(static_cast<int>(variant), std::memory_order_release);
}

void reset_avx512_sad_variant() noexcept { g_forced.store(kNotForced, std::memory_order_release); }

#if NIGHTLOC_X86_KERNELS
int detail::avx512_sad_variant_of_family(const char* vendor, unsigned family, const char** why) noexcept {
    // Families whose faster variant is known by a wide margin (one thread, 48x24, 48 shifts).
    if (std::strcmp(vendor, "AuthenticAMD") == 0 && family == 0x19) {  // Zen 3 has no AVX-512: Zen 4
        *why = "AMD Zen 4: vpaddw faster by a wide margin";
        return static_cast<int>(Avx512SadVariant::vpaddw);
    }
    *why = "not in the table";  // Intel (the two within a few per cent, host-dependent), AMD Zen 5, others
    return -1;
}

detail::AllShiftKernel detail::avx512_all_shift_kernel() {
    return avx512_sad_variant() == Avx512SadVariant::vnni ? sad_all_shifts_avx512vnni : sad_all_shifts_avx512bw;
}

detail::OffsetsKernel detail::avx512_offsets_kernel() {
    return avx512_sad_variant() == Avx512SadVariant::vnni ? sad_offsets_avx512vnni : sad_offsets_avx512bw;
}
#endif

}  // namespace nightloc
