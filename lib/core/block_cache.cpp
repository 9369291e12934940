#include "core/block_cache.h"

#include <cstdint>
#include <cstdlib>

#include "core/memory.h"

namespace aacbvh {

namespace {
template <class B> uintptr_t address(const B &block) { return reinterpret_cast<uintptr_t>(block.pointer); }
} // namespace

void *BlockCache::take(size_t bytes) noexcept {
    size_t best = count_;
    for (size_t i = 0; i < count_; ++i) {
        const size_t b = blocks_[i].bytes;
        if (b >= bytes && b - bytes <= bytes / 8 && (best == count_ || b < blocks_[best].bytes)) best = i;
    }
    if (best == count_) return nullptr;
    void *p = blocks_[best].pointer;
    const size_t held = blocks_[best].bytes;
    if (held == bytes) {
        blocks_[best] = blocks_[--count_];
        return p;
    }
    // The caller frees `bytes` (all it knows of): the pages past them stay
    // here as a block of their own, kept through this build, so that
    // end_build() can join the two again once the caller's part comes back
    // (a tree's arrays come back when the next build replaces them). Freed
    // with the cache if that never happens, so never lost.
    blocks_[best] = Block{static_cast<char *>(p) + bytes, held - bytes, false, true};
    return p;
}

void *BlockCache::take_part(size_t bytes) noexcept {
    size_t best = count_;
    for (size_t i = 0; i < count_; ++i)
        if (!blocks_[i].old && blocks_[i].bytes > bytes && (best == count_ || blocks_[i].bytes < blocks_[best].bytes))
            best = i;
    if (best == count_ || blocks_[best].bytes / kMaxSplitRatio > bytes) return nullptr;
    Block &rest = blocks_[best];
    void *p = rest.pointer;
    rest.pointer = static_cast<char *>(p) + bytes;
    rest.bytes -= bytes;
    rest.rest = true;
    return p;
}

void BlockCache::keep(void *block, size_t bytes) noexcept {
    if (count_ == kMaxBlocks) {
        free_system_block(block, bytes);
        return;
    }
    blocks_[count_++] = Block{block, bytes, false, false};
}

void BlockCache::release() noexcept {
    for (size_t i = 0; i < count_; ++i) free_system_block(blocks_[i].pointer, blocks_[i].bytes);
    count_ = 0;
}

size_t BlockCache::bytes() const noexcept {
    size_t sum = 0;
    for (size_t i = 0; i < count_; ++i) sum += blocks_[i].bytes;
    return sum;
}

void BlockCache::begin_build() noexcept {
    for (size_t i = 0; i < count_; ++i) blocks_[i].old = true;
}

void BlockCache::end_build() noexcept {
    join_rests(); // first: an old block joined to one this build freed stays
    size_t kept = 0;
    for (size_t i = 0; i < count_; ++i) {
        if (blocks_[i].old)
            free_system_block(blocks_[i].pointer, blocks_[i].bytes);
        else
            blocks_[kept++] = blocks_[i];
    }
    count_ = kept;
}

void BlockCache::join_rests() noexcept {
    // By address (insertion sort: at most kMaxBlocks), then each rest that
    // starts where the block before it ends becomes part of that block:
    // address ranges never overlap, so that block lies in the rest's own
    // front, a part of the same mapping. Other neighbours stay apart.
    for (size_t i = 1; i < count_; ++i) {
        const Block b = blocks_[i];
        size_t j = i;
        for (; j > 0 && address(blocks_[j - 1]) > address(b); --j) blocks_[j] = blocks_[j - 1];
        blocks_[j] = b;
    }
    size_t out = 0;
    for (size_t i = 0; i < count_; ++i) {
        if (out > 0 && blocks_[i].rest && address(blocks_[out - 1]) + blocks_[out - 1].bytes == address(blocks_[i])) {
            blocks_[out - 1].bytes += blocks_[i].bytes;
            blocks_[out - 1].old = blocks_[out - 1].old && blocks_[i].old;
        } else
            blocks_[out++] = blocks_[i];
    }
    count_ = out;
}

BlockCache *&BlockCache::current() noexcept {
    static thread_local BlockCache *cache = nullptr;
    return cache;
}

} // namespace aacbvh
