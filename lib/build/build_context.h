// What every builder receives besides its input: the scheduler to run on and
// the caller's progress callback (which may cancel the build).
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <thread>

#include "aacbvh/aacbvh.h"
#include "core/error.h"
#include "core/scheduler.h"
#include "core/scratch_arena.h"

namespace aacbvh {

namespace testing {
/// Least time between two progress calls made by poll(), in milliseconds
/// (5). Tests set 0 to see a call at every poll and count the work between.
extern std::atomic<int> poll_interval_ms;
/// Distance evaluations made by the clustering builders (AAC's rows, PLOC's
/// windows, locally-ordered's searches), counted where they are computed, for
/// tests that bound the work between two progress calls. One relaxed atomic
/// add per row or search, not per distance, and only while
/// `counting_distances` is set (tests set it; off by default): one shared
/// counter that every thread adds to bounces its cache line between the
/// cores, which cost a 16-thread dragon build a fifth of its time.
extern std::atomic<uint64_t> distance_evaluations;
extern std::atomic<bool> counting_distances;
inline void count_distances(uint64_t n) {
    if (counting_distances.load(std::memory_order_relaxed)) distance_evaluations.fetch_add(n, std::memory_order_relaxed);
}
} // namespace testing

/// Polls a build's context after every kPollWork units of a loop's work
/// (distance evaluations, elements swept), so that the work between two
/// chances to cancel is bounded however the loop's size grows; in between,
/// only checks whether a cancel was already asked for.
class PollingCounter {
public:
    static constexpr uint64_t kPollWork = uint64_t(1) << 20;
    explicit PollingCounter(class BuildContext &ctx) : ctx_(ctx) {}
    inline void add(uint64_t units);

private:
    class BuildContext &ctx_;
    uint64_t done_ = 0;
};

class BuildContext {
public:
    BuildContext(Scheduler &scheduler, aacbvh_progress_fn progress, void *user)
        : scheduler_(scheduler), progress_(progress), user_(user), owner_(std::this_thread::get_id()),
          last_call_(std::chrono::steady_clock::now()) {}

    Scheduler &scheduler() const { return scheduler_; }

    /// Reports progress in [0, 1] and throws Error(AACBVH_ERROR_CANCELLED) if the
    /// callback asks to stop. Call it from the thread that started the build.
    void report(double fraction) {
        if (cancelled_.load(std::memory_order_relaxed)) throw_cancelled();
        fraction_ = fraction;
        // Not again while the callback runs: a build it starts may run this
        // build's tasks on this thread while it waits, and they poll.
        if (progress_ && !in_callback_) {
            last_call_ = std::chrono::steady_clock::now();
            in_callback_ = true;
            bool go_on;
            {
                // What the library allocates for the callback (another
                // handle's refit, its nodes) is not this build's scratch.
                const ScratchArena::Pause callers_arrays;
                go_on = progress_(user_, fraction);
            }
            in_callback_ = false;
            if (!go_on) {
                cancelled_.store(true, std::memory_order_relaxed);
                throw_cancelled();
            }
        }
    }
    /// For long phases: from the building thread, calls the progress callback
    /// (with the last fraction) at most every few milliseconds, so a cancel is
    /// noticed promptly; from other threads, only checks for a cancel.
    void poll() {
        check_cancelled();
        if (!progress_ || std::this_thread::get_id() != owner_) return;
        const auto now = std::chrono::steady_clock::now();
        if (now - last_call_ >= std::chrono::milliseconds(testing::poll_interval_ms.load(std::memory_order_relaxed)))
            report(fraction_);
    }
    /// Cheap check that worker tasks may call anywhere.
    void check_cancelled() const {
        if (cancelled_.load(std::memory_order_relaxed)) throw_cancelled();
    }

private:
    [[noreturn]] static void throw_cancelled() {
        throw Error(AACBVH_ERROR_CANCELLED, "build cancelled by the progress callback");
    }
    Scheduler &scheduler_;
    aacbvh_progress_fn progress_;
    void *user_;
    std::thread::id owner_;
    std::chrono::steady_clock::time_point last_call_;
    double fraction_ = 0.0;
    bool in_callback_ = false; ///< only the owner thread calls the callback
    std::atomic<bool> cancelled_{false};
};

inline void PollingCounter::add(uint64_t units) {
    done_ += units;
    if (done_ >= kPollWork) {
        done_ = 0;
        ctx_.poll();
    } else {
        ctx_.check_cancelled(); // one relaxed load: a cancel already asked stops at once
    }
}

} // namespace aacbvh
