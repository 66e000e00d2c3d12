// Internal: a query prepared for the SAD kernels (rolled copies), and the choice of kernel.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/simd_paths.hpp"
#include "matching/sad_kernels.hpp"

namespace nightloc::detail {

/// A zero-initialized, 64-byte aligned byte buffer that keeps its capacity when reused.
class AlignedBytes {
public:
    std::uint8_t* data() { return ptr_; }
    const std::uint8_t* data() const { return ptr_; }
    /// Makes room for `size` bytes, all zero.
    void assign_zero(std::size_t size);
    /// Makes room for `size` bytes, contents unspecified.
    void reserve(std::size_t size);

private:
    std::unique_ptr<std::uint8_t[]> raw_;
    std::uint8_t* ptr_ = nullptr;
    std::size_t capacity_ = 0;
};

/// Image geometry and the column shifts a search covers. A search may compare a band of rows:
/// `height` rows of the query (from where the caller points) with `height` rows of each
/// reference, references `ref_stride` bytes apart (the whole image; ref_stride >= pixels).
///  - wrap: shifts[j] is a circular shift k in [0, width): copy j is the query rolled left by k;
///  - !wrap: shifts[j] is a column offset dx in (-width, width): copy j holds Q(r, c + dx) where
///    0 <= c + dx < width and 0 elsewhere (the caller subtracts the reference's bytes there).
///    A non-wrapping copy may start with `lead` zero bytes before its first row (pixels = lead +
///    height * width): the caller points each reference `lead` bytes before the band, so that
///    every band of a window starts at an aligned address, and subtracts those bytes' sum too.
struct SearchShape {
    std::size_t height = 0;
    std::size_t width = 0;
    std::size_t pixels = 0;
    std::size_t lead = 0;
    const std::int32_t* shifts = nullptr;
    std::size_t n_shifts = 0;
    std::size_t ref_stride = 0;
    bool wrap = true;
};

/// Checks sizes and shifts; throws std::invalid_argument naming the problem.
SearchShape make_search_shape(std::size_t height, std::size_t width, const std::int32_t* shifts, std::size_t n_shifts);

/// Writes one query in the all-shift layout (AllShiftKernel, sad_kernels.hpp) into `out`
/// (round_up(pixels, kChunk) * width / 2 bytes, 64-byte aligned, already zero); `rolled` is a
/// scratch buffer of round_up(pixels, kChunk) bytes.
void interleave_query(const std::uint8_t* query, std::size_t height, std::size_t width, std::uint8_t* rolled,
                      std::uint8_t* out);

/// Bytes one prepared query occupies (for sizing query blocks).
std::size_t plan_bytes(const SimdPath& path, const SearchShape& shape);

/// A block of queries, prepared for one block of the shift list [slot_begin, slot_end):
///  - all-shift layout (paths with an all-shift kernel, width % 8 == 0, many shifts): per query,
///    its even-shift copies, interleaved;
///  - offsets layout (paths with an offsets kernel, width % 8 == 0, non-wrapping consecutive
///    offsets): per query, its zero-filled copies at even offsets, interleaved the same way;
///  - otherwise one rolled copy per query and shift of the block, all handed to one kernel call
///    so that each reference chunk loaded serves every query of the block.
/// evaluate() and evaluate_min() are const and may run concurrently on one plan.
class QueryPlan {
public:
    /// The layout and kernels of `path` (a SIMD path registry entry) for `shape`.
    QueryPlan(const SimdPath& path, const SearchShape& shape);

    /// Shift-list slots per block (the whole list for the all-shift layout).
    std::size_t slots_per_block() const { return slots_per_block_; }

    /// Prepares `count` queries (query k at queries + k * query_stride, its `height` rows read) for
    /// slots [slot_begin, slot_begin + slots_per_block()).
    void prepare(const std::uint8_t* queries, std::size_t count, std::size_t query_stride, std::size_t slot_begin);
    std::size_t query_count() const { return query_count_; }
    std::size_t slot_begin() const { return slot_begin_; }
    std::size_t slot_count() const { return slot_count_; }

    /// out[i * out_stride + k * slot_count() + j] = sum for reference i (refs + i * ref_stride),
    /// query k and slot slot_begin() + j. `scratch` must hold scratch_size(n_refs) words.
    void evaluate(const std::uint8_t* refs, std::size_t n_refs, std::uint32_t* out, std::size_t out_stride,
                  std::uint32_t* scratch) const;
    std::size_t scratch_size(std::size_t n_refs) const { return all_shifts_ ? n_refs * shape_.width : 0; }

    /// True when evaluate_min() is available: the all-shift layout with a strictly increasing
    /// shift list (so the earliest slot of a tie is also the lowest shift).
    bool fused_min() const { return fused_min_; }
    /// True when evaluate() runs a SIMD copies kernel (RefPass: aligned references read in place).
    bool simd_copies() const { return copies_kernel_ != nullptr && copies_kernel_ != sad_copies_scalar; }
    /// Minimum over all slots for query `query` and each reference: best_sums[i], best_shifts[i].
    void evaluate_min(std::size_t query, const std::uint8_t* refs, std::size_t n_refs, std::uint32_t* best_sums,
                      std::int32_t* best_shifts) const;

private:
    SearchShape shape_;
    bool all_shifts_ = false;
    CopiesKernel copies_kernel_ = nullptr;
    AllShiftKernel all_shift_kernel_ = nullptr;
    OffsetsKernel offsets_kernel_ = nullptr;
    bool offset_layout_ = false;  // non-wrapping consecutive offsets (the path's offsets kernel)
    std::int32_t offset_e0_ = 0;
    std::size_t offset_first_ = 0, offset_copies_ = 0;
    std::size_t stride_ = 0;             // bytes per rolled copy
    std::size_t interleaved_bytes_ = 0;  // bytes per query in the all-shift layout
    bool fused_min_ = false;
    std::vector<std::uint16_t> selected_;  // all-shift layout: per 8 shifts, which are in the list
    std::size_t slots_per_block_ = 0;
    std::size_t query_count_ = 0;
    std::size_t slot_begin_ = 0;
    std::size_t slot_count_ = 0;
    AlignedBytes buffer_;
    std::unique_ptr<std::uint8_t[]> rolled_temp_;
    std::vector<std::uint8_t> padded_;  // non-wrapping shapes: the query's rows padded with zeros
};

}  // namespace nightloc::detail
