// Large blocks a BVH handle keeps from one build to the next
// (AACBVH_PARAM_KEEP_BUILD_MEMORY), for applications that rebuild every frame.
//
// A fresh build touches all of its peak memory (build_peak_bytes) new, and the
// kernel clears every page of it on first touch: a sizeable part of a build,
// and a cost that grows with threads (the faults contend in the kernel;
// figures in docs/PERFORMANCE.md). With a cache installed on the building thread
// (BlockCache::Scope), blocks of 2 MiB and more that the build frees (its
// scratch arrays, the tree it replaces) are kept instead of returned to the
// system, and the next build takes them back: warm pages, no faults.
//
// Only the thread that installed the cache touches it, so it needs no lock.
// Blocks are core/memory.h's system blocks (mapped directly, 2 MiB aligned):
// one allocated from the cache may be freed anywhere. The cache never allocates (it is used from deallocation).
#pragma once

#include <cstddef>

namespace aacbvh {

class BlockCache {
public:
    BlockCache() = default;
    ~BlockCache() { release(); }
    BlockCache(const BlockCache &) = delete;
    BlockCache &operator=(const BlockCache &) = delete;

    /// A kept block of at least `bytes` (and at most 1/8 more), or nullptr.
    void *take(size_t bytes) noexcept;
    /// Keeps a block of `bytes`; frees it when the cache is full.
    void keep(void *block, size_t bytes) noexcept;
    /// Frees every kept block.
    void release() noexcept;
    /// Bytes of the kept blocks.
    size_t bytes() const noexcept;

    /// Marks the blocks kept so far as old: end_build() frees those that the
    /// build did not take, so a cache holds at most what one build freed.
    void begin_build() noexcept;
    void end_build() noexcept;

    /// The cache installed on this thread, or nullptr.
    static BlockCache *&current() noexcept;
    class Scope {
    public:
        explicit Scope(BlockCache *cache) noexcept : previous_(current()) { current() = cache; }
        ~Scope() { current() = previous_; }
        Scope(const Scope &) = delete;
        Scope &operator=(const Scope &) = delete;

    private:
        BlockCache *previous_;
    };

private:
    struct Block {
        void *pointer;
        size_t bytes;
        bool old;
    };
    static constexpr size_t kMaxBlocks = 64; ///< a build frees about 20
    Block blocks_[kMaxBlocks];
    size_t count_ = 0;
};

} // namespace aacbvh
