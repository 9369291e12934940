// Unit tests of the kept build memory (lib/core/block_cache.h) and of its use by a
// BVH handle (lib/bvh_object.h, AACBVH_PARAM_KEEP_BUILD_MEMORY): which block a
// request gets, what a build keeps and frees, and that the setting's memory
// goes away when it is switched off; that the 4-wide tree is counted as
// build memory; and that a big block's pages are mapped when it is.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <cstdlib>
#include <cstring>
#include <new>
#include <random>
#include <sys/mman.h>
#include <vector>

#include "bvh/wide_bvh.h"
#include "bvh_object.h"
#include "core/block_cache.h"
#include "core/error.h"
#include "core/memory.h"
#include "core/scheduler.h"
#include "random_soup.h"  // set_soup
#include "test_support.h" // TS_UNDER_TSAN

using aacbvh::BlockCache;
using aacbvh_test::set_soup;

namespace {

constexpr size_t kMiB = size_t(1) << 20;

/// Random triangles in [-1, 1]^3, 9 floats each (no index buffer).
std::vector<float> random_soup(size_t triangles, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<float> vertices(9 * triangles);
    for (float &v : vertices) v = u(rng);
    return vertices;
}

void *block(size_t bytes) {
    void *p = aacbvh::allocate_system_block(bytes); // what the cache holds and frees
    assert_non_null(p);
    return p;
}

void test_take_best_fit(void **) {
    const int64_t before = aacbvh::testing::system_block_bytes.load();
    {
    BlockCache cache;
    void *b4 = block(4 * kMiB), *b6 = block(6 * kMiB), *b8 = block(8 * kMiB);
    cache.keep(b8, 8 * kMiB);
    cache.keep(b4, 4 * kMiB);
    cache.keep(b6, 6 * kMiB);
    assert_int_equal(cache.bytes(), 18 * kMiB);
    assert_null(cache.take(10 * kMiB)); // none big enough
    assert_null(cache.take(2 * kMiB));  // 4 MiB wastes more than an eighth
    assert_ptr_equal(cache.take(6 * kMiB), b6);
    assert_null(cache.take(6 * kMiB)); // 8 MiB is a third too big
    assert_ptr_equal(cache.take(4 * kMiB - 4096), b4);
    assert_ptr_equal(cache.take(8 * kMiB - kMiB / 2), b8);
    // A loose fit goes out at the size asked for; the pages past it stay in
    // the cache as blocks of their own (freed with it), so freeing that size
    // returns every page the caller has.
    assert_int_equal(cache.bytes(), 4096 + kMiB / 2);
    aacbvh::free_system_block(b4, 4 * kMiB - 4096);
    aacbvh::free_system_block(b6, 6 * kMiB);
    aacbvh::free_system_block(b8, 8 * kMiB - kMiB / 2);
    } // the cache frees the tails
    assert_int_equal(aacbvh::testing::system_block_bytes.load(), before);
}

/// Blocks that fit loosely, taken and freed through the allocator: the
/// system gets back every page it gave (the untaken tail included).
void test_loose_fit_returns_everything(void **) {
    const int64_t before = aacbvh::testing::system_block_bytes.load();
    {
        BlockCache cache;
        const BlockCache::Scope installed(&cache);
        { aacbvh::Array<float> big(9 * kMiB / sizeof(float)); }
        assert_int_equal(cache.bytes(), 9 * kMiB);
        char *front = nullptr;
        {
            aacbvh::Array<float> smaller(8 * kMiB / sizeof(float) + 10); // takes the 9 MiB block
            front = reinterpret_cast<char *>(smaller.data());
            assert_int_equal(cache.bytes(), kMiB - 4096); // its tail stays kept
        }
        assert_int_equal(cache.bytes(), 9 * kMiB); // the front came back beside it
        // The end of a build joins blocks that lie side by side: the whole
        // 9 MiB serve the next build's 9 MiB array.
        cache.end_build();
        assert_ptr_equal(cache.take(9 * kMiB), front);
        assert_int_equal(cache.bytes(), 0);
        cache.keep(front, 9 * kMiB);
        cache.release();
    }
    assert_int_equal(aacbvh::testing::system_block_bytes.load(), before);
}

/// A block bigger than asked for serves several arrays in turn: the front
/// goes out, the rest stays kept, and every page still goes back once.
void test_take_part_splits(void **) {
    const int64_t before = aacbvh::testing::system_block_bytes.load();
    {
        BlockCache cache;
        char *b8 = static_cast<char *>(block(8 * kMiB));
        cache.keep(b8, 8 * kMiB);
        assert_null(cache.take_part(8 * kMiB)); // not bigger: take() serves that
        assert_null(cache.take_part(9 * kMiB));
        assert_null(cache.take(3 * kMiB)); // 8 MiB is too loose a fit for take()
        assert_ptr_equal(cache.take_part(3 * kMiB), b8);
        assert_int_equal(cache.bytes(), 5 * kMiB);
        assert_ptr_equal(cache.take_part(2 * kMiB), b8 + 3 * kMiB);
        assert_int_equal(cache.bytes(), 3 * kMiB);
        assert_ptr_equal(cache.take(3 * kMiB), b8 + 5 * kMiB); // the rest, exactly
        assert_int_equal(cache.bytes(), 0);
        cache.keep(b8 + 3 * kMiB, 2 * kMiB);
        aacbvh::free_system_block(b8, 3 * kMiB);
        aacbvh::free_system_block(b8 + 5 * kMiB, 3 * kMiB);
        // Of two blocks that hold more, the smaller is split.
        char *b4 = static_cast<char *>(block(4 * kMiB));
        cache.keep(b4, 4 * kMiB);
        assert_ptr_equal(cache.take_part(kMiB), b8 + 3 * kMiB);
        assert_int_equal(cache.bytes(), 5 * kMiB);
        aacbvh::free_system_block(b8 + 3 * kMiB, kMiB);
    } // the cache frees the 1 MiB rest and the 4 MiB block
    assert_int_equal(aacbvh::testing::system_block_bytes.load(), before);
}

/// Through the allocator: an array freed early serves the smaller ones that
/// come after it, with no new block from the system.
void test_allocator_splits_freed_blocks(void **) {
    const int64_t before = aacbvh::testing::system_block_bytes.load();
    {
        BlockCache cache;
        const BlockCache::Scope installed(&cache);
        { aacbvh::Array<float> big(12 * kMiB / sizeof(float)); }
        const int64_t mapped = aacbvh::testing::system_block_mapped.load();
        {
            aacbvh::Array<float> a(5 * kMiB / sizeof(float)), b(4 * kMiB / sizeof(float)), c(3 * kMiB / sizeof(float));
            for (float *p : {a.data(), b.data(), c.data()}) p[0] = 1.0f; // usable memory
            assert_int_equal(cache.bytes(), 0);
        }
        assert_int_equal(aacbvh::testing::system_block_mapped.load(), mapped);
        assert_int_equal(cache.bytes(), 12 * kMiB);
    }
    assert_int_equal(aacbvh::testing::system_block_bytes.load(), before);
}

void test_build_generations(void **) {
    BlockCache cache;
    cache.keep(block(2 * kMiB), 2 * kMiB);
    cache.keep(block(4 * kMiB), 4 * kMiB);
    cache.begin_build();
    assert_null(cache.take_part(kMiB)); // blocks of an earlier build stay whole
    void *taken = cache.take(4 * kMiB);  // reused by this build
    assert_non_null(taken);
    cache.keep(block(6 * kMiB), 6 * kMiB); // freed by this build
    assert_null(cache.take_part(kMiB)); // a sixth of the block: too small to cut from it
    char *part = static_cast<char *>(cache.take_part(2 * kMiB)); // this build's blocks may be split
    assert_non_null(part);
    cache.keep(part, 2 * kMiB);
    cache.end_build(); // frees the unused 2 MiB block
    assert_int_equal(cache.bytes(), 6 * kMiB);
    cache.keep(taken, 4 * kMiB);
    assert_int_equal(cache.bytes(), 10 * kMiB);
    cache.release();
    assert_int_equal(cache.bytes(), 0);
    assert_null(cache.take(2 * kMiB));
}

void test_full_cache_frees(void **) {
    BlockCache cache;
    for (int i = 0; i < 100; ++i) cache.keep(block(2 * kMiB), 2 * kMiB); // past the limit: freed, not leaked
    assert_true(cache.bytes() <= 100 * 2 * kMiB);
    assert_true(cache.bytes() >= 32 * 2 * kMiB);
}

void test_allocator_uses_installed_cache(void **) {
    BlockCache cache;
    void *first = nullptr;
    {
        const BlockCache::Scope installed(&cache);
        aacbvh::Array<float> big(3 * kMiB / sizeof(float));
        first = big.data();
        aacbvh::Array<float> small(100); // below 2 MiB: never kept
    }
    assert_int_equal(cache.bytes(), 3 * kMiB); // whole pages
    assert_null(BlockCache::current());
    {
        const BlockCache::Scope installed(&cache);
        aacbvh::Array<float> again(3 * kMiB / sizeof(float) - 1000);
        assert_ptr_equal(again.data(), first);
        assert_int_equal(cache.bytes(), 0);
        {
            const BlockCache::Scope none(nullptr); // nested scopes restore
            aacbvh::Array<float> plain(3 * kMiB / sizeof(float));
        }
        assert_ptr_equal(BlockCache::current(), &cache);
    }
    assert_int_equal(cache.bytes(), 3 * kMiB);
}

void test_handle_keeps_and_frees(void **) {
    aacbvh::Scheduler scheduler(2);
    aacbvh::BvhObject object(scheduler);
    const std::vector<float> vertices = random_soup(50000, 3);
    set_soup(object, vertices);

    object.build();
    assert_int_equal(object.kept_build_bytes(), 0); // off by default
    object.set_param_int(AACBVH_PARAM_KEEP_BUILD_MEMORY, 1);
    object.build();
    const size_t kept = object.kept_build_bytes();
    assert_true(kept > 0);
    // Kept: what the build freed, at most its peak plus the tree it replaced.
    aacbvh_stats stats{};
    stats.struct_size = sizeof stats;
    object.stats(stats);
    assert_true(kept <= stats.build_peak_bytes + stats.memory_bytes + 8 * aacbvh::kHugePageBytes);
    object.build();
    assert_true(object.kept_build_bytes() <= kept + 8 * aacbvh::kHugePageBytes);
    object.set_param_int(AACBVH_PARAM_MAX_LEAF_SIZE, 2); // other settings leave it alone
    assert_true(object.kept_build_bytes() > 0);
    object.set_param_int(AACBVH_PARAM_KEEP_BUILD_MEMORY, 0);
    assert_int_equal(object.kept_build_bytes(), 0);
    object.build();
    assert_int_equal(object.kept_build_bytes(), 0);
}

/// A build without kept memory reuses the blocks it frees for the ones it
/// allocates later (its own BlockCache), so it maps from the system little
/// more than its peak, and gives back everything but the finished tree.
/// 200 K triangles: AAC-Fast maps 1.17 of its peak, AAC-HQ 1.67 (its later
/// arrays are a little bigger than the ones freed before them); without the
/// reuse AAC-Fast mapped 1.46 of it. Since row 168 of docs/PERFORMANCE.md the
/// arrays of 64 KiB to 2 MiB count too (they come from the build's 2 MiB
/// slabs, core/scratch_arena.h, not from operator new): 0.97 and 1.48 before.
/// Since row 214 the peak is lower (81.1 -> 73.8 B/tri) and what is mapped
/// the same (89.9 and 138.1 B/tri; AAC-HQ's 8-wide layout of this soup of
/// big triangles, 48 B/tri, is allocated while the builder's tree lives):
/// 1.22 and 1.87 of the peak.
void test_build_reuses_freed_blocks(void **) {
    aacbvh::Scheduler scheduler(1);
    const std::vector<float> vertices = random_soup(200000, 8);
    for (int builder : {AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_AAC_HQ}) {
        const int64_t held = aacbvh::testing::system_block_bytes.load();
        {
            aacbvh::BvhObject object(scheduler);
            set_soup(object, vertices);
            object.set_param_int(AACBVH_PARAM_BUILDER, builder);
            const int64_t mapped = aacbvh::testing::system_block_mapped.load();
            object.build();
            const int64_t build_mapped = aacbvh::testing::system_block_mapped.load() - mapped;
            aacbvh_stats stats{};
            stats.struct_size = sizeof stats;
            object.stats(stats);
            const double ratio = double(build_mapped) / double(stats.build_peak_bytes);
            if (ratio > (builder == AACBVH_BUILDER_AAC_FAST ? 1.25 : 1.95))
                fail_msg("builder %d mapped %.2f times its peak", builder, ratio);
            assert_int_equal(object.kept_build_bytes(), 0);
            // What the build still holds from the system is the handle's tree.
            assert_true(aacbvh::testing::system_block_bytes.load() - held <= int64_t(stats.memory_bytes));
        }
        assert_int_equal(aacbvh::testing::system_block_bytes.load(), held);
    }
}

/// A handle that rebuilds with kept memory maps nothing new from its third
/// build on: the second build still needs a tree's worth (the first tree
/// lives until the second is made), and the blocks it frees, the first
/// tree's arrays joined again with the pages past them (row 113), serve
/// every later build. Before the joins the dragon's builds 3 and 4 mapped
/// 63 and 21 MB.
void test_kept_memory_settles(void **) {
    aacbvh::Scheduler scheduler(1);
    const std::vector<float> vertices = random_soup(200000, 12);
    for (int builder : {AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_AAC_HQ}) {
        aacbvh::BvhObject object(scheduler);
        set_soup(object, vertices);
        object.set_param_int(AACBVH_PARAM_BUILDER, builder);
        object.set_param_int(AACBVH_PARAM_KEEP_BUILD_MEMORY, 1);
        int64_t mapped[5];
        for (int64_t &m : mapped) {
            const int64_t before = aacbvh::testing::system_block_mapped.load();
            object.build();
            m = aacbvh::testing::system_block_mapped.load() - before;
        }
        assert_true(mapped[0] > 0);
        for (int k = 2; k < 5; ++k)
            if (mapped[k] != 0)
                fail_msg("builder %d: build %d mapped %lld new bytes (first %lld, second %lld)", builder, k + 1,
                         (long long)mapped[k], (long long)mapped[0], (long long)mapped[1]);
    }
}

bool same_tree(const aacbvh::Bvh &a, const aacbvh::Bvh &b) {
    return a.nodes.size() == b.nodes.size() && a.prim_ids.size() == b.prim_ids.size() &&
           std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof a.nodes[0]) == 0 &&
           std::memcmp(a.prim_ids.data(), b.prim_ids.data(), a.prim_ids.size() * sizeof a.prim_ids[0]) == 0;
}

