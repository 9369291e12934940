// Work-stealing pool: Chase-Lev deques with the C++11 memory orderings of
// Le, Pop, Cohen and Zappa Nardelli, "Correct and Efficient Work-Stealing for
// Weak Memory Models" (PPoPP 2013), and an event count for sleeping.
#include "core/scheduler.h"

#include <algorithm>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

// ThreadSanitizer does not model fences; the fences below only order atomics
// (top/bottom, waiters/epoch), and every handover of a task's plain fields
// goes through a release/acquire pair that it does see.
#if defined(__SANITIZE_THREAD__) && defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 11
#pragma GCC diagnostic ignored "-Wtsan"
#endif

namespace aacbvh {

namespace {

using detail::Task;

/// Steal sweeps (each followed by a yield) before an idle thread sleeps.
constexpr unsigned kSpinRounds = 64;

/// Chase-Lev deque of Task pointers. The owner pushes and takes at the bottom;
/// thieves steal at the top. Bottom stores are release (the paper has relaxed
/// stores after a release fence or a seq_cst fence; release stores are as cheap
/// on x86 and let ThreadSanitizer see the publication of a task's fields).
class Deque {
public:
    Deque() { ring_.store(grow(nullptr, 0, 0), std::memory_order_relaxed); }

    void push(Task *task) {
        int64_t b = bottom_.load(std::memory_order_relaxed);
        int64_t t = top_.load(std::memory_order_acquire);
        Ring *r = ring_.load(std::memory_order_relaxed);
        if (b - t > r->mask) r = grow(r, t, b);
        r->slots[b & r->mask].store(task, std::memory_order_relaxed);
        bottom_.store(b + 1, std::memory_order_release);
    }

    /// Owner only: the newest task, or null if the deque is empty.
    Task *take() {
        int64_t b = bottom_.load(std::memory_order_relaxed) - 1;
        Ring *r = ring_.load(std::memory_order_relaxed);
        bottom_.store(b, std::memory_order_release);
        std::atomic_thread_fence(std::memory_order_seq_cst);
        int64_t t = top_.load(std::memory_order_relaxed);
        Task *task = nullptr;
        if (t <= b) {
            task = r->slots[b & r->mask].load(std::memory_order_relaxed);
            if (t == b) {
                // Last task: race the thieves for it.
                if (!top_.compare_exchange_strong(t, t + 1, std::memory_order_seq_cst, std::memory_order_relaxed))
                    task = nullptr;
                bottom_.store(b + 1, std::memory_order_release);
            }
        } else {
            bottom_.store(b + 1, std::memory_order_release);
        }
        return task;
    }

    enum class Steal { kEmpty, kLost, kGot };

    /// Any thread: the oldest task. kLost means another thread won the race,
    /// so the deque may still hold work.
    Steal steal(Task *&out) {
        int64_t t = top_.load(std::memory_order_acquire);
        std::atomic_thread_fence(std::memory_order_seq_cst);
        int64_t b = bottom_.load(std::memory_order_acquire);
        if (t >= b) return Steal::kEmpty;
        // The paper loads the ring with consume; acquire is what compilers do.
        Ring *r = ring_.load(std::memory_order_acquire);
        Task *task = r->slots[t & r->mask].load(std::memory_order_relaxed);
        if (!top_.compare_exchange_strong(t, t + 1, std::memory_order_seq_cst, std::memory_order_relaxed))
            return Steal::kLost;
        out = task;
        return Steal::kGot;
    }

    bool looks_nonempty() const {
        return top_.load(std::memory_order_acquire) < bottom_.load(std::memory_order_acquire);
    }

private:
    struct Ring {
        int64_t mask;
        std::unique_ptr<std::atomic<Task *>[]> slots;
    };

