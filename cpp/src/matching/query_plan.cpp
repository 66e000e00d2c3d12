// Query preparation for the SAD kernels: rolled copies and the all-shift interleaved layout.
#include "matching/query_plan.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "nightloc/sad.hpp"

namespace nightloc::detail {
namespace {

// Upper bound on the bytes of one prepared query: it must stay in L2 next to a block of refs.
constexpr std::size_t kPlanBudget = std::size_t{512} * 1024;

// Writes the query rolled left by `shift` columns (row by row), then zeros up to `stride`.
void write_rolled(const std::uint8_t* query, std::size_t height, std::size_t width, std::size_t shift,
                  std::uint8_t* dst, std::size_t stride) {
    for (std::size_t r = 0; r < height; ++r) {
        const std::uint8_t* src_row = query + r * width;
        std::uint8_t* dst_row = dst + r * width;
        std::memcpy(dst_row, src_row + shift, width - shift);
        std::memcpy(dst_row + (width - shift), src_row, shift);
    }
    std::memset(dst + height * width, 0, stride - height * width);
}

// Copies n bytes: 16 at a time, the last 16 overlapping the previous ones (inline stores
// rather than a library call per short row); memcpy when n < 16.
void copy_row(std::uint8_t* dst, const std::uint8_t* src, std::size_t n) {
    if (n < 16) {
        std::memcpy(dst, src, n);
        return;
    }
    for (std::size_t c = 0; c + 16 < n; c += 16) std::memcpy(dst + c, src + c, 16);
    std::memcpy(dst + n - 16, src + n - 16, 16);
}

// The rows of a query with `pad` zeros on either side: row r at padded + r * (width + 2 pad) + pad.
void write_padded(const std::uint8_t* query, std::size_t height, std::size_t width, std::size_t pad,
                  std::vector<std::uint8_t>& padded) {
    const std::size_t row_stride = width + 2 * pad;
    padded.assign(height * row_stride, 0);
    for (std::size_t r = 0; r < height; ++r)
        std::memcpy(padded.data() + r * row_stride + pad, query + r * width, width);
}

// Writes `lead` zeros, then dst(r, c) = query(r, c + offset) where 0 <= c + offset < width,
// else 0; zeros up to `stride`. `padded` holds the query's rows with `pad` >= |offset| zeros on
// either side (write_padded).
void write_offset(const std::uint8_t* padded, std::size_t pad, std::size_t height, std::size_t width,
                  std::int32_t offset, std::size_t lead, std::uint8_t* dst, std::size_t stride) {
    std::memset(dst, 0, lead);
    dst += lead;
    stride -= lead;
    const std::size_t row_stride = width + 2 * pad;
    const std::uint8_t* src = padded + static_cast<std::ptrdiff_t>(pad) + offset;
    for (std::size_t r = 0; r < height; ++r) copy_row(dst + r * width, src + r * row_stride, width);
    std::memset(dst + height * width, 0, stride - height * width);
}

// The largest |offset| of a non-wrapping shape's offsets.
std::size_t largest_offset(const SearchShape& shape) {
    std::size_t largest = 0;
    for (std::size_t j = 0; j < shape.n_shifts; ++j) {
        const std::int32_t v = shape.shifts[j];
        largest = std::max(largest, static_cast<std::size_t>(v < 0 ? -std::int64_t{v} : v));
    }
    return largest;
}

void write_copy(const SearchShape& shape, const std::uint8_t* query, const std::uint8_t* padded, std::size_t pad,
                std::int32_t shift, std::uint8_t* dst, std::size_t stride) {
    if (shape.wrap) {
        write_rolled(query, shape.height, shape.width, static_cast<std::size_t>(shift), dst, stride);
    } else {
        write_offset(padded, pad, shape.height, shape.width, shift, shape.lead, dst, stride);
    }
}

}  // namespace

void AlignedBytes::reserve(std::size_t size) {
    if (size > capacity_) {
        raw_.reset(new std::uint8_t[size + kChunk]);
        auto address = reinterpret_cast<std::uintptr_t>(raw_.get());
        ptr_ = raw_.get() + (kChunk - address % kChunk) % kChunk;
        capacity_ = size;
    }
}

void AlignedBytes::assign_zero(std::size_t size) {
    reserve(size);
    std::memset(ptr_, 0, size);
}

SearchShape make_search_shape(std::size_t height, std::size_t width, const std::int32_t* shifts, std::size_t n_shifts) {
    if (height == 0 || width == 0) throw std::invalid_argument("images must have at least one row and one column");
    if (height > kMaxImagePixels / width) {
        throw std::invalid_argument("images of " + std::to_string(height) + " x " + std::to_string(width) +
                                    " pixels are too large (at most " + std::to_string(kMaxImagePixels) +
                                    " pixels); downsample them first");
    }
    if (n_shifts == 0 || shifts == nullptr) throw std::invalid_argument("the shift list is empty");
    std::vector<bool> seen(width, false);
    for (std::size_t j = 0; j < n_shifts; ++j) {
        const std::int32_t s = shifts[j];
        if (s < 0 || static_cast<std::size_t>(s) >= width) {
            throw std::invalid_argument("shift " + std::to_string(s) + " is outside [0, " + std::to_string(width) +
                                        "), the image width");
        }
        if (seen[static_cast<std::size_t>(s)]) {
            throw std::invalid_argument("shift " + std::to_string(s) + " appears more than once in the shift list");
        }
        seen[static_cast<std::size_t>(s)] = true;
    }
    return SearchShape{height, width, height * width, 0, shifts, n_shifts, height * width, true};
}

namespace {

bool use_all_shift_layout(const SimdPath& path, const SearchShape& shape) {
    const std::size_t interleaved_bytes = round_up(shape.pixels, kChunk) * (shape.width / 2);
    return path.sad_all_shifts != nullptr && shape.wrap && shape.width % 8 == 0 && shape.width <= kAllShiftMaxWidth &&
           2 * shape.n_shifts > shape.width && interleaved_bytes <= kPlanBudget;
}

// The offsets layout (OffsetsKernel, sad_kernels.hpp): copies at even offsets e0, e0 + 2, ... covering the
// consecutive ascending offsets of a non-wrapping search.
struct OffsetCopies {
    std::int32_t e0 = 0;
    std::size_t first = 0, n_copies = 0;
};

OffsetCopies offset_copies(const SearchShape& shape) {
    OffsetCopies c;
    const std::int32_t v0 = shape.shifts[0], last = shape.shifts[shape.n_shifts - 1];
    c.e0 = v0 - ((v0 % 2 + 2) % 2);
    c.first = static_cast<std::size_t>(v0 - c.e0);
    c.n_copies = static_cast<std::size_t>((last - c.e0) / 2) + 2;
    return c;
}

bool use_offset_layout(const SimdPath& path, const SearchShape& shape) {
    if (path.sad_offsets == nullptr || shape.wrap || shape.width % 8 != 0 || shape.n_shifts < 3) return false;
    for (std::size_t j = 1; j < shape.n_shifts; ++j) {
        if (shape.shifts[j] != shape.shifts[j - 1] + 1) return false;
    }
    const OffsetCopies c = offset_copies(shape);
    return c.n_copies <= kMaxOffsetCopies && c.n_copies * round_up(shape.pixels, kChunk) <= kPlanBudget;
}

std::size_t copies_per_block(const SearchShape& shape) {
    return std::clamp<std::size_t>(kPlanBudget / round_up(shape.pixels, kChunk), 1, shape.n_shifts);
}

}  // namespace

void interleave_query(const std::uint8_t* query, std::size_t height, std::size_t width, std::uint8_t* rolled,
                      std::uint8_t* out) {
    const std::size_t stride = round_up(height * width, kChunk);
    const std::size_t n_chunks = stride / kChunk;
    const std::size_t n_even = width / 2;
    for (std::size_t m = 0; m < n_even; ++m) {
        write_rolled(query, height, width, 2 * m, rolled, stride);
        for (std::size_t c = 0; c < n_chunks; ++c) {
            std::memcpy(out + (c * n_even + m) * kChunk, rolled + c * kChunk, kChunk);
        }
    }
}

std::size_t plan_bytes(const SimdPath& path, const SearchShape& shape) {
    const std::size_t stride = round_up(shape.pixels, kChunk);
    if (use_all_shift_layout(path, shape)) return stride * (shape.width / 2);
    if (use_offset_layout(path, shape)) return stride * offset_copies(shape).n_copies;
    return stride * copies_per_block(shape);
}

QueryPlan::QueryPlan(const SimdPath& path, const SearchShape& shape) : shape_(shape) {
    stride_ = round_up(shape.pixels, kChunk);
    all_shifts_ = use_all_shift_layout(path, shape);
    if (all_shifts_) {
        all_shift_kernel_ = path.sad_all_shifts();
        slots_per_block_ = shape.n_shifts;
        interleaved_bytes_ = stride_ * (shape.width / 2);
        rolled_temp_.reset(new std::uint8_t[stride_]);
        fused_min_ = std::is_sorted(shape.shifts, shape.shifts + shape.n_shifts);
        selected_.assign(shape.width / 8, 0);
        for (std::size_t j = 0; j < shape.n_shifts; ++j) {
            const auto k = static_cast<std::size_t>(shape.shifts[j]);
            const std::size_t lane = (k % 8) / 2, dword = k % 2;
            selected_[k / 8] = static_cast<std::uint16_t>(selected_[k / 8] | (1u << (4 * lane + dword)));
        }
    } else if (use_offset_layout(path, shape)) {
        offsets_kernel_ = path.sad_offsets();
        const OffsetCopies c = offset_copies(shape);
        offset_layout_ = true;
        offset_e0_ = c.e0;
        offset_first_ = c.first;
        offset_copies_ = c.n_copies;
        slots_per_block_ = shape.n_shifts;
        rolled_temp_.reset(new std::uint8_t[stride_]);
    } else {
        copies_kernel_ = path.sad_copies;
        slots_per_block_ = copies_per_block(shape);
    }
}

void QueryPlan::prepare(const std::uint8_t* queries, std::size_t count, std::size_t query_stride,
                        std::size_t slot_begin) {
    query_count_ = count;
    slot_begin_ = slot_begin;
    slot_count_ = std::min(slots_per_block_, shape_.n_shifts - slot_begin);
    // Every byte of the buffer is written below: no zeroing first.
    if (offset_layout_) {
        const std::size_t bytes = offset_copies_ * stride_, n_chunks = stride_ / kChunk;
        const std::int32_t last = offset_e0_ + 2 * static_cast<std::int32_t>(offset_copies_ - 1);
        const std::size_t pad = static_cast<std::size_t>(
            std::max<std::int64_t>(std::abs(std::int64_t{offset_e0_}), std::abs(std::int64_t{last})));
        buffer_.reserve(count * bytes);
        for (std::size_t k = 0; k < count; ++k) {
            std::uint8_t* dst = buffer_.data() + k * bytes;
            write_padded(queries + k * query_stride, shape_.height, shape_.width, pad, padded_);
            for (std::size_t m = 0; m < offset_copies_; ++m) {
                write_offset(padded_.data(), pad, shape_.height, shape_.width,
                             offset_e0_ + 2 * static_cast<std::int32_t>(m), shape_.lead, rolled_temp_.get(), stride_);
                for (std::size_t c = 0; c < n_chunks; ++c) {
                    std::memcpy(dst + (c * offset_copies_ + m) * kChunk, rolled_temp_.get() + c * kChunk, kChunk);
                }
            }
        }
    } else if (all_shifts_) {
        buffer_.reserve(count * interleaved_bytes_);
        for (std::size_t k = 0; k < count; ++k) {
            interleave_query(queries + k * query_stride, shape_.height, shape_.width, rolled_temp_.get(),
                             buffer_.data() + k * interleaved_bytes_);
        }
    } else {
        buffer_.reserve(count * slot_count_ * stride_);
        const std::size_t pad = shape_.wrap ? 0 : largest_offset(shape_);
        for (std::size_t k = 0; k < count; ++k) {
            if (!shape_.wrap) write_padded(queries + k * query_stride, shape_.height, shape_.width, pad, padded_);
            for (std::size_t j = 0; j < slot_count_; ++j) {
                write_copy(shape_, queries + k * query_stride, padded_.data(), pad, shape_.shifts[slot_begin + j],
                           buffer_.data() + (k * slot_count_ + j) * stride_, stride_);
            }
        }
    }
}

void QueryPlan::evaluate(const std::uint8_t* refs, std::size_t n_refs, std::uint32_t* out, std::size_t out_stride,
                         std::uint32_t* scratch) const {
    if (n_refs == 0) return;
    if (offset_layout_) {
        const std::size_t bytes = offset_copies_ * stride_;
        for (std::size_t k = 0; k < query_count_; ++k) {
            offsets_kernel_(buffer_.data() + k * bytes, offset_copies_, offset_first_, slot_count_, refs,
                            shape_.ref_stride, n_refs, shape_.pixels, out + k * slot_count_, out_stride);
        }
        return;
    }
    if (all_shifts_) {
        const std::size_t width = shape_.width;
        for (std::size_t k = 0; k < query_count_; ++k) {
            all_shift_kernel_(buffer_.data() + k * interleaved_bytes_, width, refs, shape_.ref_stride, n_refs,
                              shape_.pixels, scratch, width, nullptr, nullptr, nullptr);
            for (std::size_t i = 0; i < n_refs; ++i) {
                const std::uint32_t* row = scratch + i * width;
                std::uint32_t* dst = out + i * out_stride + k * slot_count_;
                for (std::size_t j = 0; j < slot_count_; ++j) {
                    dst[j] = row[static_cast<std::size_t>(shape_.shifts[slot_begin_ + j])];
                }
            }
        }
        return;
    }
    (void)scratch;
    copies_kernel_(buffer_.data(), stride_, query_count_ * slot_count_, refs, shape_.ref_stride, n_refs, shape_.pixels,
                   out, out_stride);
}

void QueryPlan::evaluate_min(std::size_t query, const std::uint8_t* refs, std::size_t n_refs, std::uint32_t* best_sums,
                             std::int32_t* best_shifts) const {
    if (!fused_min_ || query >= query_count_) {
        throw std::logic_error(
            "QueryPlan::evaluate_min needs the all-shift layout, sorted shifts and a prepared query");
    }
    all_shift_kernel_(buffer_.data() + query * interleaved_bytes_, shape_.width, refs, shape_.ref_stride, n_refs,
                      shape_.pixels, nullptr, 0, selected_.data(), best_sums, best_shifts);
}

}  // namespace nightloc::detail
