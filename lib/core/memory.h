// Memory for large build and tree arrays.
//
// Two costs dominate a fresh build's memory: value-initialising arrays that are
// about to be overwritten, and the page faults of touching them for the first
// time (expensive under virtualisation). Array<T> leaves trivially constructible
// elements uninitialised on resize, and blocks of 2 MiB and more are 2 MiB
// aligned and marked for transparent huge pages (one fault per 2 MiB instead
// of per 4 KiB), as Embree does for its build memory, and their pages are
// mapped when the block is (one call instead of a fault for each).
//
// Arrays from 16 KiB to 2 MiB that a build makes on its calling thread come
// from huge-page slabs instead (core/scratch_arena.h), unless they are the
// handle's; smaller arrays from `operator new`.
//
// With a BlockCache installed on the thread (core/block_cache.h), big blocks
// are taken from it (a kept block of about the size asked for, else the front
// of a bigger one) and given back to it instead of the system. Every build
// installs one: the handle's (AACBVH_PARAM_KEEP_BUILD_MEMORY) or its own.
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

#include "core/block_cache.h"
#include "core/scratch_arena.h"

namespace aacbvh {

namespace testing {

/// Allocation failure injection, for tests only. 0 = unarmed. Armed with
/// k > 0, each checked allocation counts it down and the one that takes it
/// from 1 to 0 fails with std::bad_alloc (one failure, then unarmed again).
/// A value still above 0 afterwards means the failure point was not reached.
extern std::atomic<int64_t> alloc_fail_countdown;

/// The armed path of check_allocation(): true when this allocation must fail.
bool take_injected_failure() noexcept;

/// Bytes of big blocks (2 MiB and more) that the build allocator holds from
/// the system: in use or kept by a BlockCache. Tests read it to check that
/// destroying every handle gives everything back.
extern std::atomic<int64_t> system_block_bytes;

/// Bytes of big blocks mapped from the system so far (never decreases):
/// tests read it to check that a build reuses the blocks it frees.
extern std::atomic<int64_t> system_block_mapped;

inline void count_system_block(int64_t bytes) {
    system_block_bytes.fetch_add(bytes, std::memory_order_relaxed);
    if (bytes > 0) system_block_mapped.fetch_add(bytes, std::memory_order_relaxed);
}

/// Throws std::bad_alloc when an injected failure is due.
inline void check_allocation() {
    if (alloc_fail_countdown.load(std::memory_order_relaxed) != 0 && take_injected_failure())
        throw std::bad_alloc();
}

} // namespace testing

/// Bytes of build arrays alive during one build, and their peak: a build
/// installs one on its calling thread (MemoryMeter::Scope) to report its peak
/// memory. Worker threads are counted where a builder installs the build's
/// meter on them too (the AAC combine scratch does); the counters are atomic
/// for that. Arrays allocated by worker threads outside such a scope are not
/// counted: the builders allocate their arrays on the calling thread and let
/// tasks fill them.
class MemoryMeter {
public:
    void add(int64_t bytes) {
        const int64_t live = live_.fetch_add(bytes, std::memory_order_relaxed) + bytes;
        int64_t peak = peak_.load(std::memory_order_relaxed);
        while (live > peak && !peak_.compare_exchange_weak(peak, live, std::memory_order_relaxed)) {
        }
    }
    int64_t peak() const { return peak_.load(std::memory_order_relaxed); }
    int64_t live() const { return live_.load(std::memory_order_relaxed); }

    static MemoryMeter *&current() {
        static thread_local MemoryMeter *meter = nullptr;
        return meter;
    }
    /// Installs a meter (or none, with nullptr) on this thread for the scope's lifetime.
    class Scope {
    public:
        explicit Scope(MemoryMeter *m) : previous_(current()) { current() = m; }
        explicit Scope(MemoryMeter &m) : Scope(&m) {}
        ~Scope() { current() = previous_; }
        Scope(const Scope &) = delete;
        Scope &operator=(const Scope &) = delete;

