// Fork/join task scheduler owned by aacbvh_context; builders and batch queries
// run on it. Work-stealing pool of pthreads (one Chase-Lev deque per worker, as
// corrected for weak memory models by Le, Pop, Cohen and Zappa Nardelli,
// PPoPP 2013); a Scheduler with one thread runs everything inline on the caller.
//
// Threads that are not workers (the application's) take part too: on their
// first fork they borrow a deque of their own from the pool, so several builds
// may run at once on one Scheduler from different application threads. A
// thread waiting for a forked task runs other tasks instead of blocking; idle
// workers spin briefly, then sleep until work is pushed.
//
// Forked tasks are small records on the forking thread's stack (a function
// pointer and a context pointer): fork_join waits before it returns, so nothing
// is allocated per task.
#pragma once

#include <atomic>
#include <cstddef>
#include <exception>
#include <functional>
#include <memory>
#include <type_traits>
#include <utility>

#include "core/memory.h"

namespace aacbvh {

namespace detail {

/// One forked call. Lives on the forking thread's stack until joined.
struct Task {
    enum : int { kPending = 0, kJoinerAsleep = 1, kDone = 2 };
    void (*fn)(void *) = nullptr;
    void *ctx = nullptr;
    std::atomic<int> state{kPending};
    std::exception_ptr error; ///< set by a thief whose run of fn threw
    /// The forking thread's build meter: a thief counts what the task
    /// allocates there, not in the build it happens to be helping with.
    MemoryMeter *meter = nullptr;
};

template <class F> void invoke_erased(void *f) { (*static_cast<F *>(f))(); }

template <class F> void *erase(F &f) {
    return const_cast<void *>(static_cast<const void *>(std::addressof(f)));
}

} // namespace detail

class Scheduler {
public:
    /// threads >= 1 (0 is taken as 1): the pool has threads - 1 workers plus
    /// the calling thread. Throws std::system_error if a thread cannot start.
    explicit Scheduler(unsigned threads);
    /// Joins the workers. No fork_join may be running on this Scheduler.
    ~Scheduler();
    Scheduler(const Scheduler &) = delete;
    Scheduler &operator=(const Scheduler &) = delete;

    unsigned thread_count() const { return threads_; }

    /// Runs a() and b(), possibly in parallel, and returns when both are done.
    /// The calling thread helps with other work while it waits. Exceptions
    /// thrown by either are rethrown here (a's first); if a() throws before
    /// b() has been taken by another thread, b() is skipped. Thread-safe: any
    /// number of threads may call it at once.
    template <class A, class B> void fork_join(A &&a, B &&b) {
        if (threads_ <= 1) {
            a();
            b();
            return;
        }
        fork_join_parallel(a, b);
    }

    /// Calls body(begin_i, end_i) over disjoint chunks covering [begin, end),
    /// chunk k being [begin + k*grain, min(end, begin + (k+1)*grain)) (grain 0
    /// is taken as 1), possibly in parallel. Each chunk runs exactly once.
    template <class F> void parallel_for(size_t begin, size_t end, size_t grain, F &&body) {
        if (end <= begin) return;
        if (grain == 0) grain = 1;
        if (threads_ <= 1 || end - begin <= grain) {
            for (size_t b = begin; b < end;) {
                size_t e = end - b > grain ? b + grain : end;
                body(b, e);
                b = e;
            }
            return;
        }
        for_chunks(begin, end, grain, body);
    }

    /// Reduces [begin, end): body(begin_i, end_i) returns the T of one chunk
    /// (chunks as in parallel_for), combine(T, T) joins two neighbours, left
    /// first. The split tree depends only on (begin, end, grain), so the result
    /// is the same for every thread count, floating point included. Returns
    /// `identity` for an empty range. T must be default-constructible.
    template <class T, class F, class C>
    T parallel_reduce(size_t begin, size_t end, size_t grain, T identity, F &&body, C &&combine) {
        if (end <= begin) return identity;
        if (grain == 0) grain = 1;
        return reduce_chunks<T>(begin, end, grain, body, combine);
    }

private:
    // Kept out of line so that fork_join itself stays small enough to inline:
    // on one thread it is then just a(); b(); in the caller.
    template <class A, class B>
#if defined(__GNUC__)
    __attribute__((noinline))
#endif
    void fork_join_parallel(A &a, B &b) {
        detail::Task tb;
        tb.fn = &detail::invoke_erased<B>;
        tb.ctx = detail::erase(b);
        tb.meter = MemoryMeter::current();
        fork_join_impl(tb, &detail::invoke_erased<A>, detail::erase(a));
    }

    template <class F> void for_chunks(size_t begin, size_t end, size_t grain, F &body) {
        size_t chunks = (end - begin - 1) / grain + 1;
        if (chunks <= 1) {
            body(begin, end);
            return;
        }
        size_t mid = begin + (chunks / 2) * grain;
        fork_join([&] { for_chunks(begin, mid, grain, body); }, [&] { for_chunks(mid, end, grain, body); });
    }

    template <class T, class F, class C> T reduce_chunks(size_t begin, size_t end, size_t grain, F &body, C &combine) {
        size_t chunks = (end - begin - 1) / grain + 1;
        if (chunks <= 1) return body(begin, end);
        size_t mid = begin + (chunks / 2) * grain;
        T left{}, right{};
        fork_join([&] { left = reduce_chunks<T>(begin, mid, grain, body, combine); },
                  [&] { right = reduce_chunks<T>(mid, end, grain, body, combine); });
        return combine(std::move(left), std::move(right));
    }

    /// Makes b stealable, runs a(actx) here, then runs or waits for b.
    void fork_join_impl(detail::Task &b, void (*a)(void *), void *actx);

    unsigned threads_;
    struct Pool;
    std::unique_ptr<Pool> pool_;
};

/// A PageMapper (core/memory.h) that maps a big block's pages in pieces of
/// whole huge pages on a scheduler's threads: a build installs one on its
/// thread when it has more than one, so that the kernel clears its fresh
/// pages on all of them. Blocks under kParallelFrom are mapped by the
/// allocating thread: waking the workers for less cost two-thread builds of
/// 200 K triangles more than it saved (docs/PERFORMANCE.md, row 224). The
/// pages are the same whoever maps them.
class ParallelPageMapper final : public PageMapper {
public:
    static constexpr size_t kParallelFrom = 16 * kHugePageBytes;

    explicit ParallelPageMapper(Scheduler &scheduler) noexcept : scheduler_(scheduler) {}
    void map(char *p, size_t bytes) const noexcept override;

private:
    Scheduler &scheduler_;
};

} // namespace aacbvh
