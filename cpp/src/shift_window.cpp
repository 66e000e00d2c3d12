// The candidates of a search with a translation window (see shift_window.hpp, nightloc/sad.hpp).
#include "shift_window.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace nightloc::detail {
namespace {

// Ranks are 32-bit and the rank tables are held per search: a bound far above any useful window.
constexpr std::size_t kMaxCandidates = std::size_t{1} << 24;

void check_window(std::size_t height, std::size_t width, const std::int32_t* shifts, std::size_t n_shifts,
                  const ShiftWindow& window) {
    if (window.rows >= height) {
        throw std::invalid_argument("the row window of +-" + std::to_string(window.rows) +
                                    " rows is not smaller than the image height (" + std::to_string(height) +
                                    " rows): an offset that large leaves no overlap; use at most " +
                                    std::to_string(height - 1));
    }
    if (window.columns >= width) {
        throw std::invalid_argument("the column window of +-" + std::to_string(window.columns) +
                                    " columns is not smaller than the image width (" + std::to_string(width) +
                                    " columns): an offset that large leaves no overlap; use at most " +
                                    std::to_string(width - 1));
    }
    if (window.columns > 0 && !(n_shifts == 1 && shifts != nullptr && shifts[0] == 0)) {
        throw std::invalid_argument(
            "a column window is for non-wrapping images (forward cameras) searched at shift 0 only; a panorama's "
            "columns are searched by its circular shifts: use a column window of 0 with a shift list, or the "
            "shift list [0] with a column window");
    }
}

}  // namespace

Window::Window(std::size_t height, std::size_t width, const std::int32_t* shifts, std::size_t n_shifts,
               const ShiftWindow& window)
    : full_(make_search_shape(height, width, shifts, n_shifts)),
      wrap_(window.columns == 0),
      columns_(window.columns),
      rows_(window.rows) {
    check_window(height, width, shifts, n_shifts, window);
    if (wrap_) {
        values_.assign(shifts, shifts + n_shifts);
        column_rank_.resize(n_shifts);
        slot_of_shift_.assign(width, 0);
        for (std::size_t j = 0; j < n_shifts; ++j) {
            column_rank_[j] = j;
            slot_of_shift_[static_cast<std::size_t>(shifts[j])] = j;
        }
    } else {
        const auto c = static_cast<std::int32_t>(columns_);
        for (std::int32_t dx = -c; dx <= c; ++dx) {
            values_.push_back(dx);
            column_rank_.push_back(offset_rank(dx));
        }
    }
    const std::size_t n_ranks = n_bands() * n_columns();
    if (n_ranks > kMaxCandidates) {
        throw std::invalid_argument("the translation window holds " + std::to_string(n_ranks) +
                                    " candidates per image pair (at most " + std::to_string(kMaxCandidates) +
                                    "); narrow it");
    }
    rank_overlap_.resize(n_ranks);
    rank_value_.resize(n_ranks);
    rank_dy_.resize(n_ranks);
    for (std::size_t t = 0; t < n_bands(); ++t) {
        for (std::size_t j = 0; j < n_columns(); ++j) {
            const std::uint32_t r = rank(t, j);
            const std::size_t cols = wrap_ ? width : width - magnitude(values_[j]);
            rank_overlap_[r] = static_cast<std::uint32_t>(band_rows(t) * cols);
            rank_value_[r] = values_[j];
            rank_dy_[r] = dy(t);
        }
    }
}

SearchShape Window::band(std::size_t band) const {
    SearchShape shape = full_;
    shape.height = band_rows(band);
    shape.pixels = shape.height * shape.width;
    shape.shifts = values_.data();
    shape.n_shifts = values_.size();
    shape.ref_stride = full_.pixels;
    shape.wrap = wrap_;
    return shape;
}

double Window::comparisons() const {
    double total = 0.0;
    for (std::size_t t = 0; t < n_bands(); ++t) {
        for (std::size_t j = 0; j < n_columns(); ++j) total += overlap_of(rank(t, j));
    }
    return total;
}

void Window::edge_sums(const std::uint8_t* ref, std::size_t band_begin, std::size_t band_end, std::uint32_t* out,
                       std::vector<std::uint32_t>& scratch) const {
    const std::size_t n = n_columns();
    if (wrap_) {
        std::fill(out, out + (band_end - band_begin) * n, 0u);
        return;
    }
    const std::size_t width = full_.width, height = full_.height, sx = columns_;
    // Column sums of the sx leftmost (left) and sx rightmost (right) columns over all rows, over
    // the top k rows and over the bottom k rows (k = 1 .. rows).
    scratch.assign(2 * sx * (2 + 2 * rows_), 0u);
    std::uint32_t* total = scratch.data();  // [left sx | right sx]
    std::uint32_t* top = total + 2 * sx;    // top + (k - 1) * 2 sx
    std::uint32_t* bottom = top + 2 * sx * rows_;
    const std::size_t right = width - sx;
    for (std::size_t r = 0; r < height; ++r) {
        const std::uint8_t* row = ref + r * width;
        for (std::size_t c = 0; c < sx; ++c) total[c] += row[c];
        for (std::size_t c = 0; c < sx; ++c) total[sx + c] += row[right + c];
        if (r < rows_) {
            std::uint32_t* snapshot = top + r * 2 * sx;
            std::copy(total, total + 2 * sx, snapshot);
        }
    }
    for (std::size_t k = 1; k <= rows_; ++k) {
        const std::uint8_t* row = ref + (height - k) * width;
        std::uint32_t* dst = bottom + (k - 1) * 2 * sx;
        const std::uint32_t* prev = k > 1 ? dst - 2 * sx : nullptr;
        for (std::size_t c = 0; c < sx; ++c) dst[c] = (prev ? prev[c] : 0u) + row[c];
        for (std::size_t c = 0; c < sx; ++c) dst[sx + c] = (prev ? prev[sx + c] : 0u) + row[right + c];
    }
    std::uint32_t* band_cols = bottom + 2 * sx * rows_;
    for (std::size_t t = band_begin; t < band_end; ++t) {
        const std::int32_t d = dy(t);
        const std::uint32_t* excluded =
            d < 0 ? top + (magnitude(d) - 1) * 2 * sx : (d > 0 ? bottom + (magnitude(d) - 1) * 2 * sx : nullptr);
        for (std::size_t c = 0; c < 2 * sx; ++c) band_cols[c] = total[c] - (excluded ? excluded[c] : 0u);
        std::uint32_t* dst = out + (t - band_begin) * n;
        // Slot j holds dx = j - sx: dx < 0 leaves out columns [0, -dx), dx > 0 columns [W - dx, W).
        dst[sx] = 0;
        std::uint32_t acc = 0;
        for (std::size_t a = 1; a <= sx; ++a) {
            acc += band_cols[a - 1];
            dst[sx - a] = acc;
        }
        acc = 0;
        for (std::size_t a = 1; a <= sx; ++a) {
            acc += band_cols[2 * sx - a];
            dst[sx + a] = acc;
        }
    }
}

}  // namespace nightloc::detail

namespace nightloc {

std::vector<std::int32_t> window_column_offsets(std::size_t height, std::size_t width, const std::int32_t* shifts,
                                                std::size_t n_shifts, const ShiftWindow& window) {
    return detail::Window(height, width, shifts, n_shifts, window).values();
}

}  // namespace nightloc
