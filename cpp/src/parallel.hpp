// Internal: a minimal fork-join loop over independent tasks.
#pragma once

#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace nightloc::detail {

/// Runs body(task) for every task in [0, n_tasks) on up to `threads` threads (the caller's
/// thread included), handing tasks out dynamically. The first exception thrown by a task is
/// rethrown after all threads have joined; remaining tasks are skipped.
template <class Body>
void parallel_for(std::size_t n_tasks, int threads, Body&& body) {
    std::size_t n_threads = threads > 1 ? static_cast<std::size_t>(threads) : 1;
    if (n_threads > n_tasks) n_threads = n_tasks;
    if (n_threads <= 1) {
        for (std::size_t t = 0; t < n_tasks; ++t) body(t);
        return;
    }
    std::atomic<std::size_t> next{0};
    std::atomic<bool> failed{false};
    std::exception_ptr error;
    std::mutex error_mutex;
    auto worker = [&]() {
        for (;;) {
            if (failed.load(std::memory_order_relaxed)) return;
            const std::size_t t = next.fetch_add(1, std::memory_order_relaxed);
            if (t >= n_tasks) return;
            try {
                body(t);
            } catch (...) {
                std::lock_guard<std::mutex> lock(error_mutex);
                if (!error) error = std::current_exception();
                failed.store(true, std::memory_order_relaxed);
            }
        }
    };
    std::vector<std::thread> pool;
    pool.reserve(n_threads - 1);
    try {
        for (std::size_t i = 0; i + 1 < n_threads; ++i) pool.emplace_back(worker);
    } catch (...) {
        // Could not start a thread: the threads already started and this one finish the work.
    }
    worker();
    for (auto& thread : pool) thread.join();
    if (error) std::rethrow_exception(error);
}

}  // namespace nightloc::detail
