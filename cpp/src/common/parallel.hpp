// Internal: a fork-join loop over independent tasks, run on a persistent pool of worker threads.
#pragma once

#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>

namespace nightloc::detail {

/// A job for the worker pool: `run` is called by each engaged helper thread with `context`.
struct PoolJob {
    void (*run)(void* context) = nullptr;
    void* context = nullptr;
};

/// Runs `job` on up to `helpers` threads of the process-wide worker pool while the calling thread
/// runs `job.run(job.context)` too; returns when the caller's part and every helper that took part are
/// done. Helpers that wake after the caller's part is finished no longer join. The pool's threads
/// are started on first use, kept for the life of the process (a fork starts a fresh pool in the
/// child), and spin briefly before sleeping so that back-to-back calls do not pay a wake-up.
/// When the pool is busy with another caller's job, plain threads are started for this one.
void run_on_pool(std::size_t helpers, const PoolJob& job);

/// Runs body(task) for every task in [0, n_tasks) on up to `threads` threads (the caller's
/// thread included), handing tasks out dynamically. The first exception thrown by a task is
/// rethrown after all threads are done; remaining tasks are skipped.
template <class Body>
void parallel_for(std::size_t n_tasks, int threads, Body&& body) {
    std::size_t n_threads = threads > 1 ? static_cast<std::size_t>(threads) : 1;
    if (n_threads > n_tasks) n_threads = n_tasks;
    if (n_threads <= 1) {
        for (std::size_t t = 0; t < n_tasks; ++t) body(t);
        return;
    }
    struct State {
        Body* body = nullptr;
        std::size_t n_tasks = 0;
        std::atomic<std::size_t> next{0};
        std::atomic<bool> failed{false};
        std::exception_ptr error;
        std::mutex error_mutex;
    } state;
    state.body = &body;
    state.n_tasks = n_tasks;
    auto work = [](void* context) {
        auto& s = *static_cast<State*>(context);
        for (;;) {
            if (s.failed.load(std::memory_order_relaxed)) return;
            const std::size_t t = s.next.fetch_add(1, std::memory_order_relaxed);
            if (t >= s.n_tasks) return;
            try {
                (*s.body)(t);
            } catch (...) {
                std::lock_guard<std::mutex> lock(s.error_mutex);
                if (!s.error) s.error = std::current_exception();
                s.failed.store(true, std::memory_order_relaxed);
            }
        }
    };
    run_on_pool(n_threads - 1, PoolJob{work, &state});
    if (state.error) std::rethrow_exception(state.error);
}

}  // namespace nightloc::detail
