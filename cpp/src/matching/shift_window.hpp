// Internal: the candidates of a search with a translation window (nightloc/sad.hpp), as bands of
// rows that the SAD kernels compare, and the exact order in which candidates are ranked.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "matching/query_plan.hpp"
#include "nightloc/sad.hpp"

namespace nightloc::detail {

/// A validated search: the column candidates (slots) and the row offsets, each row offset a band.
///
/// Band t (0 <= t < n_bands) is the row offset dy = t - rows: reference rows [r0, r0 + band_rows)
/// against query rows [r0 + dy, ...), r0 = max(0, -dy). Its SearchShape (band()) reads the
/// reference at ref_offset(t) bytes into each image and the query at query_offset(t).
///
/// Candidates are ranked (rank(t, j)): row offsets 0, -1, +1, ... first, then the column order
/// (the shift list's, or column offsets 0, -1, +1, ...). A candidate is better than another when
/// its mean sum / overlap is lower, or equal with a lower rank (better()).
class Window {
public:
    Window(std::size_t height, std::size_t width, const std::int32_t* shifts, std::size_t n_shifts,
           const ShiftWindow& window);

    const SearchShape& full() const { return full_; }
    bool wrap() const { return wrap_; }
    std::size_t columns() const { return columns_; }
    std::size_t rows() const { return rows_; }
    /// True for window {0, 0}: one band, the whole image.
    bool trivial() const { return columns_ == 0 && rows_ == 0; }

    /// Column candidates (the slots of every band), in table order.
    const std::vector<std::int32_t>& values() const { return values_; }
    std::size_t n_columns() const { return values_.size(); }
    std::size_t n_bands() const { return 2 * rows_ + 1; }

    std::int32_t dy(std::size_t band) const {
        return static_cast<std::int32_t>(band) - static_cast<std::int32_t>(rows_);
    }
    std::size_t band_rows(std::size_t band) const { return full_.height - magnitude(dy(band)); }
    std::size_t ref_offset(std::size_t band) const { return first_ref_row(band) * full_.width; }
    /// Non-wrapping bands start at an address that is a multiple of `bytes` (the SIMD kernels'
    /// vector width) where they can: band t's copies begin with band_lead(t) zeros, compared with
    /// the reference's bytes [ref_start(t), ref_offset(t)), whose sum edge_sums() includes.
    /// `base` = the address of the reference images modulo `bytes` (their stride, full().pixels,
    /// a multiple of `bytes`); a band whose aligned start would lie before the image keeps no
    /// lead. Wrapping bands, and align_bands(1, 0): no leads.
    void align_bands(std::size_t bytes, std::size_t base);
    std::size_t band_lead(std::size_t band) const { return leads_.empty() ? 0 : leads_[band]; }
    std::size_t ref_start(std::size_t band) const { return ref_offset(band) - band_lead(band); }
    std::size_t query_offset(std::size_t band) const {
        return static_cast<std::size_t>(static_cast<std::int64_t>(first_ref_row(band)) + dy(band)) * full_.width;
    }
    /// The band's shape for a QueryPlan: band_lead zeros and band_rows x width, references
    /// full().pixels apart.
    SearchShape band(std::size_t band) const;

    /// Rank of candidate (band, slot) and what it stands for.
    std::uint32_t rank(std::size_t band, std::size_t slot) const {
        return static_cast<std::uint32_t>(band_rank(band) * n_columns() + column_rank_[slot]);
    }
    std::uint32_t overlap_of(std::uint32_t rank) const { return rank_overlap_[rank]; }
    std::int32_t value_of(std::uint32_t rank) const { return rank_value_[rank]; }
    std::int32_t dy_of(std::uint32_t rank) const { return rank_dy_[rank]; }
    /// The slot of circular shift k (an entry of the shift list).
    std::size_t slot_of_shift(std::int32_t shift) const { return slot_of_shift_[static_cast<std::size_t>(shift)]; }

    /// Number of candidates a search over one query and one reference compares, in byte
    /// comparisons of the overlaps.
    double comparisons() const;