    /// Owner only. Old rings stay alive until the deque dies, because a thief
    /// may still read from one; fork/join depth keeps them few and small.
    Ring *grow(Ring *old, int64_t t, int64_t b) {
        int64_t size = old ? 2 * (old->mask + 1) : 64;
        auto ring = std::make_unique<Ring>();
        ring->mask = size - 1;
        ring->slots = std::make_unique<std::atomic<Task *>[]>(static_cast<size_t>(size));
        for (int64_t i = t; i < b; ++i)
            ring->slots[i & ring->mask].store(old->slots[i & old->mask].load(std::memory_order_relaxed),
                                              std::memory_order_relaxed);
        Ring *raw = ring.get();
        rings_.push_back(std::move(ring));
        ring_.store(raw, std::memory_order_release);
        return raw;
    }

    alignas(64) std::atomic<int64_t> top_{0};
    alignas(64) std::atomic<int64_t> bottom_{0};
    std::atomic<Ring *> ring_{nullptr};
    std::vector<std::unique_ptr<Ring>> rings_;
};

/// A deque and who owns it: a worker, or an application thread that borrowed
/// it for the duration of its outermost fork_join.
struct alignas(64) Slot {
    Deque deque;
    std::atomic<bool> borrowed{false};
    Slot *next = nullptr; ///< external slots form a list that only grows
};

/// The pool and deque the current thread forks into.
struct Binding {
    const void *pool;
    Slot *slot;
    uint64_t rng;
};
thread_local Binding tls_binding = {nullptr, nullptr, 0};

uint64_t seed_for(const void *p) {
    return (reinterpret_cast<uintptr_t>(p) * 0x9E3779B97F4A7C15ull) | 1;
}

} // namespace

struct Scheduler::Pool {
    /// One external slot is made up front, so that the first application
    /// thread to fork (most contexts serve one) finds its deque made: a
    /// fork_join allocates only when more application threads fork into the
    /// pool at once than ever before (slots that then live as long as the
    /// pool) or when more than 64 forks are pending on one deque (its ring
    /// grows).
    explicit Pool(unsigned workers) : worker_count(workers), workers(new Slot[workers]), externals(new Slot) {}
    ~Pool() {
        for (Slot *s = externals.load(std::memory_order_acquire); s;) {
            Slot *next = s->next;
            delete s;
            s = next;
        }
    }

    Slot *borrow_slot() {
        Slot *head = externals.load(std::memory_order_acquire);
        for (Slot *s = head; s; s = s->next)
            if (!s->borrowed.load(std::memory_order_relaxed) && !s->borrowed.exchange(true, std::memory_order_acquire))
                return s;
        Slot *s = new Slot;
        s->borrowed.store(true, std::memory_order_relaxed);
        s->next = head;
        while (!externals.compare_exchange_weak(s->next, s, std::memory_order_release, std::memory_order_acquire)) {
        }
        return s;
    }

    /// One sweep over every deque but `self`, from a random worker.
    Deque::Steal steal_any(const Slot *self, uint64_t &rng, Task *&out) {
        bool lost = false;
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        unsigned start = static_cast<unsigned>(rng % worker_count);
        for (unsigned k = 0; k < worker_count; ++k) {
            Slot &s = workers[(start + k) % worker_count];
            if (&s == self) continue;
            Deque::Steal r = s.deque.steal(out);
            if (r == Deque::Steal::kGot) return r;
            lost |= r == Deque::Steal::kLost;
        }
        for (Slot *s = externals.load(std::memory_order_acquire); s; s = s->next) {
            if (s == self) continue;
            Deque::Steal r = s->deque.steal(out);
            if (r == Deque::Steal::kGot) return r;
            lost |= r == Deque::Steal::kLost;
        }
        return lost ? Deque::Steal::kLost : Deque::Steal::kEmpty;
    }

    bool work_visible() const {
        for (unsigned k = 0; k < worker_count; ++k)
            if (workers[k].deque.looks_nonempty()) return true;
        for (Slot *s = externals.load(std::memory_order_acquire); s; s = s->next)
            if (s->deque.looks_nonempty()) return true;
        return false;
    }

