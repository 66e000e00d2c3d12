// Drivers of the SAD kernels: shift blocks, reference blocks, query blocks and threads.
#include <algorithm>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "common/parallel.hpp"
#include "common/simd_paths.hpp"
#include "matching/query_plan.hpp"
#include "matching/shift_window.hpp"
#include "nightloc/sad.hpp"

namespace nightloc {
namespace {

using detail::QueryPlan;
using detail::SearchShape;
using detail::SimdPath;
using detail::Window;

// A block of references should stay in L2 while every query of a query block scans it.
constexpr std::size_t kRefBlockBytes = std::size_t{256} * 1024;
// Most bytes of slot sums a tile keeps for all bands of a reference block at once (compute_tile).
constexpr std::size_t kAllBandSumsBytes = std::size_t{128} * 1024;
// Most queries for which compute_tile stages (aligns) the references of a forward window.
constexpr std::size_t kMaxStagingQueries = 4;
// Prepared queries of one block, together: each reference block read from memory serves them all.
constexpr std::size_t kQueryBlockBytes = std::size_t{512} * 1024;
constexpr std::size_t kMaxQueryBlock = 64;
// References per task at most (bounds the per-task tile of results).
constexpr std::size_t kMaxRefsPerTask = 1 << 15;
// Smallest chunk of references of guided scheduling (its time at 48x24, all shifts: docs/cpp_core.md).
constexpr std::size_t kMinGuidedChunk = 64;
// Below this many byte comparisons a second thread costs more than it saves (docs/cpp_core.md).
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

// One task's results: rows = its queries, columns = its references; the best candidate of each
// pair as its sum over the overlap and its rank (Window: rank -> column candidate, row offset).
struct Tile {
    std::size_t q_first, q_count, r_first, r_count;
    const std::uint32_t* sums;   // q_count x r_count
    const std::uint32_t* ranks;  // q_count x r_count
};

// The query plans of one block of queries, one per band (row offset) of the window.
class PlanSet {
public:
    PlanSet(const SimdPath& path, const Window& window) {
        plans_.reserve(window.n_bands());
        for (std::size_t t = 0; t < window.n_bands(); ++t) plans_.emplace_back(path, window.band(t));
    }
    QueryPlan& operator[](std::size_t band) { return plans_[band]; }
    /// True when every band's plan covers all slots in one block (prepared once per query block).
    bool single_block(std::size_t n_slots) const {
        return std::all_of(plans_.begin(), plans_.end(),
                           [&](const QueryPlan& p) { return p.slots_per_block() >= n_slots; });
    }
    /// Prepares `count` queries (whole images, `pixels` bytes apart) in every band (single_block only).
    void prepare_all(const std::uint8_t* queries, std::size_t count, const Window& window) {
        for (std::size_t t = 0; t < plans_.size(); ++t) {
            plans_[t].prepare(queries + window.query_offset(t), count, window.full().pixels, 0);
        }
    }
    std::size_t max_slots_per_block() const {
        std::size_t most = 0;
        for (const QueryPlan& p : plans_) most = std::max(most, p.slots_per_block());
        return most;
    }
    /// True when some band runs a SIMD copies kernel (it reads aligned references in place).
    bool any_simd_copies() const {
        return std::any_of(plans_.begin(), plans_.end(), [](const QueryPlan& p) { return p.simd_copies(); });
    }
    bool any_fused() const {
        return std::any_of(plans_.begin(), plans_.end(), [](const QueryPlan& p) { return p.fused_min(); });
    }
    std::size_t max_scratch(std::size_t n_refs) const {
        std::size_t most = 0;
        for (const QueryPlan& p : plans_) most = std::max(most, p.scratch_size(n_refs));
        return most;
    }

private:
    std::vector<QueryPlan> plans_;
};

std::size_t plan_set_bytes(const SimdPath& path, const Window& window) {
    std::size_t total = 0;
    for (std::size_t t = 0; t < window.n_bands(); ++t) total += detail::plan_bytes(path, window.band(t));
    return total;
}

// One task: queries [q_first, q_first + q_count) against references [r_first, r_first + r_count),
// with `plans` prepared for those queries when `prepared` (single-block plans only), else prepared
// here. Every candidate (band, slot) of every pair is merged into the pair's best (Window::better:
// the order of the merges does not matter). Returns the tile through sink.
// long: the hot loop nest of a tile (reference blocks x bands x slot blocks) and the buffers its
// kernels share; split, each step would take most of them as arguments
template <class Sink>
void compute_tile(Tile tile, PlanSet& plans, bool prepared, bool stage, const std::uint8_t* queries,
                  const std::uint8_t* refs, const Window& window, Sink&& sink) {
    const std::size_t pixels = window.full().pixels, n_slots_total = window.n_columns(), n_bands = window.n_bands();
    const std::size_t r_block = ref_block_size(pixels);
    const std::size_t r_max = std::min(r_block, tile.r_count);
    std::vector<std::uint32_t> best(tile.q_count * tile.r_count, std::numeric_limits<std::uint32_t>::max());
    std::vector<std::uint32_t> best_rank(tile.q_count * tile.r_count, Window::kNoRank);
    // Written by the kernels and edge_sums before they are read: left uninitialized.
    const std::unique_ptr<std::uint32_t[]> slot_sums(
        new std::uint32_t[r_max * tile.q_count * plans.max_slots_per_block()]);
    std::vector<std::uint32_t> scratch(plans.max_scratch(r_max));
    std::vector<std::uint32_t> mins(plans.any_fused() ? r_max : 0);
    std::vector<std::int32_t> min_shifts(mins.size());
    std::unique_ptr<std::uint32_t[]> edges;
    std::vector<std::uint32_t> edge_scratch;
    std::vector<float> keys(window.wrap() ? 0 : n_slots_total);

    // Band t of references [r0, r0 + r_count) of the tile; edge(i) = the edge sums of reference
    // r0 + i for this band's slots (non-wrapping searches).
    // `images` points at reference r0's image (in refs, or in the staged copy).
    auto evaluate_band = [&](std::size_t t, std::size_t r0, std::size_t r_count, const std::uint8_t* images,
                             const std::uint32_t* edge, std::size_t edge_stride) {
        QueryPlan& plan = plans[t];
        const std::uint8_t* block = images + window.ref_start(t);
        if (plan.fused_min()) {  // the kernel takes the minimum over the band's shifts itself
            for (std::size_t k = 0; k < tile.q_count; ++k) {
                plan.evaluate_min(k, block, r_count, mins.data(), min_shifts.data());
                std::uint32_t* row_best = best.data() + k * tile.r_count + r0;
                std::uint32_t* row_rank = best_rank.data() + k * tile.r_count + r0;
                for (std::size_t i = 0; i < r_count; ++i) {
                    const std::uint32_t rank = window.rank(t, window.slot_of_shift(min_shifts[i]));
                    if (window.better(mins[i], rank, row_best[i], row_rank[i])) {
                        row_best[i] = mins[i];
                        row_rank[i] = rank;
                    }
                }
            }
            return;
        }
        const std::size_t n_slots = plan.slot_count(), slot0 = plan.slot_begin();
        const std::size_t row_width = tile.q_count * n_slots;
        plan.evaluate(block, r_count, slot_sums.get(), row_width, scratch.data());
        for (std::size_t k = 0; k < tile.q_count; ++k) {
            std::uint32_t* row_best = best.data() + k * tile.r_count + r0;
            std::uint32_t* row_rank = best_rank.data() + k * tile.r_count + r0;
            for (std::size_t i = 0; i < r_count; ++i) {
                const std::uint32_t* s = slot_sums.get() + i * row_width + k * n_slots;
                if (window.wrap()) {  // one overlap in the band: the first minimum of the block
                    std::size_t j_best = 0;
                    for (std::size_t j = 1; j < n_slots; ++j)
                        if (s[j] < s[j_best]) j_best = j;
                    const std::uint32_t rank = window.rank(t, slot0 + j_best);
                    if (window.better(s[j_best], rank, row_best[i], row_rank[i])) {
                        row_best[i] = s[j_best];
                        row_rank[i] = rank;
                    }
                    continue;
                }
                std::uint32_t sum = 0, rank = 0;
                window.best_of_band(t, slot0, n_slots, s, edge + i * edge_stride + slot0, keys.data(), sum, rank);
                if (window.better(sum, rank, row_best[i], row_rank[i])) {
                    row_best[i] = sum;
                    row_rank[i] = rank;
                }
            }
        }
    };

    if (plans.single_block(n_slots_total)) {
        if (!prepared) plans.prepare_all(queries + tile.q_first * pixels, tile.q_count, window);
        if (!window.wrap()) edges.reset(new std::uint32_t[r_max * n_bands * n_slots_total]);
        detail::AlignedBytes staged;
        if (stage) staged.reserve(r_max * pixels);
        // A forward window with few queries (the per-frame match): the sums of all bands of a block
        // fit in L2 beside it, and one selection per pair over all candidates replaces one per band
        // and the merges.
        const std::size_t all_sums = r_max * tile.q_count * n_bands * n_slots_total;
        const bool select_over_bands = !window.wrap() && all_sums * sizeof(std::uint32_t) <= kAllBandSumsBytes;
        std::unique_ptr<std::uint32_t[]> window_sums(select_over_bands ? new std::uint32_t[all_sums] : nullptr);
        if (select_over_bands) keys.resize(n_bands * n_slots_total);
        for (std::size_t r0 = 0; r0 < tile.r_count; r0 += r_block) {
            const std::size_t r_count = std::min(r_block, tile.r_count - r0);
            const std::uint8_t* images = refs + (tile.r_first + r0) * pixels;
            if (stage) {
                std::memcpy(staged.data(), images, r_count * pixels);
                images = staged.data();
            }
            if (!window.wrap()) {
                for (std::size_t i = 0; i < r_count; ++i) {
                    window.edge_sums(refs + (tile.r_first + r0 + i) * pixels, 0, n_bands,
                                     edges.get() + i * n_bands * n_slots_total, edge_scratch);
                }
            }
            if (select_over_bands) {  // every band's sums, then one selection per pair over them all
                const std::size_t band_width = tile.q_count * n_slots_total, row_width = n_bands * band_width;
                for (std::size_t t = 0; t < n_bands; ++t) {
                    plans[t].evaluate(images + window.ref_start(t), r_count, window_sums.get() + t * band_width,
                                      row_width, scratch.data());
                }
                for (std::size_t k = 0; k < tile.q_count; ++k) {
                    for (std::size_t i = 0; i < r_count; ++i) {
                        const std::size_t pair = k * tile.r_count + r0 + i;
                        window.best_of_bands(window_sums.get() + i * row_width + k * n_slots_total, band_width,
                                             edges.get() + i * n_bands * n_slots_total, keys.data(), best[pair],
                                             best_rank[pair]);
                    }
                }
                continue;
            }
            for (std::size_t t = 0; t < n_bands; ++t) {
                evaluate_band(t, r0, r_count, images, edges.get() + t * n_slots_total, n_bands * n_slots_total);
            }
        }
    } else {  // large images: blocks of slots, each prepared in turn
        if (!window.wrap()) edges.reset(new std::uint32_t[r_max * n_slots_total]);
        for (std::size_t t = 0; t < n_bands; ++t) {
            for (std::size_t slot = 0; slot < n_slots_total; slot += plans[t].slots_per_block()) {
                plans[t].prepare(queries + tile.q_first * pixels + window.query_offset(t), tile.q_count, pixels, slot);
                for (std::size_t r0 = 0; r0 < tile.r_count; r0 += r_block) {
                    const std::size_t r_count = std::min(r_block, tile.r_count - r0);
                    if (!window.wrap()) {
                        for (std::size_t i = 0; i < r_count; ++i) {
                            window.edge_sums(refs + (tile.r_first + r0 + i) * pixels, t, t + 1,
                                             edges.get() + i * n_slots_total, edge_scratch);
                        }
                    }
                    evaluate_band(t, r0, r_count, refs + (tile.r_first + r0) * pixels, edges.get(), n_slots_total);
                }
            }
        }
    }
    tile.sums = best.data();
    tile.ranks = best_rank.data();
    sink(tile);
}

// The difference matrix as a set of tiles computed in parallel; sink(tile) is called once per
// tile, from the thread that computed it (tiles never overlap).
//
// Work split: blocks of queries (their prepared copies share L2 with a block of references) times
// chunks of references, handed out dynamically. A single query block (the per-frame match) is
// prepared once, before the threads start, and shared (evaluation is const); its references are
// cut into shrinking chunks (guided scheduling: each a quarter of what is left for two threads,
// down to 64 references), so that threads that start late (thread creation, another
// process on the core) or run slower still finish together: with equal chunks one thread could
// idle for up to a chunk at the end. Several query blocks: 4 equal chunks per thread and block.
template <class Sink>
void for_each_difference_tile(const std::uint8_t* queries, std::size_t n_queries, const std::uint8_t* refs,
                              std::size_t n_refs, const Window& search, int threads, Sink&& sink) {
    if (n_queries == 0 || n_refs == 0) return;
    const SimdPath& path = detail::active_simd_path();
    // The same candidates and ranks, the bands aligned to the path's vector width
    // (Window::align_bands), so that no band reads references across cache lines.
    // The bands of a forward window read each reference several times. For few queries, when the
    // references are not aligned to the vector width, the copies kernels would stage (align)
    // them in every band: each tile copies its block once, aligned, and the kernels read it in
    // place, on the paths whose registry entry stages references (SimdPath::stage_references).
    // Aligned references are read in place, and many queries share each staging of the copies
    // kernels.
    Window window = search;
    const std::size_t align = path.alignment, pixels = window.full().pixels;
    const std::size_t base = reinterpret_cast<std::uintptr_t>(refs) % align;
    const bool stage = path.stage_references && !window.wrap() && window.n_bands() > 1 && pixels % align == 0 &&
                       base != 0 && n_queries <= kMaxStagingQueries;
    if (pixels % align == 0) window.align_bands(align, stage ? 0 : base);

    const std::size_t q_block =
        std::clamp<std::size_t>(kQueryBlockBytes / plan_set_bytes(path, window), 1, kMaxQueryBlock);
    const std::size_t n_q_blocks = (n_queries + q_block - 1) / q_block;
    const int n_threads =
        useful_threads(threads, static_cast<double>(n_queries) * static_cast<double>(n_refs) * window.comparisons());
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
        PlanSet shared(path, window);
        if (shared.single_block(window.n_columns())) {
            shared.prepare_all(queries, n_queries, window);
            detail::parallel_for(n_r_chunks, n_threads, [&](std::size_t task) {
                const Tile tile = tile_of(task);
                if (tile.r_count > 0) compute_tile(tile, shared, true, stage, queries, refs, window, sink);
            });
            return;
        }
    }
    detail::parallel_for(n_q_blocks * n_r_chunks, n_threads, [&](std::size_t task) {
        const Tile tile = tile_of(task);
        if (tile.r_count == 0) return;
        PlanSet plans(path, window);
        compute_tile(tile, plans, false, stage, queries, refs, window, sink);
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
    QueryPlan plan(detail::active_simd_path(), shape);
    const std::size_t block = ref_block_size(shape.pixels);
    const std::size_t n_blocks = (n_refs + block - 1) / block;
    const int n_threads = useful_threads(
        threads, static_cast<double>(n_refs) * static_cast<double>(n_shifts) * static_cast<double>(shape.pixels));
    for (std::size_t slot = 0; slot < n_shifts; slot += plan.slots_per_block()) {
        plan.prepare(query, 1, shape.pixels, slot);
        detail::parallel_for(n_blocks, n_threads, [&](std::size_t b) {
            const std::size_t first = b * block;
            const std::size_t count = std::min(block, n_refs - first);
            std::vector<std::uint32_t> scratch(plan.scratch_size(count));
            plan.evaluate(refs + first * shape.pixels, count, sums + first * n_shifts + slot, n_shifts, scratch.data());
        });
    }
}

void rotational_sad(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                    std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, const ShiftWindow& window,
                    float* scores, std::int32_t* best_rows, int threads, double divisor) {
    Window win(height, width, shifts, n_shifts, window);
    if (divisor != 0.0) check_divisor(divisor);
    if (n_refs == 0) return;
    const SimdPath& path = detail::active_simd_path();
    const std::size_t align = path.alignment;
    if (win.full().pixels % align == 0) win.align_bands(align, reinterpret_cast<std::uintptr_t>(refs) % align);
    const std::size_t pixels = win.full().pixels, n_cols = win.n_columns();
    std::vector<std::uint32_t> best(n_refs * n_cols, std::numeric_limits<std::uint32_t>::max());
    std::vector<std::uint32_t> best_rank(n_refs * n_cols, Window::kNoRank);
    const std::size_t block = ref_block_size(pixels);
    const std::size_t n_blocks = (n_refs + block - 1) / block;
    const int n_threads = useful_threads(threads, static_cast<double>(n_refs) * win.comparisons());
    for (std::size_t t = 0; t < win.n_bands(); ++t) {
        QueryPlan plan(path, win.band(t));
        for (std::size_t slot = 0; slot < n_cols; slot += plan.slots_per_block()) {
            plan.prepare(query + win.query_offset(t), 1, pixels, slot);
            const std::size_t n_slots = plan.slot_count();
            detail::parallel_for(n_blocks, n_threads, [&](std::size_t b) {
                const std::size_t first = b * block;
                const std::size_t count = std::min(block, n_refs - first);
                std::vector<std::uint32_t> sums(count * n_slots), scratch(plan.scratch_size(count));
                plan.evaluate(refs + first * pixels + win.ref_start(t), count, sums.data(), n_slots, scratch.data());
                std::vector<std::uint32_t> edges(win.wrap() ? 0 : n_cols), edge_scratch;
                for (std::size_t i = 0; i < count; ++i) {
                    if (!win.wrap()) win.edge_sums(refs + (first + i) * pixels, t, t + 1, edges.data(), edge_scratch);
                    for (std::size_t j = 0; j < n_slots; ++j) {
                        const std::uint32_t sum = sums[i * n_slots + j] - (win.wrap() ? 0u : edges[slot + j]);
                        const std::uint32_t rank = win.rank(t, slot + j);
                        const std::size_t entry = (first + i) * n_cols + slot + j;
                        if (win.better(sum, rank, best[entry], best_rank[entry])) {
                            best[entry] = sum;
                            best_rank[entry] = rank;
                        }
                    }
                }
            });
        }
    }
    for (std::size_t e = 0; e < n_refs * n_cols; ++e) {
        scores[e] = window_score(best[e], win.overlap_of(best_rank[e]), pixels, divisor);
        if (best_rows != nullptr) best_rows[e] = win.dy_of(best_rank[e]);
    }
}

void rotational_sad(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                    std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, float* scores, int threads,
                    double divisor) {
    rotational_sad(query, refs, n_refs, height, width, shifts, n_shifts, ShiftWindow{}, scores, nullptr, threads,
                   divisor);
}

void difference_matrix_sums(const std::uint8_t* queries, std::size_t n_queries, const std::uint8_t* refs,
                            std::size_t n_refs, std::size_t height, std::size_t width, const std::int32_t* shifts,
                            std::size_t n_shifts, std::uint32_t* best_sums, std::int32_t* best_shifts, int threads) {
    const Window window(height, width, shifts, n_shifts, ShiftWindow{});
    for_each_difference_tile(queries, n_queries, refs, n_refs, window, threads, [&](const Tile& tile) {
        for (std::size_t k = 0; k < tile.q_count; ++k) {
            const std::size_t offset = (tile.q_first + k) * n_refs + tile.r_first;
            std::memcpy(best_sums + offset, tile.sums + k * tile.r_count, tile.r_count * sizeof(std::uint32_t));
            for (std::size_t i = 0; i < tile.r_count; ++i) {
                best_shifts[offset + i] = window.value_of(tile.ranks[k * tile.r_count + i]);
            }
        }
    });
}

void difference_matrix(const std::uint8_t* queries, std::size_t n_queries, const std::uint8_t* refs, std::size_t n_refs,
                       std::size_t height, std::size_t width, const std::int32_t* shifts, std::size_t n_shifts,
                       const ShiftWindow& shift_window, float* scores, std::int32_t* best_shifts,
                       std::int32_t* best_rows, int threads, double divisor) {
    const Window window(height, width, shifts, n_shifts, shift_window);
    if (divisor != 0.0) check_divisor(divisor);
    const std::size_t pixels = window.full().pixels;
    for_each_difference_tile(queries, n_queries, refs, n_refs, window, threads, [&](const Tile& tile) {
        for (std::size_t k = 0; k < tile.q_count; ++k) {
            const std::size_t offset = (tile.q_first + k) * n_refs + tile.r_first;
            const std::uint32_t* sums = tile.sums + k * tile.r_count;
            const std::uint32_t* ranks = tile.ranks + k * tile.r_count;
            for (std::size_t i = 0; i < tile.r_count; ++i) {
                scores[offset + i] = window_score(sums[i], window.overlap_of(ranks[i]), pixels, divisor);
                best_shifts[offset + i] = window.value_of(ranks[i]);
            }
            if (best_rows != nullptr) {
                for (std::size_t i = 0; i < tile.r_count; ++i) best_rows[offset + i] = window.dy_of(ranks[i]);
            }
        }
    });
}

void difference_matrix(const std::uint8_t* queries, std::size_t n_queries, const std::uint8_t* refs, std::size_t n_refs,
                       std::size_t height, std::size_t width, const std::int32_t* shifts, std::size_t n_shifts,
                       float* scores, std::int32_t* best_shifts, int threads, double divisor) {
    if (divisor == 0.0) divisor = static_cast<double>(height * width);
    check_divisor(divisor);
    difference_matrix(queries, n_queries, refs, n_refs, height, width, shifts, n_shifts, ShiftWindow{}, scores,
                      best_shifts, nullptr, threads, divisor);
}

std::size_t match(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                  std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, const ShiftWindow& shift_window,
                  float* scores, std::int32_t* best_shifts, std::int32_t* best_rows, double* headings, int threads) {
    if (n_refs == 0) throw std::invalid_argument("the reference stack is empty");
    const Window window(height, width, shifts, n_shifts, shift_window);
    const std::size_t pixels = window.full().pixels;
    // Scores, shifts and headings are written by the thread that computed the tile (no serial
    // pass after the threads); the best reference is the lowest (mean, index) over the tiles.
    std::mutex best_mutex;
    std::size_t best = n_refs;
    std::uint64_t best_sum = 0, best_overlap = 1;
    for_each_difference_tile(query, 1, refs, n_refs, window, threads, [&](const Tile& tile) {
        std::size_t tile_best = 0;
        std::uint64_t tile_sum = tile.sums[0], tile_overlap = window.overlap_of(tile.ranks[0]);
        for (std::size_t i = 0; i < tile.r_count; ++i) {
            const std::size_t r = tile.r_first + i;
            const std::uint32_t overlap = window.overlap_of(tile.ranks[i]);
            scores[r] = window_score(tile.sums[i], overlap, pixels, 0.0);
            best_shifts[r] = window.value_of(tile.ranks[i]);
            if (best_rows != nullptr) best_rows[r] = window.dy_of(tile.ranks[i]);
            if (tile.sums[i] * tile_overlap < tile_sum * overlap) {  // the first minimum of the tile
                tile_best = i;
                tile_sum = tile.sums[i];
                tile_overlap = overlap;
            }
        }
        if (headings != nullptr) {
            for (std::size_t i = 0; i < tile.r_count; ++i) {
                headings[tile.r_first + i] = shift_heading(window.value_of(tile.ranks[i]), width);
            }
        }
        const std::size_t index = tile.r_first + tile_best;
        std::lock_guard<std::mutex> lock(best_mutex);
        const std::uint64_t lhs = tile_sum * best_overlap, rhs = best_sum * tile_overlap;
        if (best == n_refs || lhs < rhs || (lhs == rhs && index < best)) {  // ties: lowest index
            best = index;
            best_sum = tile_sum;
            best_overlap = tile_overlap;
        }
    });
    return best;
}

std::size_t match(const std::uint8_t* query, const std::uint8_t* refs, std::size_t n_refs, std::size_t height,
                  std::size_t width, const std::int32_t* shifts, std::size_t n_shifts, float* scores,
                  std::int32_t* best_shifts, double* headings, int threads) {
    return match(query, refs, n_refs, height, width, shifts, n_shifts, ShiftWindow{}, scores, best_shifts, nullptr,
                 headings, threads);
}

double shift_heading(std::int32_t shift, std::size_t width) noexcept {
    const double two_pi = 6.283185307179586476925286766559;
    const double angle = two_pi * static_cast<double>(shift) / static_cast<double>(width);
    return angle > 0.5 * two_pi ? angle - two_pi : angle;
}

}  // namespace nightloc
