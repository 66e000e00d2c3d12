// The process-wide worker pool behind detail::parallel_for (see parallel.hpp).
#include "common/parallel.hpp"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <thread>
#include <vector>

#include "common/arch.hpp"

#if defined(__unix__) || defined(__APPLE__)
#include <pthread.h>
#define NIGHTLOC_HAVE_ATFORK 1
#endif

namespace nightloc::detail {
namespace {

/// How long a helper spins on the job counter after its work before it sleeps: back-to-back calls
/// (a stream of frames matched as fast as they come) find it awake; an idle pool costs nothing.
constexpr auto kSpin = std::chrono::microseconds(200);

/// How long the caller, its own part done, spins on the helpers' completion before it sleeps:
/// with shrinking chunks they finish within one chunk of each other, and a sleep costs a wake-up
/// on top (docs/cpp_core.md, "Threads", has the times).
constexpr auto kFinishSpin = std::chrono::microseconds(100);

/// A hint to the CPU that this thread is spinning.
inline void cpu_relax() noexcept {
#if NIGHTLOC_X86_KERNELS
    __builtin_ia32_pause();
#elif NIGHTLOC_ARM_KERNELS
    asm volatile("yield" ::: "memory");
#endif
}

class WorkerPool {
public:
    /// Runs job on up to `helpers` pool threads and job.run on the caller; false when busy.
    bool run(std::size_t helpers, const PoolJob& job) {
        std::unique_lock<std::mutex> busy(busy_, std::try_to_lock);
        if (!busy.owns_lock()) return false;
        grow(helpers);
        {
            std::lock_guard<std::mutex> lock(mutex_);
            job_ = job;
            wanted_ = helpers;
            claimed_ = 0;
            active_ = 0;
            generation_.fetch_add(1, std::memory_order_release);
        }
        wake_.notify_all();
        job.run(job.context);
        {
            std::lock_guard<std::mutex> lock(mutex_);
            wanted_ = claimed_;  // the work is done: helpers that wake now do not join
        }
        const auto spin_until = std::chrono::steady_clock::now() + kFinishSpin;
        while (active_.load(std::memory_order_acquire) != 0 && std::chrono::steady_clock::now() < spin_until) {
            cpu_relax();
        }
        std::unique_lock<std::mutex> lock(mutex_);
        done_.wait(lock, [&] { return active_.load(std::memory_order_relaxed) == 0; });
        return true;
    }

private:
    void grow(std::size_t helpers) {
        while (threads_.size() < helpers) {
            try {
                threads_.emplace_back([this] { loop(); });
                threads_.back().detach();  // lives as long as the process (never joined)
            } catch (...) {
                return;  // fewer helpers: the caller does the rest
            }
        }
    }

    void loop() {
        std::uint64_t seen = generation_.load(std::memory_order_acquire);
        for (;;) {
            const auto spin_until = std::chrono::steady_clock::now() + kSpin;
            while (generation_.load(std::memory_order_acquire) == seen &&
                   std::chrono::steady_clock::now() < spin_until) {
                std::this_thread::yield();
            }
            std::unique_lock<std::mutex> lock(mutex_);
            wake_.wait(lock, [&] { return generation_.load(std::memory_order_relaxed) != seen; });
            seen = generation_.load(std::memory_order_relaxed);
            if (claimed_ >= wanted_) continue;  // enough helpers, or the job is already done
            ++claimed_;
            ++active_;
            const PoolJob job = job_;
            lock.unlock();
            job.run(job.context);
            lock.lock();
            if (--active_ == 0) done_.notify_all();
        }
    }

    std::mutex busy_;   // one job at a time
    std::mutex mutex_;  // guards the fields below
    std::condition_variable wake_, done_;
    std::atomic<std::uint64_t> generation_{0};
    PoolJob job_;
    std::size_t wanted_ = 0, claimed_ = 0;
    std::atomic<std::size_t> active_{0};  // helpers running the job; changed under mutex_, read spinning
    std::vector<std::thread> threads_;
};

std::mutex g_pool_mutex;
WorkerPool* g_pool = nullptr;  // never deleted: its threads live as long as the process

#ifdef NIGHTLOC_HAVE_ATFORK
// A forked child has only the thread that forked (none of the pool's): it gets a new pool on
// first use. The old object, with its locks copied in whatever state, is left alone.
void lock_before_fork() { g_pool_mutex.lock(); }
void unlock_after_fork() { g_pool_mutex.unlock(); }
void reset_in_child() {
    g_pool = nullptr;
    g_pool_mutex.unlock();  // held by this thread since lock_before_fork
}

/// Registers the fork handlers when the library is loaded, before any thread of the core exists:
/// registered lazily, a fork racing the first pooled call could copy g_pool_mutex (or the
/// registration's own guard) held by another thread into the child, where it is never released.
[[maybe_unused]] const bool g_fork_handlers_registered =
    pthread_atfork(lock_before_fork, unlock_after_fork, reset_in_child) == 0;
#endif

WorkerPool* pool() {
    std::lock_guard<std::mutex> lock(g_pool_mutex);
    if (g_pool == nullptr) g_pool = new WorkerPool();
    return g_pool;
}

/// The caller's fallback when the pool is busy: plain threads for this job alone.
void run_on_new_threads(std::size_t helpers, const PoolJob& job) {
    std::vector<std::thread> threads;
    threads.reserve(helpers);
    try {
        for (std::size_t i = 0; i < helpers; ++i) threads.emplace_back(job.run, job.context);
    } catch (...) {
        // could not start a thread: the threads started and the caller do the work
    }
    job.run(job.context);
    for (auto& thread : threads) thread.join();
}

}  // namespace

void run_on_pool(std::size_t helpers, const PoolJob& job) {
    if (helpers == 0) {
        job.run(job.context);
        return;
    }
    if (!pool()->run(helpers, job)) run_on_new_threads(helpers, job);
}

}  // namespace nightloc::detail
