#include "core/block_cache.h"

#include <cstdlib>

#include "core/memory.h"

namespace aacbvh {

void *BlockCache::take(size_t bytes) noexcept {
    size_t best = count_;
    for (size_t i = 0; i < count_; ++i) {
        const size_t b = blocks_[i].bytes;
        if (b >= bytes && b - bytes <= bytes / 8 && (best == count_ || b < blocks_[best].bytes)) best = i;
    }
    if (best == count_) return nullptr;
    void *p = blocks_[best].pointer;
    const size_t held = blocks_[best].bytes;
    blocks_[best] = blocks_[--count_];
    // The caller frees `bytes` (all it knows of): the pages past them go
    // back now, or they would never be unmapped.
    if (held > bytes) free_system_block(static_cast<char *>(p) + bytes, held - bytes);
    return p;
}

void *BlockCache::take_part(size_t bytes) noexcept {
    size_t best = count_;
    for (size_t i = 0; i < count_; ++i)
        if (!blocks_[i].old && blocks_[i].bytes > bytes && (best == count_ || blocks_[i].bytes < blocks_[best].bytes))
            best = i;
    if (best == count_) return nullptr;
    Block &rest = blocks_[best];
    void *p = rest.pointer;
    rest.pointer = static_cast<char *>(p) + bytes;
    rest.bytes -= bytes;
    return p;
}

void BlockCache::keep(void *block, size_t bytes) noexcept {
    if (count_ == kMaxBlocks) {
        free_system_block(block, bytes);
        return;
    }
    blocks_[count_++] = Block{block, bytes, false};
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
    size_t kept = 0;
    for (size_t i = 0; i < count_; ++i) {
        if (blocks_[i].old)
            free_system_block(blocks_[i].pointer, blocks_[i].bytes);
        else
            blocks_[kept++] = blocks_[i];
    }
    count_ = kept;
}

BlockCache *&BlockCache::current() noexcept {
    static thread_local BlockCache *cache = nullptr;
    return cache;
}

} // namespace aacbvh
