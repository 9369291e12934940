#include "core/scratch_arena.h"

#include <atomic>
#include <cstdint>
#include <mutex>
#include <new>

#include "core/block_cache.h"
#include "core/memory.h"

#if defined(__SANITIZE_ADDRESS__)
#define AACBVH_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define AACBVH_ASAN 1
#endif
#endif
#if defined(AACBVH_ASAN)
#include <sanitizer/asan_interface.h>
#endif

namespace aacbvh {

namespace {

constexpr size_t kSlabBytes = kHugePageBytes;

/// Under AddressSanitizer, a live slab's bytes outside its arrays (free
/// stretches, the colour gaps, each array's rounding to whole pages) are
/// poisoned, so that an access past an array's end is reported as it would
/// be for an array from `operator new`; a slab is unpoisoned whole before
/// its memory goes anywhere else. Without it these do nothing.
inline void poison(const void *p, size_t bytes) {
#if defined(AACBVH_ASAN)
    ASAN_POISON_MEMORY_REGION(p, bytes);
#else
    (void)p;
    (void)bytes;
#endif
}
inline void unpoison(const void *p, size_t bytes) {
#if defined(AACBVH_ASAN)
    ASAN_UNPOISON_MEMORY_REGION(p, bytes);
#else
    (void)p;
    (void)bytes;
#endif
}

/// A slab holds at most kSlabBytes / kScratchFrom arrays, so at most one
/// more free stretch between them.
constexpr size_t kMaxStretches = kSlabBytes / ScratchArena::kScratchFrom + 1;

} // namespace

struct ScratchArena::Slab {
    char *base;
    ScratchArena *owner; ///< nullptr once its arena is gone (an array outlived it)
    Slab *next;          ///< every live slab, in the registry
    Slab *next_owned;    ///< the owner's
    size_t arrays = 0;   ///< arrays cut from it and not yet given back
    /// Free stretches (offset, bytes), by offset, never adjacent.
    size_t stretch_count = 0;
    size_t offset[kMaxStretches];
    size_t bytes[kMaxStretches];

