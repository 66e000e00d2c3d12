// The candidates of a search with a translation window (see shift_window.hpp, nightloc/sad.hpp).
#include "matching/shift_window.hpp"

#include <algorithm>
#include <cstring>
#include <limits>
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
    small_sums_ = full_.pixels <= (std::size_t{1} << 31) / 256;  // a band's sums fit an int32
    const std::size_t n_ranks = n_bands() * n_columns();
    if (n_ranks > kMaxCandidates) {
        throw std::invalid_argument("the translation window holds " + std::to_string(n_ranks) +
                                    " candidates per image pair (at most " + std::to_string(kMaxCandidates) +
                                    "); narrow it");
    }
    rank_overlap_.resize(n_ranks);
    rank_value_.resize(n_ranks);
    rank_dy_.resize(n_ranks);
    slot_rank_.resize(n_ranks);
    slot_inverse_.resize(n_ranks);
    slot_band_.resize(n_ranks);
    for (std::size_t t = 0; t < n_bands(); ++t) {
        for (std::size_t j = 0; j < n_columns(); ++j) {
            const std::uint32_t r = rank(t, j);
            const std::size_t cols = wrap_ ? width : width - magnitude(values_[j]);
            rank_overlap_[r] = static_cast<std::uint32_t>(band_rows(t) * cols);
            rank_value_[r] = values_[j];
            rank_dy_[r] = dy(t);
            slot_rank_[t * n_columns() + j] = r;
            slot_inverse_[t * n_columns() + j] = 1.0f / static_cast<float>(band_rows(t) * cols);
            slot_band_[t * n_columns() + j] = static_cast<std::uint32_t>(t);
        }
    }
}

void Window::align_bands(std::size_t bytes, std::size_t base) {
    leads_.clear();
    if (wrap_ || bytes <= 1) return;
    for (std::size_t t = 0; t < n_bands(); ++t) {
        const std::size_t lead = (base + ref_offset(t)) % bytes;
        leads_.push_back(lead <= ref_offset(t) ? lead : 0);
    }
}

