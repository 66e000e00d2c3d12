// Min-warping of 360-degree panoramas: the teach run's relative heading and direction of travel
// between two frames taken apart (python/nightloc/mapping/warping.py builds the geometry and
// reads the costs; docs/teach_run.md explains the method).
//
// A landmark seen by frame A at angle theta from the direction of travel appears in frame B
// farther from that direction on the same side, at a vertical magnification the geometry fixes.
// For each hypothesis (direction of travel g on a grid, column shift k = the relative heading)
// every column c of A takes its best match over the columns of B its landmark may have moved to,
// each compared at its magnification; the hypothesis's cost is the mean of those best matches.
//
// All arithmetic is integer sums of absolute differences, one double product per (scale, column,
// column) entry and sequential double sums in a fixed order: the same bits on every architecture
// (the library is built without FMA contraction).
#pragma once

#include <cstddef>
#include <cstdint>

namespace nightloc {

/// The geometry of min-warping (built by the Python layer, checked by warp_costs).
struct WarpGeometry {
    std::size_t height = 0;      ///< rows of a prepared image, H
    std::size_t width = 0;       ///< columns of a prepared image, W (a full turn)
    std::size_t scales = 0;      ///< vertical magnifications, L: each frame's stack holds L copies
    std::size_t directions = 0;  ///< directions of travel on the grid, G
    std::size_t moves = 0;       ///< moves per column in `level`, M (column c moves 0 .. M-1 columns)
    /// (L,) the rows [row_begin[l], row_end[l]) of magnification l that show the frame (an empty
    /// range: magnification l is not compared).
    const std::int32_t* row_begin = nullptr;
    const std::int32_t* row_end = nullptr;
    /// (G, W, M): the magnification (0 .. L-1) at which column c of A, moved m columns away from
    /// direction g, is compared with B; L: the best over all magnifications; -1: not allowed.
    const std::int32_t* level = nullptr;
    /// (G, W): +1 or -1; column c of A moved m columns lands on B's column c + k - sign * m.
    const std::int32_t* sign = nullptr;
};

/// Min-warping costs of pairs of frames.
///
/// images: (n_frames, H, W) uint8 prepared panoramas; stacks: (n_frames, L, H, W) uint8, each
/// frame magnified by each scale (rows outside [row_begin, row_end) are not read).
/// pairs: (n_pairs, 2) frame indices (A, B). For pair p, direction d (0 .. n_directions-1) is
/// grid direction (first_direction[p] + d) mod G and shift s (0 .. n_shifts-1) is column shift
/// first_shift[p] + s (mod W). out: (n_pairs, n_directions, n_shifts):
///
///   cost(l, c, c') = (sum over rows r of |stacks[A, l, r, c] - images[B, r, c']|) * (1 / row count)
///                    (+inf for an empty range; l = L: the least over l)
///   out[p, d, s]   = mean over the columns c of A that have a finite best of
///                    min over allowed m of cost(level[g, c, m], c, (c + k - sign[g, c] * m) mod W)
///                    (summed in column order; +inf when no column has one)
///
/// Runs on up to `threads` threads. Throws std::invalid_argument naming the problem for empty
/// sizes, frame indices out of range, tables out of range or a row range outside the image.
void warp_costs(const std::uint8_t* images, const std::uint8_t* stacks, std::size_t n_frames,
                const WarpGeometry& geometry, const std::int32_t* pairs, std::size_t n_pairs,
                const std::int32_t* first_direction, std::size_t n_directions, const std::int32_t* first_shift,
                std::size_t n_shifts, double* out, int threads = 1);

}  // namespace nightloc
