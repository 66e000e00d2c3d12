// Rotation-invariant sum of absolute differences (Mount & Milford eqs. 2-3), pointer-level API.
//
// Images are C-contiguous uint8, `height` x `width`; a stack of n images is n*height*width bytes.
// Shift convention: for shift k (0 <= k < width), the query rolled left by k columns,
//     Q_k(r, c) = Q(r, (c + k) mod width)        (numpy: np.roll(Q, -k, axis=1))
// is compared with the reference:  sum_k = sum_{r,c} |Q_k(r, c) - R(r, c)|.
// If the query is the reference rolled right by d columns (Q = np.roll(R, d, axis=1)), the best
// shift is d. With the panorama convention of nightloc (column c looks along heading - 2*pi*c/W)
// the query's heading relative to the reference is +2*pi*k/width.
//
// A shift list selects which k are searched (all 0..width-1 for a panorama, {0} for a forward
// camera); every value must be in [0, width) and appear once. Minimum ties go to the earliest
// entry of the list. All SIMD paths give bit-identical sums.
//
// Translation window (viewpoint tolerance, ShiftWindow below): a robot a few metres beside its
// day path sees the scene moved by a few pixels. On top of the column candidates the search
// tries the row offsets dy in [-rows, rows], and for a non-wrapping image (a forward camera,
// shift list {0}) the column offsets dx in [-columns, columns] instead of circular shifts.
// Candidate (column candidate, dy) compares
//     circular k:        Q(r + dy, (c + k) mod W)  with R(r, c)
//     non-wrapping dx:   Q(r + dy, c + dx)         with R(r, c)
// over the overlap, the pixels (r, c) of R where the query pixel exists: (H - |dy|) * W pixels for
// circular shifts, (H - |dy|) * (W - |dx|) for column offsets. If the query is the reference moved
// down by d rows and right by e columns, the best candidate is dy = d, dx = e (as for k).
//  - The best candidate has the lowest mean sum / overlap, compared exactly (integer cross
//    products sum_a * overlap_b < sum_b * overlap_a); equal means go to the earlier candidate in
//    the order: row offsets 0, -1, +1, -2, +2, ...; within one row offset the shift list's order
//    (circular) or the column offsets 0, -1, +1, -2, +2, ... (non-wrapping).
//  - Its score is window_score(sum, overlap, pixels, divisor): by default float32(double(sum) /
//    overlap), the mean absolute difference over the overlap in grey levels.
//  - A window of {0, 0} is the plain search above, bit for bit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace nightloc {

/// Largest supported image (pixels): keeps every sum below 2^32.
inline constexpr std::size_t kMaxImagePixels = std::size_t{1} << 24;

/// The translation window searched on top of the column candidates (see above). `rows` must be
/// below the image height and `columns` below its width (an offset as wide as the image leaves no
/// overlap); `columns` > 0 needs the shift list {0} (a non-wrapping image: panoramas search their
/// columns with circular shifts).
struct ShiftWindow {
    std::size_t columns = 0;  ///< non-wrapping column offsets -columns .. columns
    std::size_t rows = 0;     ///< row offsets -rows .. rows
};

/// The column candidates of a search over height x width images, in the order of a table's
/// columns: the shift list (window columns 0) or the column offsets -columns .. columns. Throws
/// std::invalid_argument, as the search functions do, for invalid sizes, shifts or window.
std::vector<std::int32_t> window_column_offsets(std::size_t height, std::size_t width, const std::int32_t* shifts,
                                                std::size_t n_shifts, const ShiftWindow& window);

/// The score of a candidate's sum over `overlap` of the image's `pixels` pixels:
/// float32(double(sum) / d), d = overlap when divisor = 0 (the mean absolute difference); else
/// d = divisor at full overlap and (divisor * overlap) / pixels (in double) below it, so that an
/// explicit divisor of `pixels` also gives the mean.
inline float window_score(std::uint32_t sum, std::size_t overlap, std::size_t pixels, double divisor) noexcept {
    double d = static_cast<double>(overlap);
    if (divisor != 0.0) {
        d = overlap == pixels ? divisor : divisor * static_cast<double>(overlap) / static_cast<double>(pixels);
    }
    return static_cast<float>(static_cast<double>(sum) / d);
}

/// Full table: sums[i * n_shifts + j] = sum_{shifts[j]}(query, refs[i]). Uses up to `threads`
/// threads (<= 0: one). Throws std::invalid_argument on invalid sizes or shifts.
void rotational_sad_sums(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                         std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, std::uint32_t* sums,
                         int threads = 1);