    // Event count. A sleeper announces itself (waiters), reads the epoch,
    // re-checks its condition, then sleeps until the epoch moves. A waker
    // changes the condition, then checks waiters behind a seq_cst fence: one
    // of the two sees the other (Dekker), so no wake-up is lost.
    uint64_t prepare_wait() {
        waiters.fetch_add(1, std::memory_order_seq_cst);
        std::atomic_thread_fence(std::memory_order_seq_cst);
        return epoch.load(std::memory_order_seq_cst);
    }
    void cancel_wait() { waiters.fetch_sub(1, std::memory_order_relaxed); }
    void wait(uint64_t key) {
        {
            std::unique_lock<std::mutex> lock(mutex);
            while (epoch.load(std::memory_order_relaxed) == key && !stopping) wake.wait(lock);
        }
        waiters.fetch_sub(1, std::memory_order_relaxed);
    }
    /// After a push: wake one sleeper, if any, to steal it.
    void notify_push() {
        std::atomic_thread_fence(std::memory_order_seq_cst);
        if (waiters.load(std::memory_order_relaxed) == 0) return;
        bump_epoch();
        wake.notify_one();
    }
    /// A joiner sleeps on the shared condition variable, so wake everyone.
    void notify_all() {
        bump_epoch();
        wake.notify_all();
    }
    void bump_epoch() {
        std::lock_guard<std::mutex> lock(mutex);
        epoch.fetch_add(1, std::memory_order_seq_cst);
    }

    void run_stolen(Task *task) {
        try {
            // The task's build's meter, and no block cache: the thief may be
            // another build's thread, and a cache is only ever touched by the
            // thread that owns it.
            const MemoryMeter::Scope metered(task->meter);
            const BlockCache::Scope uncached(nullptr);
            task->fn(task->ctx);
        } catch (...) {
            task->error = std::current_exception();
        }
        // The joiner may return and free the task as soon as it sees kDone.
        if (task->state.exchange(Task::kDone, std::memory_order_acq_rel) == Task::kJoinerAsleep) notify_all();
    }

    void worker_main(Slot *self);
    void shutdown();

    /// Binds an application thread (or a worker of another Scheduler) to a
    /// borrowed slot for the duration of its outermost fork_join on this pool.
    class BorrowGuard {
    public:
        explicit BorrowGuard(Pool &pool) : saved_(tls_binding) {
            if (saved_.pool == &pool) return;
            slot_ = pool.borrow_slot();
            tls_binding = {&pool, slot_, seed_for(slot_) ^ seed_for(&saved_)};
        }
        ~BorrowGuard() {
            if (!slot_) return;
            tls_binding = saved_;
            slot_->borrowed.store(false, std::memory_order_release);
        }
        BorrowGuard(const BorrowGuard &) = delete;
        BorrowGuard &operator=(const BorrowGuard &) = delete;

    private:
        Binding saved_;
        Slot *slot_ = nullptr;
    };

    const unsigned worker_count;
    std::unique_ptr<Slot[]> workers;
    std::atomic<Slot *> externals{nullptr};
    std::vector<std::thread> threads;

