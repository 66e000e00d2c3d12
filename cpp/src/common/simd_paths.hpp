// Internal: the SIMD path registry. One entry per path compiled into this build holds everything
// the library varies by path: the CPU check, the kernels (SAD, frame preparation, and which
// compilation of the float kernels), the vector alignment the SAD engine aligns bands to, and
// whether it stages unaligned references. The dispatch code reads entries; it never switches on
// a path. A new path is its enum value and name (nightloc/simd.hpp), its kernel file, one entry
// in cpp/src/dispatch/simd_paths.cpp (the table) and a build line (cpp/CMakeLists.txt).
#pragma once

#include <cstddef>

#include "common/arch.hpp"
#include "common/kernel_signatures.hpp"
#include "nightloc/simd.hpp"

namespace nightloc::detail {

struct PrepareKernels;

/// Which compilation of the float kernels (heat maps, grid filter, route likelihood; see
/// float_kernel_table.hpp) a path runs: scalar (no auto-vectorization), the architecture's
/// baseline (SSE2 or NEON: 4 lanes), AVX2 (8 lanes) or AVX-512F (16 lanes).
enum class FloatKernelWidth : int { scalar = 0, baseline = 1, avx2 = 2, avx512 = 3 };

struct SimdPath {
    /// The public identity (nightloc/simd.hpp; its name is in kSimdBackendNames).
    SimdBackend backend;
    /// True when the running CPU can execute the path's kernels.
    bool (*cpu_supports)() noexcept;
    /// SAD against rolled or offset copies of a query (every path has one).
    CopiesKernel sad_copies;
    /// SAD at every shift from the interleaved query layout, or nullptr (then the copies kernel
    /// serves all shifts). A function: the AVX-512 kernel depends on the variant in use.
    AllShiftKernel (*sad_all_shifts)();
    /// SAD at consecutive non-wrapping offsets from the offsets layout, or nullptr.
    OffsetsKernel (*sad_offsets)();
    /// Vector width in bytes: the SAD engine starts each non-wrapping band of references at a
    /// multiple of it (1: no alignment).
    std::size_t alignment;
    /// Whether a forward window with few queries copies each block of unaligned references to an
    /// aligned buffer before the copies kernel reads it (false: read in place).
    bool stage_references;
    /// The row kernels of frame preparation (prepare_kernels.hpp).
    const PrepareKernels& (*prepare_kernels)() noexcept;
    /// The float kernels' compilation.
    FloatKernelWidth float_kernels;
};

/// The registry's entries, slowest first within each architecture; the first is scalar.
struct SimdPathRange {
    const SimdPath* first;
    const SimdPath* last;
    const SimdPath* begin() const noexcept { return first; }
    const SimdPath* end() const noexcept { return last; }
};
SimdPathRange simd_paths() noexcept;

/// The entry of a path, or nullptr when the path is not compiled into this build.
const SimdPath* find_simd_path(SimdBackend backend) noexcept;

/// The entry of a path compiled into this build (scalar's entry for any other).
const SimdPath& simd_path(SimdBackend backend) noexcept;

/// The entry of the active path (nightloc::active_simd_backend()).
const SimdPath& active_simd_path() noexcept;

}  // namespace nightloc::detail
