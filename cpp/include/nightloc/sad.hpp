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
#pragma once

#include <cstddef>
#include <cstdint>

namespace nightloc {

/// Largest supported image (pixels): keeps every sum below 2^32.
inline constexpr std::size_t kMaxImagePixels = std::size_t{1} << 24;

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

/// The query's heading relative to the reference for a best shift of `shift` columns of a
/// `width`-column panorama: 2*pi*shift/width, wrapped to (-pi, pi].
double shift_heading(std::int32_t shift, std::size_t width) noexcept;

/// The score of a sum, as the functions above compute it.
inline float score_from_sum(std::uint32_t sum, double divisor) noexcept {
    return static_cast<float>(static_cast<double>(sum) / divisor);
}

}  // namespace nightloc
