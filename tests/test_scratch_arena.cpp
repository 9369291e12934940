// Unit tests of the build's scratch slabs (lib/core/scratch_arena.h): which
// arrays come from them, that arrays never overlap and keep their contents,
// that a slab comes back whatever thread frees its arrays and whether or not
// its arena still lives, that a build leaves none behind and keeps no array of
// the handle in one, and that the memory goes back to the system.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <algorithm>
#include <cstring>
#include <random>
#include <thread>
#include <vector>

#include "bvh_object.h"
#include "core/block_cache.h"
#include "core/memory.h"
#include "core/scheduler.h"
#include "core/scratch_arena.h"
#include "random_soup.h" // random_soup, set_soup
#include "test_support.h" // TS_UNDER_ASAN

#if TS_UNDER_ASAN
#include <sanitizer/asan_interface.h>
#endif

using aacbvh::ScratchArena;
using aacbvh_test::random_soup;
using aacbvh_test::set_soup;

namespace {

constexpr size_t kKiB = 1024;

struct Piece {
    unsigned char *p;
    size_t bytes;
    unsigned char tag;
};

void fill(const Piece &x) { std::memset(x.p, x.tag, x.bytes); }
bool intact(const Piece &x) {
    for (size_t i = 0; i < x.bytes; i += 509)
        if (x.p[i] != x.tag) return false;
    return x.p[x.bytes - 1] == x.tag;
}

/// Sizes from the threshold to just under 2 MiB, made and freed in a random
/// order: every array of the threshold's size and up (under 2 MiB) lies in a
/// slab, none overlaps another (each keeps its own bytes), smaller ones and
/// those made with the arena paused do not, and when the arena goes every
/// slab goes back to the system.
void test_random_sizes(void **) {
    const int64_t held = aacbvh::testing::system_block_bytes.load();
    std::mt19937 rng(7);
    std::uniform_int_distribution<size_t> size(ScratchArena::kScratchFrom, aacbvh::kHugePageBytes - 1);
    {
        ScratchArena arena;
        const ScratchArena::Scope scope(&arena);
        std::vector<Piece> live;
        unsigned char tag = 1;
        for (int step = 0; step < 400; ++step) {
            if (live.size() < 12 && (live.empty() || rng() % 3 != 0)) {
                const size_t bytes = step % 7 == 0 ? ScratchArena::kScratchFrom : size(rng);
                Piece x{static_cast<unsigned char *>(aacbvh::allocate_build_memory(bytes)), bytes, tag++};
                if (tag == 0) tag = 1;
                assert_true(ScratchArena::holds(x.p));
                assert_true(ScratchArena::holds(x.p + bytes - 1));
                fill(x);
                live.push_back(x);
            } else {
                const size_t k = rng() % live.size();
                for (const Piece &x : live) assert_true(intact(x));
                aacbvh::free_build_memory(live[k].p, live[k].bytes);
                live.erase(live.begin() + long(k));
            }
        }
        void *small = aacbvh::allocate_build_memory(ScratchArena::kScratchFrom - 1);
        assert_false(ScratchArena::holds(small));
        aacbvh::free_build_memory(small, ScratchArena::kScratchFrom - 1);
        {
            const ScratchArena::Pause pause;
            void *kept = aacbvh::allocate_build_memory(256 * kKiB);
            assert_false(ScratchArena::holds(kept));
            aacbvh::free_build_memory(kept, 256 * kKiB);
        }
        for (const Piece &x : live) {
            assert_true(intact(x));
            aacbvh::free_build_memory(x.p, x.bytes);
        }
        assert_true(ScratchArena::live_slabs() > 0); // kept for reuse until the arena goes
    }
    assert_int_equal(ScratchArena::live_slabs(), 0);
    assert_int_equal(aacbvh::testing::system_block_bytes.load(), held);
}

/// Arrays of nearly a whole slab, whatever colour their turn gives them,
/// each take a slab of their own and keep all their bytes.
void test_whole_slabs(void **) {
    const int64_t held = aacbvh::testing::system_block_bytes.load();
    {
        ScratchArena arena;
        const ScratchArena::Scope scope(&arena);
        std::vector<Piece> live;
        for (unsigned char tag = 1; tag <= 70; ++tag) { // more turns than colours
            const size_t bytes = aacbvh::kHugePageBytes - 1 - (tag % 3) * 100;
            Piece x{static_cast<unsigned char *>(aacbvh::allocate_build_memory(bytes)), bytes, tag};
            assert_true(ScratchArena::holds(x.p) && ScratchArena::holds(x.p + bytes - 1));
            fill(x);
            live.push_back(x);
            if (live.size() > 3) {
                for (const Piece &y : live) assert_true(intact(y));
                aacbvh::free_build_memory(live.front().p, live.front().bytes);
                live.erase(live.begin());
            }
        }
        for (const Piece &x : live) {
            assert_true(intact(x));
            aacbvh::free_build_memory(x.p, x.bytes);
        }
    }
    assert_int_equal(ScratchArena::live_slabs(), 0);
    assert_int_equal(aacbvh::testing::system_block_bytes.load(), held);
}

/// Under AddressSanitizer a slab's bytes outside its live arrays are
/// poisoned: the byte past an array's end, the slab's free stretches, and an
/// array once freed; the array itself is not, and a slab goes back to the
/// system (or the reserve) unpoisoned. (The suite's ASan stage runs this; in
/// the other builds it checks only that the arrays are whole.)
void test_poisoned_outside_arrays(void **) {
    std::vector<Piece> pieces;
    {
        ScratchArena arena;
        const ScratchArena::Scope scope(&arena);
        const size_t sizes[] = {ScratchArena::kScratchFrom, ScratchArena::kScratchFrom + 5, 100 * kKiB + 3,
                                700 * kKiB};
        unsigned char tag = 1;
        for (size_t bytes : sizes) {
            Piece x{static_cast<unsigned char *>(aacbvh::allocate_build_memory(bytes)), bytes, tag++};
            assert_true(ScratchArena::holds(x.p));
            fill(x);
            pieces.push_back(x);
        }
        for (const Piece &x : pieces) {
            assert_true(intact(x));
#if TS_UNDER_ASAN
            assert_null(__asan_region_is_poisoned(x.p, x.bytes));
            assert_true(__asan_address_is_poisoned(x.p + x.bytes));
#endif
        }
        unsigned char *freed = pieces[1].p;
        aacbvh::free_build_memory(freed, pieces[1].bytes);
#if TS_UNDER_ASAN
        assert_true(__asan_address_is_poisoned(freed));
        assert_true(__asan_address_is_poisoned(freed + pieces[1].bytes - 1));
#endif
        for (size_t i = 0; i < pieces.size(); ++i)
            if (i != 1) aacbvh::free_build_memory(pieces[i].p, pieces[i].bytes);
    }
    assert_int_equal(ScratchArena::live_slabs(), 0);
#if TS_UNDER_ASAN
    // The slab's memory went to the system (no reserve user here): a block
    // mapped now may lie where it was, and must be usable.
    void *block = aacbvh::allocate_build_memory(aacbvh::kHugePageBytes);
    assert_null(__asan_region_is_poisoned(block, aacbvh::kHugePageBytes));
    aacbvh::free_build_memory(block, aacbvh::kHugePageBytes);
#endif
}

/// Freed pages serve the next arrays: the same sizes made and freed a
/// thousand times map one slab.
void test_reuse(void **) {
    const int64_t mapped = aacbvh::testing::system_block_mapped.load();
    {
        ScratchArena arena;
        const ScratchArena::Scope scope(&arena);
        for (int i = 0; i < 1000; ++i) {
            void *a = aacbvh::allocate_build_memory(300 * kKiB);
            void *b = aacbvh::allocate_build_memory(700 * kKiB);
            aacbvh::free_build_memory(a, 300 * kKiB);
            aacbvh::free_build_memory(b, 700 * kKiB);
        }
        assert_int_equal(ScratchArena::live_slabs(), 1);
    }
    assert_int_equal(aacbvh::testing::system_block_mapped.load() - mapped, int64_t(aacbvh::kHugePageBytes));
}

/// An array freed on another thread, and one that outlives its arena: its
/// slab stays until the array goes, then returns to the system.
void test_other_thread_and_orphan(void **) {
    const int64_t held = aacbvh::testing::system_block_bytes.load();
    void *orphan = nullptr;
    {
        ScratchArena arena;
        const ScratchArena::Scope scope(&arena);
        void *p = aacbvh::allocate_build_memory(512 * kKiB);
        std::thread([p] { aacbvh::free_build_memory(p, 512 * kKiB); }).join();
        orphan = aacbvh::allocate_build_memory(384 * kKiB);
        std::memset(orphan, 3, 384 * kKiB);
    }
    assert_int_equal(ScratchArena::live_slabs(), 1);
    assert_true(ScratchArena::holds(orphan));
    assert_int_equal(static_cast<unsigned char *>(orphan)[384 * kKiB - 1], 3);
    std::thread([orphan] { aacbvh::free_build_memory(orphan, 384 * kKiB); }).join();
    assert_int_equal(ScratchArena::live_slabs(), 0);
    assert_int_equal(aacbvh::testing::system_block_bytes.load(), held);
}

/// A build's slabs are gone when it returns, none of the handle's arrays
/// lies in one, and the handle's later work (rebuilds with and without kept
/// memory, stats, a refit, an optimisation, destruction) leaves none and
/// gives back every block.
void test_builds_leave_no_slab(void **) {
    aacbvh::Scheduler scheduler(2);
    const std::vector<float> vertices = random_soup(60000, 11);
    const int64_t held = aacbvh::testing::system_block_bytes.load();
    {
        aacbvh::BvhObject object(scheduler);
        set_soup(object, vertices);
        for (int builder : {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_BINNED_SAH}) {
            for (int keep : {0, 1}) {
                object.set_param_int(AACBVH_PARAM_BUILDER, builder);
                object.set_param_int(AACBVH_PARAM_KEEP_BUILD_MEMORY, keep);
                const size_t made = ScratchArena::slabs_made();
                object.build();
                assert_true(ScratchArena::slabs_made() > made); // its scratch used them
                assert_int_equal(ScratchArena::live_slabs(), 0);
                aacbvh_stats stats{};
                stats.struct_size = sizeof stats;
                object.stats(stats);
                assert_true(stats.build_peak_bytes > 0);
            }
        }
        object.refit();
        object.optimize(1);
        object.with_tree([](const aacbvh::Bvh &tree) { assert_true(!tree.prim_ids.empty()); });
        assert_int_equal(ScratchArena::live_slabs(), 0);
    }
    assert_int_equal(aacbvh::testing::system_block_bytes.load(), held);
}

/// Arrays made from inside a build's progress callback (another handle's
/// work, say) are the caller's, not the build's scratch: none comes from a
/// slab.
struct CallbackProbe {
    int calls = 0;
    int in_slab = 0;
};
bool probe_allocation(void *user, double) {
    CallbackProbe &probe = *static_cast<CallbackProbe *>(user);
    ++probe.calls;
    void *p = aacbvh::allocate_build_memory(512 * kKiB);
    if (ScratchArena::holds(p)) ++probe.in_slab;
    aacbvh::free_build_memory(p, 512 * kKiB);
    return true;
}

void test_callback_arrays_are_not_scratch(void **) {
    aacbvh::Scheduler scheduler(1);
    const std::vector<float> vertices = random_soup(100000, 3);
    aacbvh::BvhObject object(scheduler);
    set_soup(object, vertices);
    CallbackProbe probe;
    object.set_progress(probe_allocation, &probe);
    object.build();
    object.optimize(1);
    assert_true(probe.calls > 2);
    assert_int_equal(probe.in_slab, 0);
    assert_int_equal(ScratchArena::live_slabs(), 0);
}

/// While a ReserveUser lives, the slabs a build frees serve the next build
/// (no new mapping for them), at most ScratchArena::kReserveSlabs are kept,
/// and when the last user goes they are freed.
void test_reserve(void **) {
    aacbvh::Scheduler scheduler(1);
    const std::vector<float> vertices = random_soup(200000, 5);
    const int64_t held = aacbvh::testing::system_block_bytes.load();
    {
        aacbvh::BvhObject object(scheduler);
        set_soup(object, vertices);
        object.build(); // no user: nothing kept
        assert_int_equal(ScratchArena::reserved_slabs(), 0);
        const ScratchArena::ReserveUser user;
        {
            const ScratchArena::ReserveUser second; // users nest
        }
        object.build();
        const size_t kept = ScratchArena::reserved_slabs();
        assert_true(kept > 0);
        assert_true(kept <= ScratchArena::kReserveSlabs);
        const int64_t before = aacbvh::testing::system_block_mapped.load();
        const int64_t before_held = aacbvh::testing::system_block_bytes.load();
        object.build();
        assert_int_equal(ScratchArena::reserved_slabs(), kept);
        // Mapped anew: the handle's own arrays and what the reserve did not
        // hold, never the reserve's slabs again; what is held stays put.
        assert_true(aacbvh::testing::system_block_mapped.load() - before <=
                    int64_t(object.kept_build_bytes()) + 40 * int64_t(aacbvh::kHugePageBytes));
        assert_int_equal(aacbvh::testing::system_block_bytes.load(), before_held);
    }
    assert_int_equal(ScratchArena::reserved_slabs(), 0);
    assert_int_equal(ScratchArena::live_slabs(), 0);
    assert_int_equal(aacbvh::testing::system_block_bytes.load(), held);
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_sizes),
        cmocka_unit_test(test_whole_slabs),
        cmocka_unit_test(test_poisoned_outside_arrays),
        cmocka_unit_test(test_reuse),
        cmocka_unit_test(test_other_thread_and_orphan),
        cmocka_unit_test(test_builds_leave_no_slab),
        cmocka_unit_test(test_callback_arrays_are_not_scratch),
        cmocka_unit_test(test_reserve),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