SearchShape Window::band(std::size_t band) const {
    SearchShape shape = full_;
    shape.height = band_rows(band);
    shape.lead = band_lead(band);
    shape.pixels = shape.lead + shape.height * shape.width;
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

#if defined(__GNUC__) || defined(__clang__)
#define NIGHTLOC_VECTOR_EXTENSIONS 1
namespace {
typedef float Float4 __attribute__((vector_size(16)));
typedef std::int32_t Int4 __attribute__((vector_size(16)));
typedef std::uint8_t Byte8 __attribute__((vector_size(8)));
typedef std::uint16_t Word8 __attribute__((vector_size(16)));
typedef std::uint32_t Dword8 __attribute__((vector_size(32)));
typedef std::uint64_t Qword2 __attribute__((vector_size(16)));
typedef std::uint32_t Dword4 __attribute__((vector_size(16)));

template <class V>
V load_vector(const void* p) {
    V v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
}  // namespace
#else
#define NIGHTLOC_VECTOR_EXTENSIONS 0
#endif

namespace {

// keys[j] = float(s[j] - e[j]) * inverse[j] for j < n; returns the lowest key. Keys are within a
// relative 2^-22 of the mean (three roundings); every lowest mean is within 2^-20 of the lowest
// key, so the candidates above lowest * (1 + 2^-18) cannot win, and the others are compared
// exactly (contender_threshold, count_contenders).
float write_keys(const std::uint32_t* s, const std::uint32_t* e, const float* inverse, std::size_t n, float* keys,
                 bool small_sums) {
    float lowest = std::numeric_limits<float>::infinity();
    std::size_t j = 0;
#if NIGHTLOC_VECTOR_EXTENSIONS
    if (small_sums) {  // band sums below 2^31: int32 conversion
        const float inf = std::numeric_limits<float>::infinity();
        Float4 low = {inf, inf, inf, inf};
        for (; j + 4 <= n; j += 4) {
            const Int4 d = load_vector<Int4>(s + j) - load_vector<Int4>(e + j);
            const Float4 key = __builtin_convertvector(d, Float4) * load_vector<Float4>(inverse + j);
            std::memcpy(keys + j, &key, sizeof key);
            low = key < low ? key : low;
        }
        for (int lane = 0; lane < 4; ++lane) lowest = low[lane] < lowest ? low[lane] : lowest;
    }
#else
    (void)small_sums;
#endif
    for (; j < n; ++j) {
        const float key = static_cast<float>(s[j] - e[j]) * inverse[j];
        keys[j] = key;
        lowest = key < lowest ? key : lowest;
    }
    return lowest;
}

float contender_threshold(float lowest) { return lowest + lowest * 0x1p-18f; }

// The number of keys[j] <= threshold, j < n, and the sum of their indices, without branching:
// almost always there is one, and the exact comparison is needed only when there are several.
std::size_t count_contenders(const float* keys, std::size_t n, float threshold, std::size_t& index_sum) {
    std::size_t count = 0, j = 0;
    index_sum = 0;
#if NIGHTLOC_VECTOR_EXTENSIONS
    const Float4 limit = {threshold, threshold, threshold, threshold};
    Int4 counts = {0, 0, 0, 0}, indices = {0, 0, 0, 0};
    Int4 lane = {0, 1, 2, 3};
    const Int4 four = {4, 4, 4, 4};
    for (; j + 4 <= n; j += 4, lane += four) {
        const Int4 in = load_vector<Float4>(keys + j) <= limit;  // -1 where a contender
        counts -= in;
        indices += in & lane;
    }
    for (int l = 0; l < 4; ++l) {
        count += static_cast<std::size_t>(counts[l]);
        index_sum += static_cast<std::size_t>(indices[l]);
    }
#endif
    for (; j < n; ++j) {
        const bool in = keys[j] <= threshold;
        count += in;
        index_sum += in ? j : 0;
    }
    return count;
}

}  // namespace

void Window::best_of_band(std::size_t band, std::size_t slot0, std::size_t n, const std::uint32_t* s,
                          const std::uint32_t* e, float* keys, std::uint32_t& best_sum,
                          std::uint32_t& best_rank) const {
    const float* inverse = slot_inverse_.data() + band * n_columns() + slot0;
    const std::uint32_t* ranks = slot_rank_.data() + band * n_columns() + slot0;
    const float threshold = contender_threshold(write_keys(s, e, inverse, n, keys, small_sums_));
    std::size_t index_sum = 0;
    if (count_contenders(keys, n, threshold, index_sum) == 1) {
        best_sum = s[index_sum] - e[index_sum];
        best_rank = ranks[index_sum];
        return;
    }
    best_sum = std::numeric_limits<std::uint32_t>::max();
    best_rank = kNoRank;
    for (std::size_t j = 0; j < n; ++j) {
        if (keys[j] <= threshold && better(s[j] - e[j], ranks[j], best_sum, best_rank)) {
            best_sum = s[j] - e[j];
            best_rank = ranks[j];
        }
    }
}

void Window::best_of_bands(const std::uint32_t* s, std::size_t band_stride, const std::uint32_t* e, float* keys,
                           std::uint32_t& best_sum, std::uint32_t& best_rank) const {
    const std::size_t n = n_columns(), total = n_bands() * n;
    float lowest = std::numeric_limits<float>::infinity();
    for (std::size_t t = 0; t < n_bands(); ++t) {
        const float band_lowest =
            write_keys(s + t * band_stride, e + t * n, slot_inverse_.data() + t * n, n, keys + t * n, small_sums_);
        lowest = band_lowest < lowest ? band_lowest : lowest;
    }
    const float threshold = contender_threshold(lowest);
    auto sum_of = [&](std::size_t index) {
        const std::size_t band = slot_band_[index];
        return s[band * band_stride + (index - band * n)] - e[index];
    };
    std::size_t index_sum = 0;
    if (count_contenders(keys, total, threshold, index_sum) == 1) {
        best_sum = sum_of(index_sum);
        best_rank = slot_rank_[index_sum];
        return;
    }
    best_sum = std::numeric_limits<std::uint32_t>::max();
    best_rank = kNoRank;
    for (std::size_t index = 0; index < total; ++index) {
        if (keys[index] <= threshold && better(sum_of(index), slot_rank_[index], best_sum, best_rank)) {
            best_sum = sum_of(index);
            best_rank = slot_rank_[index];
        }
    }
}

inline std::uint32_t Window::lead_sum(const std::uint8_t* ref, std::size_t band) const {
    const std::uint8_t* p = ref + ref_start(band);
    const std::uint8_t* const end = ref + ref_offset(band);
    std::uint32_t sum = 0;
    for (; p + 8 <= end; p += 8) {  // eight bytes at a time: pairs, then the four pair sums
        std::uint64_t x = 0;
        std::memcpy(&x, p, 8);
        x = (x & 0x00ff00ff00ff00ffull) + ((x >> 8) & 0x00ff00ff00ff00ffull);
        sum += static_cast<std::uint32_t>((x * 0x0001000100010001ull) >> 48);
    }
    for (; p < end; ++p) sum += *p;
    return sum;
}

void Window::edge_sums(const std::uint8_t* ref, std::size_t band_begin, std::size_t band_end, std::uint32_t* out,
                       std::vector<std::uint32_t>& scratch) const {
    const std::size_t n = n_columns();
    if (wrap_) {
        std::fill(out, out + (band_end - band_begin) * n, 0u);
        return;
    }
#if NIGHTLOC_VECTOR_EXTENSIONS
    // (SideSums reads a row's two 8-byte sides as the 16-bit lanes of one vector: little-endian.)
    if (full_.height <= 257 && rows_ <= kNarrowMaxRows && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__) {
        if (columns_ <= 8 && full_.width >= 8) return edge_sums_narrow<1>(ref, band_begin, band_end, out);
        if (columns_ <= 16 && full_.width >= 16) return edge_sums_narrow<2>(ref, band_begin, band_end, out);
    }
#endif
    const std::size_t width = full_.width, height = full_.height, sx = columns_, w2 = 2 * sx;
    // Column sums of the sx leftmost and sx rightmost columns ([left sx | right sx]) over all rows
    // (total), over the top k rows (top + (k - 1) * w2) and the bottom k rows (bottom + ...), k =
    // 1 .. rows; then zeros (the rows a band of dy = 0 leaves out) and one band's sums.
    scratch.assign(w2 * (3 + 2 * rows_), 0u);
    std::uint32_t* const total = scratch.data();
    std::uint32_t* const top = total + w2;
    std::uint32_t* const bottom = top + w2 * rows_;
    const std::uint32_t* const none = bottom + w2 * rows_;
    std::uint32_t* const band_cols = bottom + w2 * (rows_ + 1);
    const std::size_t right = width - sx;
    auto add_row = [&](std::uint32_t* __restrict acc, const std::uint8_t* __restrict row) {
        for (std::size_t c = 0; c < sx; ++c) acc[c] += row[c];
        for (std::size_t c = 0; c < sx; ++c) acc[sx + c] += row[right + c];
    };
    for (std::size_t r = 0; r < rows_; ++r) {
        add_row(total, ref + r * width);
        std::copy(total, total + w2, top + r * w2);
    }
    for (std::size_t r = rows_; r < height; ++r) add_row(total, ref + r * width);
    for (std::size_t k = 1; k <= rows_; ++k) {
        std::uint32_t* dst = bottom + (k - 1) * w2;
        if (k > 1) std::copy(dst - w2, dst, dst);
        add_row(dst, ref + (height - k) * width);
    }
    for (std::size_t t = band_begin; t < band_end; ++t) {
        const std::int32_t d = dy(t);
        const std::uint32_t* excluded =
            d < 0 ? top + (magnitude(d) - 1) * w2 : (d > 0 ? bottom + (magnitude(d) - 1) * w2 : none);
        for (std::size_t c = 0; c < w2; ++c) band_cols[c] = total[c] - excluded[c];
        std::uint32_t* dst = out + (t - band_begin) * n;
        // Slot j holds dx = j - sx: dx < 0 leaves out columns [0, -dx), dx > 0 columns [W - dx, W).
        dst[sx] = band_lead(t) != 0 ? lead_sum(ref, t) : 0;
        std::uint32_t left = dst[sx], right_sum = dst[sx];
        for (std::size_t a = 1; a <= sx; ++a) {
            left += band_cols[a - 1];
            right_sum += band_cols[w2 - a];
            dst[sx - a] = left;
            dst[sx + a] = right_sum;
        }
    }
}

#if NIGHTLOC_VECTOR_EXTENSIONS
namespace {

// Column sums of the 8 * NV leftmost and rightmost columns of rows, in 16-bit lanes: vector v
// holds the bytes [8v, 8v + 8) of a row and [width - 8 (v + 1), width - 8 v) as 16 bytes, summed as
// their even bytes (even[v]) and odd bytes (odd[v]): no unpacking per row.
template <std::size_t NV>
struct SideSums {
    Word8 even[NV], odd[NV];

    void clear() {
        for (std::size_t v = 0; v < NV; ++v) even[v] = odd[v] = Word8{};
    }
    void add_row(const std::uint8_t* row, std::size_t width) {
        for (std::size_t v = 0; v < NV; ++v) {
            std::uint64_t left = 0, right = 0;
            std::memcpy(&left, row + 8 * v, 8);
            std::memcpy(&right, row + width - 8 * (v + 1), 8);
            const Word8 bytes = reinterpret_cast<Word8>(Qword2{left, right});  // little-endian lanes
            even[v] += bytes & std::uint16_t{0xff};
            odd[v] += bytes >> 8;
        }
    }
    SideSums operator+(const SideSums& other) const {
        SideSums sum;
        for (std::size_t v = 0; v < NV; ++v) sum.even[v] = even[v] + other.even[v], sum.odd[v] = odd[v] + other.odd[v];
        return sum;
    }
    SideSums operator-(const SideSums& other) const {
        SideSums difference;
        for (std::size_t v = 0; v < NV; ++v) {
            difference.even[v] = even[v] - other.even[v], difference.odd[v] = odd[v] - other.odd[v];
        }
        return difference;
    }
    /// NV == 1, sx <= 8: out[sx] = lead, out[sx - a] = lead + the sum of columns [0, a) and
    /// out[sx + a] = lead + the sum of columns [width - a, width), a = 1 .. sx; running sums in
    /// 32-bit vector lanes.
    void running_sums(std::uint32_t lead, std::size_t sx, std::uint32_t* out) const {
        const Dword4 zero = {0, 0, 0, 0}, leads = {lead, lead, lead, lead};
        // Columns 0, 2, 4, 6 (e_left), 1, 3, 5, 7 (o_left), width - 8, width - 6, .. (e_right) and
        // width - 7, width - 5, .. (o_right) widened, then in the orders 7, 6, .., 0 and width - 1,
        // width - 2, .., width - 8.
        const Dword4 e_left = __builtin_convertvector(__builtin_shufflevector(even[0], even[0], 0, 1, 2, 3), Dword4);
        const Dword4 o_left = __builtin_convertvector(__builtin_shufflevector(odd[0], odd[0], 0, 1, 2, 3), Dword4);
        const Dword4 e_right = __builtin_convertvector(__builtin_shufflevector(even[0], even[0], 4, 5, 6, 7), Dword4);
        const Dword4 o_right = __builtin_convertvector(__builtin_shufflevector(odd[0], odd[0], 4, 5, 6, 7), Dword4);
        const Dword4 left_lo = __builtin_shufflevector(e_left, o_left, 7, 3, 6, 2);
        const Dword4 left_hi = __builtin_shufflevector(e_left, o_left, 5, 1, 4, 0);
        const Dword4 right_lo = __builtin_shufflevector(e_right, o_right, 7, 3, 6, 2);
        const Dword4 right_hi = __builtin_shufflevector(e_right, o_right, 5, 1, 4, 0);
        // Left: sums from each lane to the last (columns [0, c]); right: from the first lane on.
        Dword4 l_hi = left_hi + __builtin_shufflevector(left_hi, zero, 1, 2, 3, 4);
        l_hi += __builtin_shufflevector(l_hi, zero, 2, 3, 4, 4);
        Dword4 l_lo = left_lo + __builtin_shufflevector(left_lo, zero, 1, 2, 3, 4);
        l_lo += __builtin_shufflevector(l_lo, zero, 2, 3, 4, 4);
        l_lo += __builtin_shufflevector(l_hi, l_hi, 0, 0, 0, 0);
        Dword4 r_lo = right_lo + __builtin_shufflevector(right_lo, zero, 4, 0, 1, 2);
        r_lo += __builtin_shufflevector(r_lo, zero, 4, 4, 0, 1);
        Dword4 r_hi = right_hi + __builtin_shufflevector(right_hi, zero, 4, 0, 1, 2);
        r_hi += __builtin_shufflevector(r_hi, zero, 4, 4, 0, 1);
        r_hi += __builtin_shufflevector(r_lo, r_lo, 3, 3, 3, 3);
        // sums[8 - a] = left a columns, sums[8] = lead, sums[8 + a] = right a columns.
        std::uint32_t buffer[17];
        std::uint32_t* const sums = sx == 8 ? out : buffer;
        l_lo += leads, l_hi += leads, r_lo += leads, r_hi += leads;
        std::memcpy(sums, &l_lo, sizeof l_lo);
        std::memcpy(sums + 4, &l_hi, sizeof l_hi);
        sums[8] = lead;
        std::memcpy(sums + 9, &r_lo, sizeof r_lo);
        std::memcpy(sums + 13, &r_hi, sizeof r_hi);
        if (sx != 8) std::copy(buffer + (8 - sx), buffer + (9 + sx), out);
    }
    /// out[c] = column c's sum for c < 8 NV, out[8 NV + c] = column width - 1 - c's.
    void columns(std::uint16_t* out) const {
        for (std::size_t v = 0; v < NV; ++v) {
            const Word8 left = __builtin_shufflevector(even[v], odd[v], 0, 8, 1, 9, 2, 10, 3, 11);
            const Word8 right = __builtin_shufflevector(even[v], odd[v], 15, 7, 14, 6, 13, 5, 12, 4);
            std::memcpy(out + 8 * v, &left, sizeof left);
            std::memcpy(out + 8 * (NV + v), &right, sizeof right);
        }
    }
};

}  // namespace

// edge_sums for columns <= 8 * NV, width >= 8 * NV, height <= 257 and rows <= kNarrowMaxRows:
// the leftmost and rightmost columns of every row summed in 16-bit vector lanes (at most 257 * 255
// per lane), the rows each band leaves out kept aside in the same lanes, and the band's column
// sums widened to 32 bits only for the running sums over columns. No scratch memory: this runs
// once per reference in every call (the per-frame match has no other query to share it with).
template <std::size_t NV>
void Window::edge_sums_narrow(const std::uint8_t* ref, std::size_t band_begin, std::size_t band_end,
                              std::uint32_t* out) const {
    const std::size_t width = full_.width, height = full_.height, sx = columns_, n = n_columns(), rows = rows_;
    SideSums<NV> top[kNarrowMaxRows + 1], bottom[kNarrowMaxRows + 1], middle;
    top[0].clear();
    bottom[0].clear();
    middle.clear();
    for (std::size_t k = 1; k <= rows; ++k) {  // top[k], bottom[k]: the k top (bottom) rows
        top[k] = top[k - 1];
        top[k].add_row(ref + (k - 1) * width, width);
        bottom[k] = bottom[k - 1];
        bottom[k].add_row(ref + (height - k) * width, width);
    }
    for (std::size_t r = rows; r < height - rows; ++r) middle.add_row(ref + r * width, width);
    // The top and bottom rows overlap when 2 * rows > height: then the bottom height - rows rows.
    const SideSums<NV> total = top[rows] + (2 * rows > height ? bottom[height - rows] : bottom[rows] + middle);
    for (std::size_t t = band_begin; t < band_end; ++t) {
        const std::int32_t d = dy(t);
        const SideSums<NV>& excluded = d < 0 ? top[magnitude(d)] : bottom[magnitude(d)];
        std::uint32_t* dst = out + (t - band_begin) * n;
        const std::uint32_t lead = band_lead(t) != 0 ? lead_sum(ref, t) : 0;
        if constexpr (NV == 1) {
            (total - excluded).running_sums(lead, sx, dst);
            continue;
        }
        // Column c from the left at band_cols[c], column width - 1 - c at band_cols[kRight + c].
        std::uint16_t band_cols[16 * NV];
        (total - excluded).columns(band_cols);
        constexpr std::size_t kRight = 8 * NV;
        dst[sx] = lead;
        std::uint32_t left = dst[sx], right = dst[sx];
        for (std::size_t c = 0; c < sx; ++c) {
            left += band_cols[c];
            right += band_cols[kRight + c];
            dst[sx - 1 - c] = left;
            dst[sx + 1 + c] = right;
        }
    }
}
#endif

}  // namespace nightloc::detail

namespace nightloc {

std::vector<std::int32_t> window_column_offsets(std::size_t height, std::size_t width, const std::int32_t* shifts,
                                                std::size_t n_shifts, const ShiftWindow& window) {
    return detail::Window(height, width, shifts, n_shifts, window).values();
}

}  // namespace nightloc
