// Huge-page slabs for a build's mid-size scratch arrays.
//
// Arrays under 2 MiB come from `operator new`, so what their pages cost
// depends on the C library's heap: in a process whose heap is warm they are
// free, in one whose heap gives fresh pages back to the system between
// builds each 4 KiB page faults anew, and on a virtual machine a fault costs
// microseconds (docs/PERFORMANCE.md, rows 159 and 164-165: a 207 K-triangle
// AAC-Fast build took 40 ms in one process and 68 ms in another with the same
// library). A build installs a ScratchArena on its calling thread; while it is
// installed, arrays from kScratchFrom to 2 MiB come from 2 MiB slabs (one
// huge page each, mapped at once and reused within the build) instead, and
// the slabs go back when the build ends: to a reserve of at most
// kReserveSlabs slabs (16 MiB) for the next build of any handle, while a
// ReserveUser lives (each C API context holds one; the reserve is freed with
// the last), else to the build's block cache (the system, or the handle's
// kept memory, AACBVH_PARAM_KEEP_BUILD_MEMORY). Without the reserve a warm
// process would pay for fresh slabs that its C library's heap gave for free
// (docs/PERFORMANCE.md, row 168).
// Arrays the handle keeps after the build (its tree, layouts and primitive
// order) are made with the arena set aside (ScratchArena::Pause), so that no
// slab outlives its build.
//
// A slab is found from any pointer into it (ScratchArena::owns), whatever
// thread frees it, so an array made on the building thread may be freed
// anywhere. Should one outlive the arena all the same, its slab stays mapped
// until it is freed, and then goes back to the system.
#pragma once

#include <cstddef>

namespace aacbvh {

class ScratchArena {
public:
    /// Arrays of at least this size (and under 2 MiB) come from the slabs.
    /// From 16 KiB, so that scenes of a few thousand triangles take theirs
    /// from the reserve too: from `operator new` their builds took 0.30 or
    /// 0.75 ms depending on the process's heap (docs/PERFORMANCE.md, row
    /// 198). Smaller arrays would leave most of a slab's pages unused.
    static constexpr size_t kScratchFrom = size_t(1) << 14;
    /// The alignment its arrays get (each starts at a 64-byte multiple within
    /// its first page); arrays of types aligned more come from elsewhere.
    static constexpr size_t kAlignment = 64;
    /// Free slabs kept between builds, at most (2 MiB each).
    static constexpr size_t kReserveSlabs = 8;

    /// While one lives, slabs that builds free are kept (up to kReserveSlabs)
    /// for later builds; when the last goes, they are freed.
    class ReserveUser {
    public:
        ReserveUser() noexcept;
        ~ReserveUser();
        ReserveUser(const ReserveUser &) = delete;
        ReserveUser &operator=(const ReserveUser &) = delete;
    };

    ScratchArena() = default;
    /// Gives its free slabs to the block cache installed on this thread (or
    /// to the system); a slab that still holds an array waits for it.
    ~ScratchArena();
    ScratchArena(const ScratchArena &) = delete;
    ScratchArena &operator=(const ScratchArena &) = delete;

    /// `bytes` (kScratchFrom to 2 MiB) from a slab: the smallest free stretch
    /// that holds them, else a new slab (from the block cache installed on
    /// this thread, else the system). Throws std::bad_alloc.
    void *allocate(size_t bytes);
    /// If `p` lies in a slab of any arena, gives its `bytes` back and returns
    /// true; false for memory that is not a slab's. Any thread.
    static bool release(void *p, size_t bytes) noexcept;

    /// The arena installed on this thread, or nullptr.
    static ScratchArena *&current() noexcept;
    class Scope {
    public:
        explicit Scope(ScratchArena *arena) noexcept : previous_(current()) { current() = arena; }
        ~Scope() { current() = previous_; }
        Scope(const Scope &) = delete;
        Scope &operator=(const Scope &) = delete;

    private:
        ScratchArena *previous_;
    };
    /// Sets this thread's arena aside: arrays made meanwhile are the handle's.
    class Pause : public Scope {
    public:
        Pause() noexcept : Scope(nullptr) {}
    };

    /// Whether `p` lies in a live slab of any arena, how many slabs are live,
    /// and how many were ever made: for tests.
    static bool holds(const void *p) noexcept;
    static size_t live_slabs() noexcept;
    static size_t slabs_made() noexcept;
    static size_t reserved_slabs() noexcept;

    struct Slab; ///< scratch_arena.cpp

private:
    Slab *slabs_ = nullptr; ///< this arena's, linked through Slab::next_owned
    unsigned next_color_ = 0;
};

} // namespace aacbvh