/// Out of memory at each build allocation in turn, with blocks kept: the
/// failed build leaves the tree as it was, the kept memory stays bounded, and
/// the next build (from kept blocks) makes the tree a fresh build makes.
/// The handle alternates between two soups, so that each step is the failing
/// build and the rebuild that follows it: the tree before the failure is the
/// one the step before rebuilt, a fresh build's (builds are deterministic,
/// and every rebuild is checked against one).
void test_failures_with_kept_memory(void **) {
    aacbvh::Scheduler scheduler(1);
    aacbvh::BvhObject object(scheduler);
    // 100 K triangles: arrays of 2 MiB and more, the ones kept.
    const std::vector<float> vertices = random_soup(100000, 5), offsets = random_soup(100000, 6);
    std::vector<float> moved(vertices.size());
    for (size_t i = 0; i < moved.size(); ++i) moved[i] = vertices[i] + 0.05f * offsets[i];
    const std::vector<float> *soups[2] = {&vertices, &moved};
    aacbvh::Bvh fresh[2];
    for (int s = 0; s < 2; ++s) {
        aacbvh::BvhObject f(scheduler);
        set_soup(f, *soups[s]);
        f.set_param_int(AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST);
        f.build();
        const aacbvh::Bvh tree = f.binary_tree();
        fresh[s] = aacbvh::Bvh{aacbvh::Array<aacbvh::Node>(tree.nodes), aacbvh::Array<uint32_t>(tree.prim_ids)};
    }
    object.set_param_int(AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST);
    object.set_param_int(AACBVH_PARAM_KEEP_BUILD_MEMORY, 1);
    set_soup(object, vertices);
    object.build();
    object.build();
    int built = 0; // the soup of the handle's tree
    if (!same_tree(object.binary_tree(), fresh[built])) fail_msg("the first tree is not the fresh build's");

    // Every allocation in turn (a build makes about 330); under
    // ThreadSanitizer every 16th, an early, a middle and a late one (this test
    // runs one thread, so there is no race for it to find).
    const int64_t stride = TS_UNDER_TSAN ? 16 : 1;
    int64_t k = 1;
    for (;; k += stride) {
        // The tree is fresh[built]: checked before the loop, then at the end
        // of each step.
        const size_t kept = object.kept_build_bytes();
        assert_true(kept > 0); // the failures below hit a build that reuses blocks
        const int next = 1 - built;
        set_soup(object, *soups[next]);
        aacbvh::testing::alloc_fail_countdown.store(k);
        bool failed = false;
        try {
            object.build();
        } catch (const std::bad_alloc &) {
            failed = true;
        } catch (const aacbvh::Error &e) {
            failed = e.status() == AACBVH_ERROR_OUT_OF_MEMORY;
            if (!failed) fail_msg("allocation %lld failing: %s", (long long)k, e.what());
        }
        const bool reached = aacbvh::testing::alloc_fail_countdown.exchange(0) == 0;
        if (failed) {
            if (!same_tree(object.binary_tree(), fresh[built]))
                fail_msg("allocation %lld failing changed the tree", (long long)k);
            if (object.kept_build_bytes() > kept + object.binary_tree().memory_bytes() + 8 * aacbvh::kHugePageBytes)
                fail_msg("allocation %lld failing: %zu bytes kept, %zu before", (long long)k,
                         object.kept_build_bytes(), kept);
            object.build(); // from the kept blocks
        } else {
            assert_false(reached); // a build that reached its failure must fail
        }
        built = next;
        if (!same_tree(object.binary_tree(), fresh[built]))
            fail_msg("after allocation %lld failing, the rebuild differs from a fresh build", (long long)k);
        if (!failed) break;
    }
    assert_true(k > 5); // the build's arrays were reached one by one
}

