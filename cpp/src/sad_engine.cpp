// Drivers of the SAD kernels: shift blocks, reference blocks, query blocks and threads.
#include <algorithm>
#include <cstring>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "nightloc/sad.hpp"
#include "nightloc/simd.hpp"
#include "parallel.hpp"
#include "query_plan.hpp"

namespace nightloc {
namespace {

using detail::QueryPlan;
using detail::SearchShape;

// A block of references should stay in L2 while every query of a query block scans it.
constexpr std::size_t kRefBlockBytes = std::size_t{256} * 1024;
// Prepared queries of one block, together: each reference block read from memory serves them all.
constexpr std::size_t kQueryBlockBytes = std::size_t{512} * 1024;
constexpr std::size_t kMaxQueryBlock = 64;
// References per task at most (bounds the per-task tile of results).
constexpr std::size_t kMaxRefsPerTask = 1 << 15;
// Smallest chunk of references of guided scheduling (~15 us of work at 48x24, all shifts).
constexpr std::size_t kMinGuidedChunk = 64;
// Below this many byte comparisons a second thread costs more than it saves (~50 us of work).
constexpr double kMinComparisonsPerThread = 1e7;

std::size_t ref_block_size(std::size_t pixels) {
    std::size_t n = kRefBlockBytes / pixels;
    n = n / 8 * 8;
    return n < 8 ? 8 : n;
}

int useful_threads(int threads, double comparisons) {
    if (threads <= 1) return 1;
    const double by_work = comparisons / kMinComparisonsPerThread;
    if (by_work < 2.0) return 1;
    return by_work < threads ? static_cast<int>(by_work) : threads;
}

float scaled(std::uint32_t sum, double divisor) { return static_cast<float>(static_cast<double>(sum) / divisor); }

// One task's results: rows = its queries, columns = its references.
struct Tile {
    std::size_t q_first, q_count, r_first, r_count;
    const std::uint32_t* sums;   // q_count x r_count
    const std::int32_t* shifts;  // q_count x r_count
};

// One task: queries [q_first, q_first + q_count) against references [r_first, r_first + r_count),
// with `plan` prepared for those queries and the first shift block when `prepared`, else
// prepared here (block by block). Returns the tile through sink.
template <class Sink>
void compute_tile(Tile tile, QueryPlan& plan, bool prepared, const std::uint8_t* queries, const std::uint8_t* refs,
                  const SearchShape& shape, Sink&& sink) {
    const std::size_t pixels = shape.pixels, n_shifts = shape.n_shifts;
    const std::size_t r_block = ref_block_size(pixels);
    std::vector<std::uint32_t> best(tile.q_count * tile.r_count, std::numeric_limits<std::uint32_t>::max());
    std::vector<std::int32_t> best_shift(tile.q_count * tile.r_count, shape.shifts[0]);
    // Per-(reference, query, slot) sums are only materialised when the kernel cannot take the
    // minimum itself.
    std::vector<std::uint32_t> slot_sums, scratch;
    if (!plan.fused_min()) {
        const std::size_t r_max = std::min(r_block, tile.r_count);
        slot_sums.resize(r_max * tile.q_count * plan.slots_per_block());
        scratch.resize(plan.scratch_size(r_max));
    }
    for (std::size_t slot = 0; slot < n_shifts; slot += plan.slots_per_block()) {
        if (!prepared) plan.prepare(queries + tile.q_first * pixels, tile.q_count, slot);
        const std::size_t n_slots = plan.slot_count();
        const std::size_t row_width = tile.q_count * n_slots;
        for (std::size_t r0 = 0; r0 < tile.r_count; r0 += r_block) {
            const std::size_t r_count = std::min(r_block, tile.r_count - r0);
            const std::uint8_t* block = refs + (tile.r_first + r0) * pixels;
            if (plan.fused_min()) {  // a single shift block: the kernel takes the minimum itself
                for (std::size_t k = 0; k < tile.q_count; ++k) {
                    plan.evaluate_min(k, block, r_count, best.data() + k * tile.r_count + r0,
                                      best_shift.data() + k * tile.r_count + r0);
                }
                continue;
            }
            plan.evaluate(block, r_count, slot_sums.data(), row_width, scratch.data());
            for (std::size_t k = 0; k < tile.q_count; ++k) {
                std::uint32_t* row_best = best.data() + k * tile.r_count + r0;
                std::int32_t* row_shift = best_shift.data() + k * tile.r_count + r0;
                for (std::size_t i = 0; i < r_count; ++i) {
                    const std::uint32_t* s = slot_sums.data() + i * row_width + k * n_slots;
                    for (std::size_t j = 0; j < n_slots; ++j) {
                        if (s[j] < row_best[i]) {  // strict: the earliest slot wins ties
                            row_best[i] = s[j];
                            row_shift[i] = shape.shifts[slot + j];
                        }
                    }
                }
            }
        }
    }
    tile.sums = best.data();
    tile.shifts = best_shift.data();
    sink(tile);
}

// The difference matrix as a set of tiles computed in parallel; sink(tile) is called once per
// tile, from the thread that computed it (tiles never overlap).
//
// Work split: blocks of queries (their prepared copies share L2 with a block of references) times
// chunks of references, handed out dynamically. A single query block (the per-frame match) is
// prepared once, before the threads start, and shared (evaluation is const); its references are
// cut into shrinking chunks (guided scheduling: each a quarter of what is left for two threads,
// down to 64 references, ~15 us), so that threads that start late (thread creation, another
// process on the core) or run slower still finish together: with equal chunks one thread could
// idle for up to a chunk at the end. Several query blocks: 4 equal chunks per thread and block.
template <class Sink>
void for_each_difference_tile(const std::uint8_t* queries, std::size_t n_queries, const std::uint8_t* refs,
                              std::size_t n_refs, const SearchShape& shape, int threads, Sink&& sink) {
    if (n_queries == 0 || n_refs == 0) return;
    const SimdBackend backend = active_simd_backend();
    const std::size_t pixels = shape.pixels;
    const std::size_t n_shifts = shape.n_shifts;

    const std::size_t q_block =
        std::clamp<std::size_t>(kQueryBlockBytes / detail::plan_bytes(backend, shape), 1, kMaxQueryBlock);
    const std::size_t n_q_blocks = (n_queries + q_block - 1) / q_block;
    const int n_threads = useful_threads(threads, static_cast<double>(n_queries) * static_cast<double>(n_refs) *
                                                      static_cast<double>(n_shifts) * static_cast<double>(pixels));
    const auto n_workers = static_cast<std::size_t>(n_threads);

    // Chunk c of the references is [bounds[c], bounds[c + 1]), multiples of 8 but the last.
    std::vector<std::size_t> bounds{0};
    if (n_workers > 1 && n_q_blocks == 1) {
        while (bounds.back() < n_refs) {
            const std::size_t left = n_refs - bounds.back();
            const std::size_t size = (std::max(kMinGuidedChunk, left / (2 * n_workers)) + 7) / 8 * 8;
            bounds.push_back(bounds.back() + std::min({size, left, kMaxRefsPerTask}));
        }
    } else {
        std::size_t n_chunks = (n_refs + kMaxRefsPerTask - 1) / kMaxRefsPerTask;
        if (n_workers > 1 && n_q_blocks < 4 * n_workers) {
            n_chunks = std::max(n_chunks, (4 * n_workers + n_q_blocks - 1) / n_q_blocks);
        }
        n_chunks = std::clamp<std::size_t>(n_chunks, 1, (n_refs + 7) / 8);
        for (std::size_t c = 1; c < n_chunks; ++c)
            bounds.push_back(std::max(bounds.back(), c * n_refs / n_chunks / 8 * 8));
        bounds.push_back(n_refs);
    }
    const std::size_t n_r_chunks = bounds.size() - 1;
    auto tile_of = [&](std::size_t task) {
        Tile tile{};
        tile.q_first = task / n_r_chunks * q_block;
        tile.q_count = std::min(q_block, n_queries - tile.q_first);
        tile.r_first = bounds[task % n_r_chunks];
        tile.r_count = bounds[task % n_r_chunks + 1] - tile.r_first;
        return tile;
    };

    if (n_q_blocks == 1) {
        QueryPlan shared(backend, shape);
        if (shared.slots_per_block() >= n_shifts) {
            shared.prepare(queries, n_queries, 0);
            detail::parallel_for(n_r_chunks, n_threads, [&](std::size_t task) {
                const Tile tile = tile_of(task);
                if (tile.r_count > 0) compute_tile(tile, shared, true, queries, refs, shape, sink);
            });
            return;
        }
    }
    detail::parallel_for(n_q_blocks * n_r_chunks, n_threads, [&](std::size_t task) {
        const Tile tile = tile_of(task);
        if (tile.r_count == 0) return;
        QueryPlan plan(backend, shape);
        compute_tile(tile, plan, false, queries, refs, shape, sink);
    });
}

void check_divisor(double divisor) {
    if (!(divisor > 0.0) || divisor == std::numeric_limits<double>::infinity()) {
        throw std::invalid_argument("the score divisor must be a positive finite number");
    }
}

}  // namespace

void rotational_sad_sums(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                         std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, std::uint32_t* sums,
                         int threads) {
    const SearchShape shape = detail::make_search_shape(height, width, shifts, n_shifts);
    if (n_refs == 0) return;
    QueryPlan plan(active_simd_backend(), shape);
    const std::size_t block = ref_block_size(shape.pixels);
    const std::size_t n_blocks = (n_refs + block - 1) / block;
    const int n_threads = useful_threads(
        threads, static_cast<double>(n_refs) * static_cast<double>(n_shifts) * static_cast<double>(shape.pixels));
    for (std::size_t slot = 0; slot < n_shifts; slot += plan.slots_per_block()) {
        plan.prepare(query, 1, slot);
        detail::parallel_for(n_blocks, n_threads, [&](std::size_t b) {
            const std::size_t first = b * block;
            const std::size_t count = std::min(block, n_refs - first);
            std::vector<std::uint32_t> scratch(plan.scratch_size(count));
            plan.evaluate(refs + first * shape.pixels, count, sums + first * n_shifts + slot, n_shifts, scratch.data());
        });
    }
}

void rotational_sad(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                    std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, float* scores, int threads,
                    double divisor) {
    if (divisor == 0.0) divisor = static_cast<double>(height * width);
    check_divisor(divisor);
    std::vector<std::uint32_t> sums(n_refs * n_shifts);
    rotational_sad_sums(query, refs, n_refs, height, width, shifts, n_shifts, sums.data(), threads);
    for (std::size_t k = 0; k < sums.size(); ++k) scores[k] = scaled(sums[k], divisor);
}

void difference_matrix_sums(const std::uint8_t* queries, std::size_t n_queries, const std::uint8_t* refs,
                            std::size_t n_refs, std::size_t height, std::size_t width, const std::int32_t* shifts,
                            std::size_t n_shifts, std::uint32_t* best_sums, std::int32_t* best_shifts, int threads) {
    const SearchShape shape = detail::make_search_shape(height, width, shifts, n_shifts);
    for_each_difference_tile(queries, n_queries, refs, n_refs, shape, threads, [&](const Tile& tile) {
        for (std::size_t k = 0; k < tile.q_count; ++k) {
            const std::size_t offset = (tile.q_first + k) * n_refs + tile.r_first;
            std::memcpy(best_sums + offset, tile.sums + k * tile.r_count, tile.r_count * sizeof(std::uint32_t));
            std::memcpy(best_shifts + offset, tile.shifts + k * tile.r_count, tile.r_count * sizeof(std::int32_t));
        }
    });
}

void difference_matrix(const std::uint8_t* queries, std::size_t n_queries, const std::uint8_t* refs, std::size_t n_refs,
                       std::size_t height, std::size_t width, const std::int32_t* shifts, std::size_t n_shifts,
                       float* scores, std::int32_t* best_shifts, int threads, double divisor) {
    const SearchShape shape = detail::make_search_shape(height, width, shifts, n_shifts);
    if (divisor == 0.0) divisor = static_cast<double>(shape.pixels);
    check_divisor(divisor);
    for_each_difference_tile(queries, n_queries, refs, n_refs, shape, threads, [&](const Tile& tile) {
        for (std::size_t k = 0; k < tile.q_count; ++k) {
            const std::size_t offset = (tile.q_first + k) * n_refs + tile.r_first;
            for (std::size_t i = 0; i < tile.r_count; ++i) {
                scores[offset + i] = scaled(tile.sums[k * tile.r_count + i], divisor);
            }
            std::memcpy(best_shifts + offset, tile.shifts + k * tile.r_count, tile.r_count * sizeof(std::int32_t));
        }
    });
}

std::size_t match(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                  std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, float* scores,
                  std::int32_t* best_shifts, double* headings, int threads) {
    if (n_refs == 0) throw std::invalid_argument("the reference stack is empty");
    const SearchShape shape = detail::make_search_shape(height, width, shifts, n_shifts);
    const auto pixels = static_cast<double>(height * width);
    // Scores, shifts and headings are written by the thread that computed the tile (no serial
    // pass after the threads); the best reference is the lowest (sum, index) over the tiles.
    std::mutex best_mutex;
    std::size_t best = n_refs;
    std::uint32_t best_sum = 0;
    for_each_difference_tile(query, 1, refs, n_refs, shape, threads, [&](const Tile& tile) {
        std::size_t tile_best = 0;
        for (std::size_t i = 0; i < tile.r_count; ++i) {
            const std::size_t r = tile.r_first + i;
            scores[r] = score_from_sum(tile.sums[i], pixels);
            best_shifts[r] = tile.shifts[i];
            if (tile.sums[i] < tile.sums[tile_best]) tile_best = i;  // the first minimum of the tile
        }
        if (headings != nullptr) {
            for (std::size_t i = 0; i < tile.r_count; ++i) {
                headings[tile.r_first + i] = shift_heading(tile.shifts[i], width);
            }
        }
        const std::uint32_t sum = tile.sums[tile_best];
        const std::size_t index = tile.r_first + tile_best;
        std::lock_guard<std::mutex> lock(best_mutex);
        if (best == n_refs || sum < best_sum || (sum == best_sum && index < best)) {  // ties: lowest index
            best = index;
            best_sum = sum;
        }
    });
    return best;
}

double shift_heading(std::int32_t shift, std::size_t width) noexcept {
    const double two_pi = 6.283185307179586476925286766559;
    const double angle = two_pi * static_cast<double>(shift) / static_cast<double>(width);
    return angle > 0.5 * two_pi ? angle - two_pi : angle;
}

}  // namespace nightloc