    alignas(64) std::atomic<unsigned> waiters{0};
    std::atomic<uint64_t> epoch{0};
    std::mutex mutex;
    std::condition_variable wake;
    bool stopping = false; ///< guarded by mutex
    std::atomic<bool> stop{false};
};

void Scheduler::Pool::worker_main(Slot *self) {
    tls_binding = {this, self, seed_for(self)};
    unsigned idle = 0;
    while (!stop.load(std::memory_order_acquire)) {
        Task *task = nullptr;
        Deque::Steal r = steal_any(self, tls_binding.rng, task);
        if (r == Deque::Steal::kGot) {
            run_stolen(task);
            idle = 0;
            continue;
        }
        if (r == Deque::Steal::kLost || ++idle < kSpinRounds) {
            std::this_thread::yield();
            continue;
        }
        uint64_t key = prepare_wait();
        if (stop.load(std::memory_order_acquire) || work_visible()) {
            cancel_wait();
            continue;
        }
        wait(key);
        idle = 0;
    }
    tls_binding = {nullptr, nullptr, 0};
}

Scheduler::Scheduler(unsigned threads) : threads_(threads == 0 ? 1 : threads) {
    if (threads_ <= 1) return;
    pool_ = std::make_unique<Pool>(threads_ - 1);
    try {
        pool_->threads.reserve(threads_ - 1);
        for (unsigned i = 0; i + 1 < threads_; ++i)
            pool_->threads.emplace_back([pool = pool_.get(), i] { pool->worker_main(&pool->workers[i]); });
    } catch (...) {
        pool_->shutdown();
        throw;
    }
}

Scheduler::~Scheduler() {
    if (pool_) pool_->shutdown();
}

void Scheduler::Pool::shutdown() {
    {
        std::lock_guard<std::mutex> lock(mutex);
        stopping = true;
        stop.store(true, std::memory_order_release);
        epoch.fetch_add(1, std::memory_order_seq_cst);
    }
    wake.notify_all();
    for (std::thread &t : threads) t.join();
    threads.clear();
}

void Scheduler::fork_join_impl(detail::Task &b, void (*a)(void *), void *actx) {
    Pool &pool = *pool_;
    Pool::BorrowGuard guard(pool);
    Binding &bind = tls_binding;
    Slot *self = bind.slot;
    Deque &deque = self->deque;

    deque.push(&b);
    pool.notify_push();

    std::exception_ptr a_error;
    try {
        a(actx);
    } catch (...) {
        a_error = std::current_exception();
    }

    // Everything a() forked has been joined, so the bottom task is b unless a
    // thief took it (and then every older task went first).
    if (deque.take() == &b) {
        if (a_error) std::rethrow_exception(a_error);
        b.fn(b.ctx);
        return;
    }

    unsigned idle = 0;
    while (b.state.load(std::memory_order_acquire) != Task::kDone) {
        Task *task = nullptr;
        Deque::Steal r = pool.steal_any(self, bind.rng, task);
        if (r == Deque::Steal::kGot) {
            pool.run_stolen(task);
            idle = 0;
            continue;
        }
        if (r == Deque::Steal::kLost || ++idle < kSpinRounds) {
            std::this_thread::yield();
            continue;
        }
        uint64_t key = pool.prepare_wait();
        int state = Task::kPending;
        if (!b.state.compare_exchange_strong(state, Task::kJoinerAsleep, std::memory_order_acq_rel,
                                             std::memory_order_acquire) &&
            state == Task::kDone) {
            pool.cancel_wait();
            break;
        }
        if (pool.work_visible()) {
            pool.cancel_wait();
            idle = 0;
            continue;
        }
        pool.wait(key);
        idle = 0;
    }
    if (a_error) std::rethrow_exception(a_error);
    if (b.error) std::rethrow_exception(b.error);
}

void ParallelPageMapper::map(char *p, size_t bytes) const noexcept {
    const size_t threads = scheduler_.thread_count();
    if (threads <= 1 || bytes < kParallelFrom) {
        map_pages(p, bytes);
        return;
    }
    // Two pieces a thread, each whole huge pages, for the balance.
    const size_t wanted = (bytes + 2 * threads - 1) / (2 * threads);
    const size_t piece = (wanted + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
    const size_t pieces = (bytes + piece - 1) / piece;
    try {
        scheduler_.parallel_for(0, pieces, 1, [&](size_t b, size_t e) {
            for (size_t i = b; i < e; ++i) map_pages(p + i * piece, std::min(piece, bytes - i * piece));
        });
    } catch (...) {
        // Mapping is advice: pages left unmapped fault in when written.
    }
}

} // namespace aacbvh
