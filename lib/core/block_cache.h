// Large blocks kept for reuse instead of returned to the system: within one
// build (every build installs a cache of its own, so the arrays it frees early
// serve the ones it makes later), and, with AACBVH_PARAM_KEEP_BUILD_MEMORY,
// from one build of a handle to the next, for applications that rebuild every
// frame.
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
// Blocks are core/memory.h's system blocks (mapped directly, page aligned;
// 2 MiB aligned unless they are the rest of a split one): one allocated from
// the cache may be freed anywhere. The cache never allocates (it is used from deallocation).
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
    /// The pages past `bytes` stay kept as a rest of their own.
    void *take(size_t bytes) noexcept;
    /// The first `bytes` (whole pages) of the smallest block freed since
    /// begin_build() that holds more; the rest stays kept as a block of its
    /// own, so one freed array can serve several smaller ones. Blocks kept
    /// from an earlier build stay whole for take(): the next build asks for
    /// the same sizes. nullptr when no block is big enough, and when that
    /// block is more than kMaxSplitRatio times `bytes`: a small array cut
    /// from a big block leaves it too short for the big array that comes
    /// after (docs/PERFORMANCE.md, change 127).
    void *take_part(size_t bytes) noexcept;
    static constexpr size_t kMaxSplitRatio = 4;
    /// Keeps a block of `bytes`; frees it when the cache is full.
    void keep(void *block, size_t bytes) noexcept;
    /// Frees every kept block.
    void release() noexcept;
    /// Bytes of the kept blocks.
    size_t bytes() const noexcept;

    /// Marks the blocks kept so far as old: end_build() frees those that the
    /// build did not take, so a cache holds at most what one build freed. It
    /// first joins each rest to its front where that came back (the parts
    /// take() and take_part() cut from one block, freed again; an old rest
    /// joined to a front this build freed stays), so that a handle that
    /// rebuilds with kept memory finds whole blocks again from its third or
    /// fourth build on (docs/PERFORMANCE.md, row 113).
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
    void join_rests() noexcept;
    struct Block {
        void *pointer;
        size_t bytes;
        bool old;
        bool rest; ///< the pages past a front that take() or take_part() gave out
    };
    static constexpr size_t kMaxBlocks = 64; ///< a build frees about 20
    Block blocks_[kMaxBlocks];
    size_t count_ = 0;
};

} // namespace aacbvh
