// Scalar reference kernel: one byte at a time, auto-vectorization disabled so that it measures
// (and tests) plain scalar code whatever the compiler flags.
#include <cstdlib>

#include "matching/sad_kernels.hpp"

namespace nightloc::detail {

#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("no-tree-vectorize")))
#endif
void sad_copies_scalar(const std::uint8_t* copies, std::size_t stride, std::size_t n_copies, const std::uint8_t* refs,
                       std::size_t ref_stride, std::size_t n_refs, std::size_t pixels, std::uint32_t* out,
                       std::size_t out_stride) {
    for (std::size_t i = 0; i < n_refs; ++i) {
        const std::uint8_t* ref = refs + i * ref_stride;
        for (std::size_t j = 0; j < n_copies; ++j) {
            const std::uint8_t* copy = copies + j * stride;
            std::uint32_t sum = 0;
#if defined(__clang__)
#pragma clang loop vectorize(disable)
#endif
            for (std::size_t p = 0; p < pixels; ++p) {
                sum += static_cast<std::uint32_t>(std::abs(int{copy[p]} - int{ref[p]}));
            }
            out[i * out_stride + j] = sum;
        }
    }
}

}  // namespace nightloc::detail
