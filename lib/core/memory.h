// Memory for large build and tree arrays.
//
// Two costs dominate a fresh build's memory: value-initialising arrays that are
// about to be overwritten, and the page faults of touching them for the first
// time (expensive under virtualisation). Array<T> leaves trivially constructible
// elements uninitialised on resize, and blocks of 2 MiB and more are 2 MiB
// aligned and marked for transparent huge pages (one fault per 2 MiB instead
// of per 4 KiB), as Embree does for its build memory.
//
// With a BlockCache installed on the thread (core/block_cache.h), big blocks
// are taken from it and given back to it instead of the system.
//
// Tests inject allocation failures through testing::alloc_fail_countdown
// (tests/test_out_of_memory.cpp): every allocation made here consults it, at
// the cost of one relaxed atomic load while it is unarmed.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <utility>
#include <vector>

#include <sys/mman.h>

#include "core/block_cache.h"

namespace aacbvh {

namespace testing {

/// Allocation failure injection, for tests only. 0 = unarmed. Armed with
/// k > 0, each checked allocation counts it down and the one that takes it
/// from 1 to 0 fails with std::bad_alloc (one failure, then unarmed again).
/// A value still above 0 afterwards means the failure point was not reached.
extern std::atomic<int64_t> alloc_fail_countdown;

/// The armed path of check_allocation(): true when this allocation must fail.
bool take_injected_failure() noexcept;

/// Throws std::bad_alloc when an injected failure is due.
inline void check_allocation() {
    if (alloc_fail_countdown.load(std::memory_order_relaxed) != 0 && take_injected_failure())
        throw std::bad_alloc();
}

} // namespace testing

/// Bytes of build arrays alive on one thread, and their peak: a build installs
/// one on its calling thread (MemoryMeter::Scope) to report its peak memory.
/// Arrays allocated by worker threads are not counted: the builders allocate
/// their arrays on the calling thread and let tasks fill them.
class MemoryMeter {
public:
    void add(int64_t bytes) {
        live_ += bytes;
        if (live_ > peak_) peak_ = live_;
    }
    int64_t peak() const { return peak_; }

    static MemoryMeter *&current() {
        static thread_local MemoryMeter *meter = nullptr;
        return meter;
    }
    /// Installs a meter on this thread for the scope's lifetime.
    class Scope {
    public:
        explicit Scope(MemoryMeter &m) : previous_(current()) { current() = &m; }
        ~Scope() { current() = previous_; }
        Scope(const Scope &) = delete;
        Scope &operator=(const Scope &) = delete;

    private:
        MemoryMeter *previous_;
    };

private:
    int64_t live_ = 0;
    int64_t peak_ = 0;
};

constexpr size_t kHugePageBytes = size_t(1) << 21;

/// Over-aligned element types (such as 64-byte wide nodes) get their
/// alignment in small blocks too; big blocks are 2 MiB aligned anyway.
inline bool over_aligned(size_t align) { return align > __STDCPP_DEFAULT_NEW_ALIGNMENT__; }

inline void *allocate_build_memory(size_t bytes, size_t align = alignof(std::max_align_t)) {
    testing::check_allocation();
    if (MemoryMeter *m = MemoryMeter::current()) m->add(int64_t(bytes));
    if (bytes < kHugePageBytes)
        return over_aligned(align) ? ::operator new(bytes, std::align_val_t(align)) : ::operator new(bytes);
    const size_t rounded = (bytes + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
    if (BlockCache *cache = BlockCache::current())
        if (void *kept = cache->take(rounded)) return kept;
    void *p = std::aligned_alloc(kHugePageBytes, rounded);
    if (!p) throw std::bad_alloc();
#ifdef MADV_HUGEPAGE
    madvise(p, rounded, MADV_HUGEPAGE); // advice only: failure is harmless
#endif
    return p;
}

inline void free_build_memory(void *p, size_t bytes, size_t align = alignof(std::max_align_t)) {
    if (!p) return;
    if (MemoryMeter *m = MemoryMeter::current()) m->add(-int64_t(bytes));
    if (bytes < kHugePageBytes && over_aligned(align))
        ::operator delete(p, std::align_val_t(align));
    else if (bytes < kHugePageBytes)
        ::operator delete(p);
    else if (BlockCache *cache = BlockCache::current())
        cache->keep(p, (bytes + kHugePageBytes - 1) & ~(kHugePageBytes - 1));
    else
        std::free(p);
}

template <class T> struct BuildAllocator {
    using value_type = T;
    BuildAllocator() noexcept = default;
    template <class U> BuildAllocator(const BuildAllocator<U> &) noexcept {}

    T *allocate(size_t n) {
        if (n > size_t(-1) / sizeof(T)) throw std::bad_alloc();
        return static_cast<T *>(allocate_build_memory(n * sizeof(T), alignof(T)));
    }
    void deallocate(T *p, size_t n) noexcept { free_build_memory(p, n * sizeof(T), alignof(T)); }

    /// Default-initialise (no zeroing) when constructed without arguments.
    template <class U> void construct(U *p) noexcept { ::new (static_cast<void *>(p)) U; }
    template <class U, class... Args> void construct(U *p, Args &&...args) {
        ::new (static_cast<void *>(p)) U(std::forward<Args>(args)...);
    }

    template <class U> bool operator==(const BuildAllocator<U> &) const noexcept { return true; }
    template <class U> bool operator!=(const BuildAllocator<U> &) const noexcept { return false; }
};

/// A std::vector whose resize() does not zero and whose big blocks use huge pages.
template <class T> using Array = std::vector<T, BuildAllocator<T>>;

} // namespace aacbvh