/// The 4-wide tree is build memory like the rest: the meter that gives
/// build_peak_bytes sees it, and it is exactly as big as memory_bytes says.
void test_wide_tree_is_metered(void **) {
    aacbvh::Scheduler scheduler(2);
    aacbvh::BvhObject object(scheduler);
    const std::vector<float> vertices = random_soup(20000, 7);
    set_soup(object, vertices);
    object.build();

    const aacbvh::Bvh tree = object.binary_tree();
    aacbvh::MemoryMeter meter;
    aacbvh::WideBvh wide;
    {
        const aacbvh::MemoryMeter::Scope metered(meter);
        wide.build(tree, scheduler);
    }
    assert_true(wide.node_count() > 0);
    assert_int_equal(wide.memory_bytes(), wide.node_count() * (sizeof(aacbvh::WideNode) + 4 * sizeof(uint32_t)));
    assert_true(uint64_t(meter.peak()) >= wide.memory_bytes());
    assert_int_equal(reinterpret_cast<uintptr_t>(wide.nodes()) % alignof(aacbvh::WideNode), 0);
}

/// A big block's pages are mapped when the block is (MADV_POPULATE_WRITE,
/// core/memory.cpp) where the kernel can: whether it can is probed on a
/// mapping of the test's own; then every page of a library block must be
/// resident before anything touches it (mincore), and none where the kernel
/// cannot.
void test_blocks_are_mapped_at_once(void **) {
    const size_t page = aacbvh::kPageBytes;
    bool kernel_populates = false;
#ifdef MADV_POPULATE_WRITE
    void *probe = mmap(nullptr, 4 * page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    assert_true(probe != MAP_FAILED);
    kernel_populates = madvise(probe, 4 * page, MADV_POPULATE_WRITE) == 0;
    munmap(probe, 4 * page);
#endif
    const size_t bytes = aacbvh::round_to_block(4 * kMiB + 3 * page + 1);
    void *block = aacbvh::allocate_system_block(bytes);
    std::vector<unsigned char> resident(bytes / page);
    assert_int_equal(mincore(block, bytes, resident.data()), 0);
    size_t count = 0;
    for (unsigned char r : resident) count += r & 1u;
    aacbvh::free_system_block(block, bytes);
    if (kernel_populates && count != resident.size())
        fail_msg("%zu of %zu pages of a new block are mapped", count, resident.size());
    if (!kernel_populates && count != 0)
        fail_msg("%zu pages of an untouched block are mapped, with no populate advice", count);
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_take_best_fit),
        cmocka_unit_test(test_loose_fit_returns_everything),
        cmocka_unit_test(test_take_part_splits),
        cmocka_unit_test(test_allocator_splits_freed_blocks),
        cmocka_unit_test(test_build_generations),
        cmocka_unit_test(test_full_cache_frees),
        cmocka_unit_test(test_allocator_uses_installed_cache),
        cmocka_unit_test(test_handle_keeps_and_frees),
        cmocka_unit_test(test_build_reuses_freed_blocks),
        cmocka_unit_test(test_kept_memory_settles),
        cmocka_unit_test(test_failures_with_kept_memory),
        cmocka_unit_test(test_wide_tree_is_metered),
        cmocka_unit_test(test_blocks_are_mapped_at_once),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
