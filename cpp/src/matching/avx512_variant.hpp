// Internal: the two accumulations of the avx512bw path's all-shift and offsets SAD kernels, and
// the once-per-process choice between them (avx512_variant.cpp). Both give the same sums; which
// is faster depends on the CPU. The choice, in order: NIGHTLOC_AVX512_VNNI=0 or 1 forces it; a
// CPU without AVX-512 VNNI runs vpaddw; a CPU family listed in avx512_sad_variant_of_family()
// takes the table's variant; every other CPU (or NIGHTLOC_AVX512_VNNI=measure) times both once
// at first use (3.5 M byte comparisons per call, best of 15 alternating rounds) and keeps vnni
// only when it is at least 2 % faster. The Python module exposes these functions (tests force
// each variant; `nightloc info` reports the choice); docs/performance.md has the figures.
#pragma once

#include <string>

namespace nightloc {

/// How the avx512bw path's all-shift SAD kernel accumulates (bit-identical results).
enum class Avx512SadVariant : int { vpaddw = 0, vnni = 1 };

/// "vpaddw" or "vnni".
const char* avx512_sad_variant_name(Avx512SadVariant variant) noexcept;

/// Whether the variant can run here (vpaddw: AVX-512BW; vnni: also AVX-512 VNNI).
bool avx512_sad_variant_supported(Avx512SadVariant variant) noexcept;

/// The variant the avx512bw path uses (decided at the first call; see above). Only meaningful
/// where avx512bw is supported.
Avx512SadVariant avx512_sad_variant();

/// Why that variant: the override, the CPU family table entry, or the measurement's outcome.
std::string avx512_sad_variant_reason();

/// Forces a variant for the whole process (tests, benchmarks). Throws std::invalid_argument
/// when the CPU cannot run it.
void set_avx512_sad_variant(Avx512SadVariant variant);

/// Returns to the per-CPU choice.
void reset_avx512_sad_variant() noexcept;

namespace detail {

/// The CPU family table of the variant choice: the Avx512SadVariant value for a CPUID vendor
/// string and family, or -1 (not listed: measure); `why` receives the table's reason.
int avx512_sad_variant_of_family(const char* vendor, unsigned family, const char** why) noexcept;

}  // namespace detail
}  // namespace nightloc
