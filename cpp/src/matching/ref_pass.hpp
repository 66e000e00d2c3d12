// Internal: the references of one pass of a "copies" SAD kernel (sad_x86.cpp, sad_neon.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>

#include "matching/sad_kernels.hpp"

namespace nightloc::detail {

/// References per pass of the copies kernels: each query chunk loaded is compared with this many
/// references before the next one is loaded.
inline constexpr std::size_t kRefsPerPass = 8;

/// The references of one pass, read in chunks of V bytes. A short last pass repeats its last
/// reference (the duplicate sums are computed and discarded). Full chunks are read from row[k],
/// the last partial chunk from tail[k], zero-padded, so that no load reads past a reference. When
/// the pass is reused for many shifts and its references are not V-byte aligned, they are first
/// copied into aligned, zero-padded rows: unaligned vector loads that straddle cache lines cost
/// up to a third of the speed. Aligned references are read where they are (a caller comparing
/// the same references several times, as the bands of a translation window, stages them once).
template <std::size_t V>
class RefPass {
public:
    const std::uint8_t* row[kRefsPerPass];
    const std::uint8_t* tail[kRefsPerPass];
    std::size_t count = 0;

    RefPass(std::size_t pixels, std::size_t n_copies)
        : pixels_(pixels),
          padded_(round_up(pixels, V)),
          stage_(n_copies >= kStageMinCopies && padded_ * kRefsPerPass <= kStageMaxBytes) {
        const std::size_t bytes = (stage_ ? padded_ * kRefsPerPass : 0) + V * kRefsPerPass;
        storage_.reset(new std::uint8_t[bytes + 64]);
        const auto address = reinterpret_cast<std::uintptr_t>(storage_.get());
        base_ = storage_.get() + (64 - address % 64) % 64;
        tails_ = base_ + (stage_ ? padded_ * kRefsPerPass : 0);
        std::memset(base_, 0, bytes);
    }

    /// References first .. first+7 of `refs` (reference i at refs + i * ref_stride).
    void load(const std::uint8_t* refs, std::size_t ref_stride, std::size_t first, std::size_t n_refs) {
        count = n_refs - first < kRefsPerPass ? n_refs - first : kRefsPerPass;
        const std::size_t full = pixels_ / V * V;
        const bool aligned = reinterpret_cast<std::uintptr_t>(refs) % V == 0 && ref_stride % V == 0;
        for (std::size_t k = 0; k < kRefsPerPass; ++k) {
            const std::uint8_t* src = refs + (first + (k < count ? k : count - 1)) * ref_stride;
            if (stage_ && !aligned) {
                std::uint8_t* dst = base_ + k * padded_;
                std::memcpy(dst, src, pixels_);
                row[k] = dst;
                tail[k] = dst + full;
            } else {
                std::uint8_t* dst = tails_ + k * V;
                copy_short(dst, src + full, pixels_ - full);
                row[k] = src;
                tail[k] = dst;
            }
        }
    }

private:
    // Copies n < V bytes, reading and writing no byte outside them: fixed-size pieces (inline
    // moves, overlapping at the end) rather than a library call per reference and pass.
    static void copy_short(std::uint8_t* dst, const std::uint8_t* src, std::size_t n) {
        if (n >= 16) {
            for (std::size_t c = 0; c + 16 < n; c += 16) std::memcpy(dst + c, src + c, 16);
            std::memcpy(dst + n - 16, src + n - 16, 16);
        } else if (n >= 8) {
            std::memcpy(dst, src, 8);
            std::memcpy(dst + n - 8, src + n - 8, 8);
        } else if (n >= 4) {
            std::memcpy(dst, src, 4);
            std::memcpy(dst + n - 4, src + n - 4, 4);
        } else {
            for (std::size_t c = 0; c < n; ++c) dst[c] = src[c];
        }
    }

    static constexpr std::size_t kStageMinCopies = 4;
    static constexpr std::size_t kStageMaxBytes = std::size_t{256} * 1024;
    std::size_t pixels_, padded_;
    bool stage_;
    std::unique_ptr<std::uint8_t[]> storage_;
    std::uint8_t* base_ = nullptr;
    std::uint8_t* tails_ = nullptr;
};

}  // namespace nightloc::detail
