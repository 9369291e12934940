// What every builder receives besides its input: the scheduler to run on and
// the caller's progress callback (which may cancel the build).
#pragma once

#include <atomic>
#include <cstddef>

#include "aacbvh/aacbvh.h"
#include "error.h"
#include "scheduler.h"

namespace aacbvh {

class BuildContext {
public:
    BuildContext(Scheduler &scheduler, aacbvh_progress_fn progress, void *user)
        : scheduler_(scheduler), progress_(progress), user_(user) {}

    Scheduler &scheduler() const { return scheduler_; }

    /// Reports progress in [0, 1] and throws Error(AACBVH_ERROR_CANCELLED) if the
    /// callback asks to stop. Call it from the thread that started the build.
    void report(double fraction) {
        if (cancelled_.load(std::memory_order_relaxed)) throw_cancelled();
        if (progress_ && !progress_(user_, fraction)) {
            cancelled_.store(true, std::memory_order_relaxed);
            throw_cancelled();
        }
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
    std::atomic<bool> cancelled_{false};
};

} // namespace aacbvh