    /// Bytes of the reference outside the overlap of every non-wrapping candidate of bands
    /// [band_begin, band_end): out[(t - band_begin) * n_columns() + j] = the sum of ref's pixels in
    /// band t's rows whose column c has c + values()[j] outside [0, width). The kernels compare
    /// those pixels with the zeros of the offset copy; subtracting gives the overlap's sum.
    /// `scratch` is reused between calls.
    void edge_sums(const std::uint8_t* ref, std::size_t band_begin, std::size_t band_end, std::uint32_t* out,
                   std::vector<std::uint32_t>& scratch) const;

    /// The best candidate of band `band` among slots [slot0, slot0 + n) for one pair, from the
    /// kernel's slot sums s minus the edge sums e (non-wrapping bands): best_sum and best_rank.
    /// `keys` is scratch for n floats. Means are first compared by float keys, float(sum) *
    /// float(1 / overlap) (three roundings); only the candidates within a relative 2^-18 of the
    /// lowest key can be the lowest mean, and those are compared exactly (better()); the bound is
    /// in shift_window.cpp.
    void best_of_band(std::size_t band, std::size_t slot0, std::size_t n, const std::uint32_t* s,
                      const std::uint32_t* e, float* keys, std::uint32_t& best_sum, std::uint32_t& best_rank) const;

    /// The best candidate of all bands for one pair (one block of slots: every slot), from the
    /// kernels' sums of band t at s + t * band_stride minus the edge sums e (n_bands() x
    /// n_columns(), as edge_sums() writes them), selected as best_of_band does over all bands at
    /// once. `keys` is scratch for n_bands() * n_columns() floats.
    void best_of_bands(const std::uint32_t* s, std::size_t band_stride, const std::uint32_t* e, float* keys,
                       std::uint32_t& best_sum, std::uint32_t& best_rank) const;

    /// Whether candidate (sum, rank) is better than the best so far (best_sum, best_rank); a best
    /// of (UINT32_MAX, UINT32_MAX) is worse than every candidate.
    bool better(std::uint32_t sum, std::uint32_t rank, std::uint32_t best_sum, std::uint32_t best_rank) const {
        if (best_rank == kNoRank) return true;
        const std::uint64_t lhs = std::uint64_t{sum} * overlap_of(best_rank);
        const std::uint64_t rhs = std::uint64_t{best_sum} * overlap_of(rank);
        return lhs < rhs || (lhs == rhs && rank < best_rank);
    }

    static constexpr std::uint32_t kNoRank = 0xffffffffu;

private:
    static std::size_t magnitude(std::int32_t v) { return static_cast<std::size_t>(v < 0 ? -v : v); }
    static std::size_t offset_rank(std::int32_t v) { return 2 * magnitude(v) - (v < 0 ? 1 : 0); }
    std::size_t band_rank(std::size_t band) const { return offset_rank(dy(band)); }
    std::size_t first_ref_row(std::size_t band) const { return dy(band) < 0 ? magnitude(dy(band)) : 0; }

    SearchShape full_;
    bool wrap_ = true;
    std::size_t columns_ = 0, rows_ = 0;
    std::vector<std::int32_t> values_;
    std::vector<std::size_t> column_rank_;
    std::vector<std::size_t> slot_of_shift_;
    std::vector<std::uint32_t> rank_overlap_;
    std::vector<std::uint32_t> slot_rank_;  // band * n_columns + slot -> rank
    std::vector<float> slot_inverse_;       // band * n_columns + slot -> 1 / overlap
    std::vector<std::uint32_t> slot_band_;  // band * n_columns + slot -> band (no division per pair)
    bool small_sums_ = false;               // every band sum fits an int32
    std::vector<std::size_t> leads_;        // align_bands(): per band, or empty
    std::uint32_t lead_sum(const std::uint8_t* ref, std::size_t band) const;
    static constexpr std::size_t kNarrowMaxRows = 8;
    template <std::size_t NV>
    void edge_sums_narrow(const std::uint8_t* ref, std::size_t band_begin, std::size_t band_end,
                          std::uint32_t* out) const;
    std::vector<std::int32_t> rank_value_;
    std::vector<std::int32_t> rank_dy_;
};

}  // namespace nightloc::detail
