// nightloc C++ API over Eigen types: the core of "2D Visual Place Recognition for Domestic
// Service Robots at Night" (Mount & Milford, 2016) for firmware and C++ programs.
//
//   #include <nightloc/nightloc.hpp>
//   nightloc::ImageStack refs(50, 24, 48);                 // 50 images of 24 x 48 pixels
//   ... fill refs.image(i) ...
//   auto prepared = nightloc::patch_normalize(refs);
//   auto result = nightloc::match(prepared.image(0), prepared);   // best reference, scores, shifts
//
// The pointer-level API (sad.hpp, normalize.hpp) is what these wrap; see sad.hpp for the shift and
// heading conventions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "nightloc/normalize.hpp"
#include "nightloc/sad.hpp"
#include "nightloc/simd.hpp"

namespace nightloc {

using Index = Eigen::Index;
/// One image, row-major (height x width), uint8.
using ImageU8 = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
/// Row-major float32 matrix: difference matrices are (n_query, n_ref).
using MatrixXfR = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
/// Row-major int32 matrix: best shifts (n_query, n_ref).
using MatrixXiR = Eigen::Matrix<std::int32_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// A stack of equally sized uint8 images: one image per row of `pixels`, each row holding the
/// image row-major (height * width bytes) - the same memory layout as a numpy (n, h, w) array.
struct ImageStack {
    Eigen::Matrix<std::uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> pixels;
    Index height = 0;
    Index width = 0;

    ImageStack() = default;
    ImageStack(Index count, Index h, Index w) : pixels(count, h * w), height(h), width(w) { pixels.setZero(); }

    Index count() const { return pixels.rows(); }
    /// Image i as a (height x width) row-major map.
    Eigen::Map<ImageU8> image(Index i) { return {pixels.row(i).data(), height, width}; }
    Eigen::Map<const ImageU8> image(Index i) const { return {pixels.row(i).data(), height, width}; }
    const std::uint8_t* data() const { return pixels.data(); }
};

/// Result of matching one query against a reference stack.
struct MatchResult {
    Index best = -1;           ///< index of the reference with the lowest score
    Eigen::VectorXf scores;    ///< (n_ref,) minimum mean absolute difference, grey levels
    Eigen::VectorXi shifts;    ///< (n_ref,) column shift attaining it (see sad.hpp); column offset dx
                               ///< with a column window
    Eigen::VectorXd headings;  ///< (n_ref,) query heading relative to each reference, radians in (-pi, pi]
    Eigen::VectorXi rows;      ///< (n_ref,) row offset dy of the best candidate (0 without a row window)
};

/// Difference matrix of a query stack against a reference stack.
struct DifferenceMatrix {
    MatrixXfR scores;  ///< (n_query, n_ref) minimum mean absolute difference
    MatrixXiR shifts;  ///< (n_query, n_ref) best column shift (column offset dx with a column window)
    MatrixXiR rows;    ///< (n_query, n_ref) best row offset dy (0 without a row window)
};

/// Scores of one query for every reference and column candidate, each the best over the row
/// offsets of a translation window (sad.hpp).
struct ShiftTable {
    MatrixXfR scores;                   ///< (n_ref, n_columns) mean absolute difference over the overlap
    MatrixXiR rows;                     ///< (n_ref, n_columns) row offset dy of each entry
    std::vector<std::int32_t> columns;  ///< (n_columns) the shift k or column offset dx of each column
};

/// All shifts 0..width-1 (a full panorama).
std::vector<std::int32_t> all_shifts(Index width);

/// Patch normalization (eq. 1) of every image; see normalize.hpp.
ImageStack patch_normalize(const ImageStack& images, int radius = 4, bool wrap = true,
                           double scale = kDefaultPatchScale);

/// OpenSeqSLAM block normalization of every image; see normalize.hpp.
ImageStack block_normalize(const ImageStack& images, int side = 8);

/// Rotation-invariant match of one query image (height x width of refs) against all references.
/// An empty shift list means all shifts.
MatchResult match(const Eigen::Ref<const ImageU8>& query, const ImageStack& refs,
                  const std::vector<std::int32_t>& shifts = {}, int threads = 1);

/// Full (n_ref, n_shifts) table of mean absolute differences.
MatrixXfR rotational_sad(const Eigen::Ref<const ImageU8>& query, const ImageStack& refs,
                         const std::vector<std::int32_t>& shifts = {}, int threads = 1);

/// (n_query, n_ref) difference matrix, multithreaded.
DifferenceMatrix difference_matrix(const ImageStack& queries, const ImageStack& refs,
                                   const std::vector<std::int32_t>& shifts = {}, int threads = 1);

/// The same three with a translation window (sad.hpp: row offsets, and column offsets for a
/// forward camera searched at shifts {0}); scores are means over the overlap.
MatchResult match(const Eigen::Ref<const ImageU8>& query, const ImageStack& refs,
                  const std::vector<std::int32_t>& shifts, const ShiftWindow& window, int threads = 1);
ShiftTable shift_table(const Eigen::Ref<const ImageU8>& query, const ImageStack& refs,
                       const std::vector<std::int32_t>& shifts, const ShiftWindow& window, int threads = 1);
DifferenceMatrix difference_matrix(const ImageStack& queries, const ImageStack& refs,
                                   const std::vector<std::int32_t>& shifts, const ShiftWindow& window, int threads = 1);

}  // namespace nightloc