    private:
        MemoryMeter *previous_;
    };

private:
    std::atomic<int64_t> live_{0};
    std::atomic<int64_t> peak_{0};
};

constexpr size_t kHugePageBytes = size_t(1) << 21;

constexpr size_t kPageBytes = size_t(1) << 12;

/// A big block's size: `bytes` rounded up to whole 4 KiB pages. Big blocks
/// start on a 2 MiB boundary, so every whole 2 MiB stretch of them can be a
/// huge page; rounding the size up to 2 MiB as well would only add memory
/// that nothing uses (up to 2 MiB per array, a quarter of the tree on scenes
/// of 70 K triangles).
constexpr size_t round_to_block(size_t bytes) { return (bytes + kPageBytes - 1) & ~(kPageBytes - 1); }

/// Over-aligned element types (such as 64-byte wide nodes) get their
/// alignment in small blocks too; big blocks are page aligned anyway.
inline bool over_aligned(size_t align) { return align > __STDCPP_DEFAULT_NEW_ALIGNMENT__; }

/// Maps the pages of [p, p + bytes) at once (MADV_POPULATE_WRITE, where the
/// kernel has it) instead of one page fault each. Advice: a failure is harmless.
void map_pages(void *p, size_t bytes) noexcept;

/// Who maps the pages of the big blocks a thread allocates: by default the
/// thread itself, in one map_pages(); a build on several threads installs
/// one that shares the work among them (ParallelPageMapper, core/scheduler.h),
/// since clearing fresh pages is a sizeable part of a build
/// (docs/PERFORMANCE.md, row 224).
class PageMapper {
public:
    /// Maps the pages of [p, p + bytes), p on a 2 MiB boundary.
    virtual void map(char *p, size_t bytes) const noexcept = 0;

    /// The calling thread's, or nullptr.
    static const PageMapper *current() noexcept;

    /// Installs a mapper on the calling thread while it lives.
    class Scope {
    public:
        explicit Scope(const PageMapper *mapper) noexcept;
        ~Scope();
        Scope(const Scope &) = delete;
        Scope &operator=(const Scope &) = delete;

    private:
        const PageMapper *previous_;
    };

protected:
    ~PageMapper() = default;
};

/// A big block straight from the system: `rounded_bytes` (a multiple of
/// the page size) mapped at a 2 MiB boundary, advised for huge pages, its
/// pages mapped at once (map_pages(), or the thread's PageMapper). Mapped exactly,
/// so the handle's stats can count every byte of it: aligned_alloc() would
/// map up to 2 MiB more per block for the alignment, unseen by the stats.
/// Throws std::bad_alloc.
void *allocate_system_block(size_t rounded_bytes);
/// Returns a block of allocate_system_block() to the system.
void free_system_block(void *p, size_t rounded_bytes) noexcept;

inline void *allocate_build_memory(size_t bytes, size_t align = alignof(std::max_align_t)) {
    testing::check_allocation();
    if (MemoryMeter *m = MemoryMeter::current()) m->add(int64_t(bytes));
    if (bytes < kHugePageBytes) {
        if (bytes >= ScratchArena::kScratchFrom && align <= ScratchArena::kAlignment)
            if (ScratchArena *arena = ScratchArena::current()) return arena->allocate(bytes);
        return over_aligned(align) ? ::operator new(bytes, std::align_val_t(align)) : ::operator new(bytes);
    }
    const size_t rounded = round_to_block(bytes);
    if (BlockCache *cache = BlockCache::current()) {
        if (void *kept = cache->take(rounded)) return kept;
        if (void *part = cache->take_part(rounded)) return part;
    }
    return allocate_system_block(rounded);
}

inline void free_build_memory(void *p, size_t bytes, size_t align = alignof(std::max_align_t)) {
    if (!p) return;
    if (MemoryMeter *m = MemoryMeter::current()) m->add(-int64_t(bytes));
    if (bytes >= ScratchArena::kScratchFrom && bytes < kHugePageBytes && ScratchArena::release(p, bytes))
        return;
    if (bytes < kHugePageBytes && over_aligned(align))
        ::operator delete(p, std::align_val_t(align));
    else if (bytes < kHugePageBytes)
        ::operator delete(p);
    else if (BlockCache *cache = BlockCache::current())
        cache->keep(p, round_to_block(bytes));
    else
        free_system_block(p, round_to_block(bytes));
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

/// Bytes an Array holds from the system: its capacity, rounded up to whole
/// pages for big blocks. What memory_bytes reports.
template <class T> size_t held_bytes(const Array<T> &a) {
    const size_t bytes = a.capacity() * sizeof(T);
    return bytes < kHugePageBytes ? bytes : round_to_block(bytes);
}

} // namespace aacbvh