/// Difference matrix: for every query q and reference r, the minimum over the shift list,
/// best_sums[q * n_refs + r], and the shift value that attains it, best_shifts[q * n_refs + r].
/// References are processed in cache-sized blocks, each streamed once per block of queries;
/// work is spread over `threads` threads (<= 0: one). Extra memory: a few hundred KB per thread.
void difference_matrix_sums(const std::uint8_t* queries, std::size_t n_queries, const std::uint8_t* refs,
                            std::size_t n_refs, std::size_t height, std::size_t width, const std::int32_t* shifts,
                            std::size_t n_shifts, std::uint32_t* best_sums, std::int32_t* best_shifts, int threads = 1);

/// Scores as float32: score = float(double(sum) / divisor). divisor = 0 means height * width,
/// i.e. the mean absolute difference in grey levels (the paper's eq. 2); OpenSeqSLAM divides by
/// the number of references instead.
void rotational_sad(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                    std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, float* scores, int threads = 1,
                    double divisor = 0.0);

/// Difference matrix as float32 scores (see rotational_sad for `divisor`): scores and
/// best_shifts are (n_queries, n_refs) row-major. No memory beyond the outputs is needed except a
/// per-thread tile of at most 16 x 32768 entries.
void difference_matrix(const std::uint8_t* queries, std::size_t n_queries, const std::uint8_t* refs, std::size_t n_refs,
                       std::size_t height, std::size_t width, const std::int32_t* shifts, std::size_t n_shifts,
                       float* scores, std::int32_t* best_shifts, int threads = 1, double divisor = 0.0);

/// The per-frame call: one query against all references. For every reference i, scores[i] is
/// the mean absolute difference (grey levels, float32) at its best shift and best_shifts[i] that
/// shift; headings[i] (optional, nullptr skips it) the query's heading relative to the reference
/// in radians (shift_heading). Returns the index of the reference with the lowest sum, ties going
/// to the lowest index. Throws std::invalid_argument when n_refs is 0 or as difference_matrix_sums.
std::size_t match(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                  std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, float* scores,
                  std::int32_t* best_shifts, double* headings = nullptr, int threads = 1);

/// Table with a translation window: for every reference i and column candidate j
/// (window_column_offsets), scores[i * n_columns + j] is the best score over the row offsets
/// (window_score) and best_rows[i * n_columns + j] (optional, nullptr skips it) its row offset dy.
/// With window {0, 0} this is rotational_sad. Throws std::invalid_argument on invalid sizes,
/// shifts or window.
void rotational_sad(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                    std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, const ShiftWindow& window,
                    float* scores, std::int32_t* best_rows, int threads = 1, double divisor = 0.0);

/// Difference matrix with a translation window: for every query q and reference r, the score of
/// the best candidate (see above), its column candidate best_shifts[q * n_refs + r] (shift k, or
/// the column offset dx of a non-wrapping search) and its row offset best_rows[q * n_refs + r]
/// (optional, nullptr skips it). With window {0, 0} this is difference_matrix.
void difference_matrix(const std::uint8_t* queries, std::size_t n_queries, const std::uint8_t* refs, std::size_t n_refs,
                       std::size_t height, std::size_t width, const std::int32_t* shifts, std::size_t n_shifts,
                       const ShiftWindow& window, float* scores, std::int32_t* best_shifts, std::int32_t* best_rows,
                       int threads = 1, double divisor = 0.0);

/// The per-frame call with a translation window: as match above, plus best_rows[i] (optional) the
/// best row offset; scores are window_score means; the best reference has the lowest mean
/// (compared exactly), ties going to the lowest index. headings are shift_heading of the column
/// candidate (for a non-wrapping search, of the column offset dx).
std::size_t match(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                  std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, const ShiftWindow& window,
                  float* scores, std::int32_t* best_shifts, std::int32_t* best_rows, double* headings = nullptr,
                  int threads = 1);

/// The query's heading relative to the reference for a best shift of `shift` columns of a
/// `width`-column panorama: 2*pi*shift/width, wrapped to (-pi, pi].
double shift_heading(std::int32_t shift, std::size_t width) noexcept;

/// The score of a sum, as the functions above compute it.
inline float score_from_sum(std::uint32_t sum, double divisor) noexcept {
    return static_cast<float>(static_cast<double>(sum) / divisor);
}

}  // namespace nightloc