    bool holds(const void *p) const {
        const char *c = static_cast<const char *>(p);
        return c >= base && c < base + kSlabBytes;
    }
    /// The smallest free stretch of at least `want` bytes, or stretch_count.
    size_t best_fit(size_t want) const {
        size_t best = stretch_count;
        for (size_t i = 0; i < stretch_count; ++i)
            if (bytes[i] >= want && (best == stretch_count || bytes[i] < bytes[best])) best = i;
        return best;
    }
    void *cut(size_t i, size_t want) {
        void *p = base + offset[i];
        offset[i] += want;
        bytes[i] -= want;
        if (bytes[i] == 0) {
            for (size_t k = i + 1; k < stretch_count; ++k) {
                offset[k - 1] = offset[k];
                bytes[k - 1] = bytes[k];
            }
            --stretch_count;
        }
        ++arrays;
        return p;
    }
    /// Gives back [at, at + size), joined to the free stretches beside it.
    void give_back(size_t at, size_t size) {
        size_t i = 0;
        while (i < stretch_count && offset[i] < at) ++i;
        const bool join_before = i > 0 && offset[i - 1] + bytes[i - 1] == at;
        const bool join_after = i < stretch_count && at + size == offset[i];
        if (join_before && join_after) {
            bytes[i - 1] += size + bytes[i];
            for (size_t k = i + 1; k < stretch_count; ++k) {
                offset[k - 1] = offset[k];
                bytes[k - 1] = bytes[k];
            }
            --stretch_count;
        } else if (join_before) {
            bytes[i - 1] += size;
        } else if (join_after) {
            offset[i] = at;
            bytes[i] += size;
        } else {
            for (size_t k = stretch_count; k > i; --k) {
                offset[k] = offset[k - 1];
                bytes[k] = bytes[k - 1];
            }
            offset[i] = at;
            bytes[i] = size;
            ++stretch_count;
        }
        --arrays;
    }
};

namespace {

/// Every live slab of every arena: frees may come from any thread.
struct Registry {
    std::mutex mutex;
    ScratchArena::Slab *slabs = nullptr;
    std::atomic<size_t> count{0};
    std::atomic<size_t> made{0}; ///< slabs ever made, for tests
    /// Free slabs kept for the next build while a ReserveUser lives.
    void *reserve[ScratchArena::kReserveSlabs] = {};
    size_t reserved = 0;
    size_t users = 0;
};
Registry &registry() {
    static Registry r;
    return r;
}

void unlink(Registry &r, ScratchArena::Slab *slab) {
    for (ScratchArena::Slab **at = &r.slabs; *at; at = &(*at)->next)
        if (*at == slab) {
            *at = slab->next;
            r.count.fetch_sub(1, std::memory_order_relaxed);
            return;
        }
}

} // namespace

void *ScratchArena::allocate(size_t bytes) {
    // Each array starts at its own 64-byte multiple within its first page,
    // so that arrays read side by side do not share cache sets.
    size_t color = size_t((next_color_++ * 11u) % 64u) * 64u;
    if (bytes + color > kSlabBytes) color = 0; // no room for it in a slab
    const size_t want = round_to_block(bytes + color);
    Registry &r = registry();
    void *memory = nullptr;
    {
        std::lock_guard<std::mutex> lock(r.mutex);
        Slab *best = nullptr;
        size_t best_i = 0;
        for (Slab *s = slabs_; s; s = s->next_owned) {
            const size_t i = s->best_fit(want);
            if (i < s->stretch_count && (!best || s->bytes[i] < best->bytes[best_i])) {
                best = s;
                best_i = i;
            }
        }
        if (best) {
            char *p = static_cast<char *>(best->cut(best_i, want)) + color;
            unpoison(p, bytes);
            return p;
        }
        // A new slab: one kept from an earlier build, a block this build
        // freed, else the system's (the block cache is this thread's alone).
        if (r.reserved > 0) memory = r.reserve[--r.reserved];
    }
    if (!memory)
        if (BlockCache *cache = BlockCache::current()) {
            memory = cache->take(kSlabBytes);
            if (!memory) memory = cache->take_part(kSlabBytes);
        }
    if (!memory) memory = allocate_system_block(kSlabBytes);
    Slab *slab = new (std::nothrow) Slab;
    if (!slab) {
        free_system_block(memory, kSlabBytes);
        throw std::bad_alloc();
    }
    slab->base = static_cast<char *>(memory);
    poison(memory, kSlabBytes);
    slab->owner = this;
    slab->stretch_count = 1;
    slab->offset[0] = 0;
    slab->bytes[0] = kSlabBytes;
    std::lock_guard<std::mutex> lock(r.mutex);
    slab->next = r.slabs;
    r.slabs = slab;
    r.count.fetch_add(1, std::memory_order_relaxed);
    r.made.fetch_add(1, std::memory_order_relaxed);
    slab->next_owned = slabs_;
    slabs_ = slab;
    char *p = static_cast<char *>(slab->cut(0, want)) + color;
    unpoison(p, bytes);
    return p;
}

bool ScratchArena::release(void *p, size_t bytes) noexcept {
    Registry &r = registry();
    if (r.count.load(std::memory_order_relaxed) == 0) return false;
    Slab *orphan = nullptr;
    {
        std::lock_guard<std::mutex> lock(r.mutex);
        Slab *slab = r.slabs;
        while (slab && !slab->holds(p)) slab = slab->next;
        if (!slab) return false;
        const size_t offset = size_t(static_cast<char *>(p) - slab->base), color = offset & (kPageBytes - 1);
        slab->give_back(offset - color, round_to_block(bytes + color));
        poison(slab->base + (offset - color), round_to_block(bytes + color));
        if (slab->arrays == 0 && !slab->owner) {
            unlink(r, slab);
            orphan = slab;
        }
    }
    if (orphan) {
        unpoison(orphan->base, kSlabBytes);
        free_system_block(orphan->base, kSlabBytes);
        delete orphan;
    }
    return true;
}

ScratchArena::~ScratchArena() {
    Registry &r = registry();
    Slab *done = nullptr;
    {
        std::lock_guard<std::mutex> lock(r.mutex);
        for (Slab *s = slabs_; s;) {
            Slab *next = s->next_owned;
            if (s->arrays == 0) {
                unlink(r, s);
                unpoison(s->base, kSlabBytes);
                if (r.users > 0 && r.reserved < kReserveSlabs) {
                    r.reserve[r.reserved++] = s->base;
                    delete s;
                } else {
                    s->next_owned = done;
                    done = s;
                }
            } else {
                s->owner = nullptr; // freed with its last array
            }
            s = next;
        }
    }
    BlockCache *cache = BlockCache::current();
    while (done) {
        Slab *next = done->next_owned;
        if (cache)
            cache->keep(done->base, kSlabBytes);
        else
            free_system_block(done->base, kSlabBytes);
        delete done;
        done = next;
    }
}

ScratchArena::ReserveUser::ReserveUser() noexcept {
    Registry &r = registry();
    std::lock_guard<std::mutex> lock(r.mutex);
    ++r.users;
}

ScratchArena::ReserveUser::~ReserveUser() {
    Registry &r = registry();
    void *freed[kReserveSlabs];
    size_t count = 0;
    {
        std::lock_guard<std::mutex> lock(r.mutex);
        if (--r.users > 0) return;
        count = r.reserved;
        for (size_t i = 0; i < count; ++i) freed[i] = r.reserve[i];
        r.reserved = 0;
    }
    for (size_t i = 0; i < count; ++i) free_system_block(freed[i], kSlabBytes);
}

size_t ScratchArena::reserved_slabs() noexcept {
    Registry &r = registry();
    std::lock_guard<std::mutex> lock(r.mutex);
    return r.reserved;
}

ScratchArena *&ScratchArena::current() noexcept {
    static thread_local ScratchArena *arena = nullptr;
    return arena;
}

bool ScratchArena::holds(const void *p) noexcept {
    Registry &r = registry();
    std::lock_guard<std::mutex> lock(r.mutex);
    for (const Slab *s = r.slabs; s; s = s->next)
        if (s->holds(p)) return true;
    return false;
}

size_t ScratchArena::live_slabs() noexcept { return registry().count.load(std::memory_order_relaxed); }

size_t ScratchArena::slabs_made() noexcept { return registry().made.load(std::memory_order_relaxed); }

} // namespace aacbvh
