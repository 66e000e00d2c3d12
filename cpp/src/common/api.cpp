// The Eigen-level C++ API (nightloc/nightloc.hpp) over the pointer-level core.
#include "nightloc/nightloc.hpp"

#include <numeric>
#include <stdexcept>
#include <string>

namespace nightloc {
namespace {

void require_same_geometry(Index h, Index w, const ImageStack& refs) {
    if (h != refs.height || w != refs.width) {
        throw std::invalid_argument("query is " + std::to_string(h) + " x " + std::to_string(w) +
                                    " pixels but the references are " + std::to_string(refs.height) + " x " +
                                    std::to_string(refs.width));
    }
}

void require_consistent(const ImageStack& stack) {
    if (stack.pixels.cols() != stack.height * stack.width) {
        throw std::invalid_argument(
            "ImageStack: pixels has " + std::to_string(stack.pixels.cols()) +
            " columns, expected height * width = " + std::to_string(stack.height * stack.width));
    }
}

std::vector<std::int32_t> resolve_shifts(const std::vector<std::int32_t>& shifts, Index width) {
    return shifts.empty() ? all_shifts(width) : shifts;
}

// A contiguous row-major copy when the query view is strided.
ImageU8 contiguous(const Eigen::Ref<const ImageU8>& image) { return ImageU8(image); }

}  // namespace

std::vector<std::int32_t> all_shifts(Index width) {
    std::vector<std::int32_t> shifts(static_cast<std::size_t>(width));
    std::iota(shifts.begin(), shifts.end(), 0);
    return shifts;
}

ImageStack patch_normalize(const ImageStack& images, int radius, bool wrap, double scale) {
    require_consistent(images);
    ImageStack out(images.count(), images.height, images.width);
    if (images.count() > 0) {
        nightloc::patch_normalize(images.data(), out.pixels.data(), static_cast<std::size_t>(images.count()),
                                  static_cast<std::size_t>(images.height), static_cast<std::size_t>(images.width),
                                  radius, wrap, scale);
    }
    return out;
}

ImageStack block_normalize(const ImageStack& images, int side) {
    require_consistent(images);
    ImageStack out(images.count(), images.height, images.width);
    if (images.count() > 0) {
        nightloc::block_normalize(images.data(), out.pixels.data(), static_cast<std::size_t>(images.count()),
                                  static_cast<std::size_t>(images.height), static_cast<std::size_t>(images.width),
                                  side);
    }
    return out;
}

MatchResult match(const Eigen::Ref<const ImageU8>& query, const ImageStack& refs,
                  const std::vector<std::int32_t>& shifts, const ShiftWindow& window, int threads) {
    require_consistent(refs);
    require_same_geometry(query.rows(), query.cols(), refs);
    const ImageU8 q = contiguous(query);
    const std::vector<std::int32_t> shift_list = resolve_shifts(shifts, refs.width);
    MatchResult result;
    result.scores.resize(refs.count());
    result.shifts.resize(refs.count());
    result.headings.resize(refs.count());
    result.rows.resize(refs.count());
    const std::size_t best = nightloc::match(
        q.data(), refs.data(), static_cast<std::size_t>(refs.count()), static_cast<std::size_t>(refs.height),
        static_cast<std::size_t>(refs.width), shift_list.data(), shift_list.size(), window, result.scores.data(),
        result.shifts.data(), result.rows.data(), result.headings.data(), threads);
    result.best = static_cast<Index>(best);
    return result;
}

MatchResult match(const Eigen::Ref<const ImageU8>& query, const ImageStack& refs,
                  const std::vector<std::int32_t>& shifts, int threads) {
    return match(query, refs, shifts, ShiftWindow{}, threads);
}

ShiftTable shift_table(const Eigen::Ref<const ImageU8>& query, const ImageStack& refs,
                       const std::vector<std::int32_t>& shifts, const ShiftWindow& window, int threads) {
    require_consistent(refs);
    require_same_geometry(query.rows(), query.cols(), refs);
    const ImageU8 q = contiguous(query);
    const std::vector<std::int32_t> shift_list = resolve_shifts(shifts, refs.width);
    ShiftTable table;
    table.columns = window_column_offsets(static_cast<std::size_t>(refs.height), static_cast<std::size_t>(refs.width),
                                          shift_list.data(), shift_list.size(), window);
    const auto n_columns = static_cast<Index>(table.columns.size());
    table.scores.resize(refs.count(), n_columns);
    table.rows.resize(refs.count(), n_columns);
    nightloc::rotational_sad(q.data(), refs.data(), static_cast<std::size_t>(refs.count()),
                             static_cast<std::size_t>(refs.height), static_cast<std::size_t>(refs.width),
                             shift_list.data(), shift_list.size(), window, table.scores.data(), table.rows.data(),
                             threads);
    return table;
}

MatrixXfR rotational_sad(const Eigen::Ref<const ImageU8>& query, const ImageStack& refs,
                         const std::vector<std::int32_t>& shifts, int threads) {
    return shift_table(query, refs, shifts, ShiftWindow{}, threads).scores;
}

DifferenceMatrix difference_matrix(const ImageStack& queries, const ImageStack& refs,
                                   const std::vector<std::int32_t>& shifts, const ShiftWindow& window, int threads) {
    require_consistent(queries);
    require_consistent(refs);
    require_same_geometry(queries.height, queries.width, refs);
    const std::vector<std::int32_t> shift_list = resolve_shifts(shifts, refs.width);
    DifferenceMatrix result;
    result.scores.resize(queries.count(), refs.count());
    result.shifts.resize(queries.count(), refs.count());
    result.rows.resize(queries.count(), refs.count());
    nightloc::difference_matrix(queries.data(), static_cast<std::size_t>(queries.count()), refs.data(),
                                static_cast<std::size_t>(refs.count()), static_cast<std::size_t>(refs.height),
                                static_cast<std::size_t>(refs.width), shift_list.data(), shift_list.size(), window,
                                result.scores.data(), result.shifts.data(), result.rows.data(), threads);
    return result;
}

DifferenceMatrix difference_matrix(const ImageStack& queries, const ImageStack& refs,
                                   const std::vector<std::int32_t>& shifts, int threads) {
    return difference_matrix(queries, refs, shifts, ShiftWindow{}, threads);
}

}  // namespace nightloc
