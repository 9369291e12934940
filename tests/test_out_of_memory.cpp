// Out of memory, injected at every allocation in turn: each C API call either
// succeeds or returns AACBVH_ERROR_OUT_OF_MEMORY with a message, never aborts
// or crashes, leaks nothing (counted here, and LeakSanitizer in the sanitizer
// build), and a BVH whose rebuild failed keeps its previous tree, answering
// rays, stats and node reads exactly as before.
//
// Failures come from aacbvh::testing::alloc_fail_countdown (lib/core/memory.h):
// the build arrays consult it, and this program replaces the global operator
// new (every overload) to consult it too, so std containers, strings and
// objects fail as well. That reaches the library only because it is linked
// in statically: aacbvh_core plus capi/capi.cpp (tests/CMakeLists.txt).
//
// For each operation, k = 1, 2, ...: arm the countdown at k, run the call,
// disarm; stop at the first k whose call completes without reaching the
// failure. Builds run on a one-thread context (the allocation order is then
// fixed), plus one case on two threads.
#include <aacbvh/aacbvh.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>

// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include "core/memory.h"
#include "test_support.h" // TS_UNDER_TSAN
#include "xorshift_rng.h"

// ---------------------------------------------------------------------------
// Global operator new/delete: count live blocks, consult the countdown.
// ---------------------------------------------------------------------------

namespace {

std::atomic<int64_t> g_live_blocks{0};

void *checked_alloc(size_t bytes, size_t align) {
    aacbvh::testing::check_allocation(); // throws std::bad_alloc when due
    if (bytes == 0) bytes = 1;
    void *p = nullptr;
    if (align <= alignof(std::max_align_t)) {
        p = std::malloc(bytes);
    } else if (posix_memalign(&p, align, bytes) != 0) {
        p = nullptr;
    }
    if (!p) throw std::bad_alloc();
    g_live_blocks.fetch_add(1, std::memory_order_relaxed);
    return p;
}

void *checked_alloc_nothrow(size_t bytes, size_t align) noexcept {
    try {
        return checked_alloc(bytes, align);
    } catch (...) {
        return nullptr;
    }
}

void checked_free(void *p) noexcept {
    if (!p) return;
    g_live_blocks.fetch_sub(1, std::memory_order_relaxed);
    std::free(p);
}

} // namespace

void *operator new(size_t n) { return checked_alloc(n, 0); }
void *operator new[](size_t n) { return checked_alloc(n, 0); }
void *operator new(size_t n, const std::nothrow_t &) noexcept { return checked_alloc_nothrow(n, 0); }
void *operator new[](size_t n, const std::nothrow_t &) noexcept { return checked_alloc_nothrow(n, 0); }
void *operator new(size_t n, std::align_val_t a) { return checked_alloc(n, size_t(a)); }
void *operator new[](size_t n, std::align_val_t a) { return checked_alloc(n, size_t(a)); }
void *operator new(size_t n, std::align_val_t a, const std::nothrow_t &) noexcept {
    return checked_alloc_nothrow(n, size_t(a));
}
void *operator new[](size_t n, std::align_val_t a, const std::nothrow_t &) noexcept {
    return checked_alloc_nothrow(n, size_t(a));
}
void operator delete(void *p) noexcept { checked_free(p); }
void operator delete[](void *p) noexcept { checked_free(p); }
void operator delete(void *p, size_t) noexcept { checked_free(p); }
void operator delete[](void *p, size_t) noexcept { checked_free(p); }
void operator delete(void *p, const std::nothrow_t &) noexcept { checked_free(p); }
void operator delete[](void *p, const std::nothrow_t &) noexcept { checked_free(p); }
void operator delete(void *p, std::align_val_t) noexcept { checked_free(p); }
void operator delete[](void *p, std::align_val_t) noexcept { checked_free(p); }
void operator delete(void *p, size_t, std::align_val_t) noexcept { checked_free(p); }
void operator delete[](void *p, size_t, std::align_val_t) noexcept { checked_free(p); }
void operator delete(void *p, std::align_val_t, const std::nothrow_t &) noexcept { checked_free(p); }
void operator delete[](void *p, std::align_val_t, const std::nothrow_t &) noexcept { checked_free(p); }

// ---------------------------------------------------------------------------
// Injection driver
// ---------------------------------------------------------------------------

namespace {

using aacbvh::testing::alloc_fail_countdown;

/// Injection points exercised over the whole run (for the summary line).
size_t g_points = 0;

/// Runs `call` with the k-th allocation failing. Returns true when the
/// failure was reached; `status` gets the call's result.
template <class F> bool run_failing_at(int64_t k, F &&call, aacbvh_status &status) {
    alloc_fail_countdown.store(k, std::memory_order_seq_cst);
    status = call();
    const int64_t left = alloc_fail_countdown.exchange(0, std::memory_order_seq_cst);
    return left == 0;
}

void expect_ok_or_oom(aacbvh_status s, const aacbvh_bvh *bvh, const char *what, int64_t k) {
    if (s != AACBVH_OK && s != AACBVH_ERROR_OUT_OF_MEMORY)
        fail_msg("%s, allocation %lld failing: returned %s (%s)", what, (long long)k, aacbvh_status_string(s),
                 bvh ? aacbvh_bvh_last_error(bvh) : "");
    if (s == AACBVH_ERROR_OUT_OF_MEMORY && bvh && std::strlen(aacbvh_bvh_last_error(bvh)) == 0)
        fail_msg("%s, allocation %lld failing: empty message", what, (long long)k);
}

/// The k loop: `setup` (unarmed) makes the state, `call` runs armed,
/// `check(status)` (unarmed) inspects the result, `teardown` (unarmed)
/// releases it. Every iteration must leave no block behind. Every allocation
/// fails in turn; under ThreadSanitizer (10-15 times slower) every sixth:
/// most cases run one thread, where it has no race to find, and the Release
/// and AddressSanitizer stages fail every allocation.
template <class Setup, class Call, class Check, class Teardown>
void for_each_failure(const char *what, Setup &&setup, Call &&call, Check &&check, Teardown &&teardown) {
    const int64_t limit = 200000, stride = TS_UNDER_TSAN ? 6 : 1;
    for (int64_t k = 1; k < limit; k += stride) {
        const int64_t live_before = g_live_blocks.load();
        setup();
        aacbvh_status s;
        const bool reached = run_failing_at(k, call, s);
        check(s, reached, k);
        teardown();
        const int64_t live_after = g_live_blocks.load();
        if (live_after != live_before)
            fail_msg("%s, allocation %lld failing: %lld blocks leaked", what, (long long)k,
                     (long long)(live_after - live_before));
        if (!reached) {
            if (s != AACBVH_OK) fail_msg("%s: fails without an injected failure: %s", what, aacbvh_status_string(s));
            std::printf("%-34s %6lld allocation points%s\n", what, (long long)(k - 1),
                        stride > 1 ? " (at most; every sixth failed)" : "");
            g_points += size_t(k - 1);
            return;
        }
        ++g_points;
    }
    fail_msg("%s: still allocating after %lld injections", what, (long long)limit);
}

// ---------------------------------------------------------------------------
// Scene and reference answers
// ---------------------------------------------------------------------------

struct Scene {
    std::vector<float> vertices;
    std::vector<uint32_t> indices;
    std::vector<aacbvh_ray> rays;
};

/// Uniform floats in [0, 1) from unit().
using Xorshift = XorshiftRng;

/// `n` small triangles around random centres in [lo, lo + span)^3, each of
/// its own three vertices, appended to vertices / indices.
void random_soup(size_t n, float lo, float span, float size, Xorshift &rng, std::vector<float> &vertices,
                 std::vector<uint32_t> &indices) {
    for (size_t t = 0; t < n; ++t) {
        const float c[3] = {lo + span * rng.unit(), lo + span * rng.unit(), lo + span * rng.unit()};
        for (int j = 0; j < 3; ++j) {
            for (int k = 0; k < 3; ++k) vertices.push_back(c[k] + (rng.unit() - 0.5f) * size);
            indices.push_back(uint32_t(vertices.size() / 3 - 1));
        }
    }
}

const Scene &scene() {
    static const Scene s = [] {
        Scene sc;
        Xorshift rng{88172645463325252ull};
        auto next = [&rng] { return rng.unit(); };
        random_soup(2000, -1.0f, 2.0f, 0.2f, rng, sc.vertices, sc.indices);
        for (int i = 0; i < 256; ++i) {
            aacbvh_ray r;
            for (int k = 0; k < 3; ++k) {
                r.org[k] = next() * 6 - 3;
                r.dir[k] = (next() * 2 - 1) - r.org[k];
            }
            r.tmin = 0.0f;
            r.tmax = INFINITY;
            sc.rays.push_back(r);
        }
        return sc;
    }();
    return s;
}

/// Everything a query can tell about a tree.
struct Answers {
    std::vector<aacbvh_hit> hits;
    std::vector<uint8_t> occluded;
    aacbvh_stats stats;
    std::vector<aacbvh_node> nodes;
    std::vector<uint32_t> prims;
};

Answers answers(const aacbvh_bvh *bvh) {
    const Scene &sc = scene();
    Answers a;
    a.hits.resize(sc.rays.size());
    a.occluded.resize(sc.rays.size());
    assert_int_equal(aacbvh_bvh_intersect(bvh, sc.rays.data(), a.hits.data(), sc.rays.size()), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_occluded(bvh, sc.rays.data(), a.occluded.data(), sc.rays.size()), AACBVH_OK);
    std::memset(&a.stats, 0, sizeof a.stats);
    a.stats.struct_size = sizeof a.stats;
    assert_int_equal(aacbvh_bvh_get_stats(bvh, &a.stats), AACBVH_OK);
    a.nodes.resize(a.stats.node_count);
    a.prims.resize(a.stats.primitive_count);
    assert_int_equal(aacbvh_bvh_get_nodes(bvh, 0, a.nodes.size(), a.nodes.data()), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_get_primitive_indices(bvh, 0, a.prims.size(), a.prims.data()), AACBVH_OK);
    return a;
}

bool same(const Answers &a, const Answers &b) {
    // build_peak_bytes and memory_bytes may differ after a failed build (its
    // peak is not the tree's); everything about the tree itself may not.
    return a.hits.size() == b.hits.size() &&
           std::memcmp(a.hits.data(), b.hits.data(), a.hits.size() * sizeof(aacbvh_hit)) == 0 &&
           a.occluded == b.occluded && a.stats.node_count == b.stats.node_count &&
           a.stats.leaf_count == b.stats.leaf_count && a.stats.max_depth == b.stats.max_depth &&
           a.stats.sah_cost == b.stats.sah_cost && a.nodes.size() == b.nodes.size() &&
           std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof(aacbvh_node)) == 0 &&
           a.prims == b.prims;
}

/// Contexts of 1 and 2 threads, shared by every case but test_create (so
/// that thread start-up is not paid per injection).
aacbvh_context *g_contexts[2];

struct Handles {
    aacbvh_bvh *bvh = nullptr;

    void open(uint32_t threads, aacbvh_builder builder, aacbvh_layout layout = AACBVH_LAYOUT_BINARY) {
        const Scene &sc = scene();
        assert_int_equal(aacbvh_bvh_create(g_contexts[threads - 1], &bvh), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_set_triangles(bvh, sc.vertices.data(), sc.vertices.size() / 3, 12,
                                                  sc.indices.data(), sc.indices.size() / 3),
                         AACBVH_OK);
    }
    void close() {
        aacbvh_bvh_destroy(bvh);
        bvh = nullptr;
    }
};

const struct {
    const char *name;
    aacbvh_builder builder;
} kBuilders[] = {
    {"AAC-HQ", AACBVH_BUILDER_AAC_HQ},         {"AAC-Fast", AACBVH_BUILDER_AAC_FAST},
    {"binned SAH", AACBVH_BUILDER_BINNED_SAH}, {"PLOC", AACBVH_BUILDER_PLOC},
    {"locally ordered", AACBVH_BUILDER_LOCALLY_ORDERED},
};

// ---------------------------------------------------------------------------
// Tests
// ---------------------------------------------------------------------------

void test_create(void **) {
    aacbvh_context *ctx = nullptr;
    for_each_failure(
        "context_create (1 thread)", [] {}, [&] { return aacbvh_context_create(1, &ctx); },
        [&](aacbvh_status s, bool, int64_t k) {
            expect_ok_or_oom(s, nullptr, "context_create", k);
            if (s != AACBVH_OK && ctx) fail_msg("context_create failed but set *out");
        },
        [&] {
            aacbvh_context_destroy(ctx);
            ctx = nullptr;
        });
    for_each_failure(
        "context_create (2 threads)", [] {}, [&] { return aacbvh_context_create(2, &ctx); },
        [&](aacbvh_status s, bool, int64_t k) {
            expect_ok_or_oom(s, nullptr, "context_create", k);
            if (s != AACBVH_OK && ctx) fail_msg("context_create failed but set *out");
        },
        [&] {
            aacbvh_context_destroy(ctx);
            ctx = nullptr;
        });
    aacbvh_bvh *bvh = nullptr;
    for_each_failure(
        "bvh_create", [&] { assert_int_equal(aacbvh_context_create(1, &ctx), AACBVH_OK); },
        [&] { return aacbvh_bvh_create(ctx, &bvh); },
        [&](aacbvh_status s, bool, int64_t k) {
            expect_ok_or_oom(s, nullptr, "bvh_create", k);
            if (s != AACBVH_OK && bvh) fail_msg("bvh_create failed but set *out");
        },
        [&] {
            aacbvh_bvh_destroy(bvh);
            aacbvh_context_destroy(ctx);
            bvh = nullptr;
            ctx = nullptr;
        });
}

void test_set_geometry(void **) {
    Handles h;
    const Scene &sc = scene();
    for_each_failure(
        "set_triangles", [&] { h.open(1, AACBVH_BUILDER_AAC_HQ); },
        [&] {
            return aacbvh_bvh_set_triangles(h.bvh, sc.vertices.data(), sc.vertices.size() / 3, 12, sc.indices.data(),
                                            sc.indices.size() / 3);
        },
        [&](aacbvh_status s, bool, int64_t k) { expect_ok_or_oom(s, h.bvh, "set_triangles", k); }, [&] { h.close(); });
}

/// A fresh build of each builder: on failure no tree (queries refuse), and a
/// retry without injection builds the same tree as an undisturbed build.
void test_fresh_build(void **) {
    for (const auto &b : kBuilders) {
        Handles h;
        h.open(1, b.builder);
        assert_int_equal(aacbvh_bvh_build(h.bvh), AACBVH_OK);
        const Answers reference = answers(h.bvh);
        h.close();
        const std::string what = std::string("build ") + b.name;
        for_each_failure(
            what.c_str(), [&] { h.open(1, b.builder); }, [&] { return aacbvh_bvh_build(h.bvh); },
            [&](aacbvh_status s, bool, int64_t k) {
                expect_ok_or_oom(s, h.bvh, what.c_str(), k);
                if (s != AACBVH_OK) {
                    aacbvh_hit hit;
                    if (aacbvh_bvh_intersect(h.bvh, scene().rays.data(), &hit, 1) != AACBVH_ERROR_INVALID_OPERATION)
                        fail_msg("%s, allocation %lld failing: a failed first build left a tree", what.c_str(),
                                 (long long)k);
                    assert_int_equal(aacbvh_bvh_build(h.bvh), AACBVH_OK);
                }
                if (!same(answers(h.bvh), reference))
                    fail_msg("%s, allocation %lld failing: the tree differs from an undisturbed build", what.c_str(),
                             (long long)k);
            },
            [&] { h.close(); });
    }
}

/// A rebuild over an existing tree (another builder, so a success changes
/// the tree): on failure the previous tree answers exactly as before.
void rebuild_case(uint32_t threads, aacbvh_builder first, aacbvh_builder second, aacbvh_layout layout,
                  const char *what) {
    Handles h;
    Answers before;
    for_each_failure(
        what,
        [&] {
            h.open(threads, first, layout);
            assert_int_equal(aacbvh_bvh_build(h.bvh), AACBVH_OK);
            before = answers(h.bvh);
            assert_int_equal(aacbvh_bvh_set_param_int(h.bvh, AACBVH_PARAM_BUILDER, second), AACBVH_OK);
        },
        [&] { return aacbvh_bvh_build(h.bvh); },
        [&](aacbvh_status s, bool, int64_t k) {
            expect_ok_or_oom(s, h.bvh, what, k);
            if (s != AACBVH_OK && !same(answers(h.bvh), before))
                fail_msg("%s, allocation %lld failing: the previous tree changed", what, (long long)k);
        },
        [&] {
            before = Answers();
            h.close();
        });
}

void test_rebuild_keeps_tree(void **) {
    for (const auto &b : kBuilders) {
        const std::string what = std::string("rebuild ") + b.name;
        rebuild_case(1, b.builder == AACBVH_BUILDER_AAC_HQ ? AACBVH_BUILDER_BINNED_SAH : AACBVH_BUILDER_AAC_HQ,
                     b.builder, AACBVH_LAYOUT_BINARY, what.c_str());
    }
    rebuild_case(1, AACBVH_BUILDER_BINNED_SAH, AACBVH_BUILDER_AAC_FAST, AACBVH_LAYOUT_WIDE4, "rebuild AAC-Fast, wide4");
    rebuild_case(2, AACBVH_BUILDER_BINNED_SAH, AACBVH_BUILDER_AAC_HQ, AACBVH_LAYOUT_BINARY, "rebuild AAC-HQ, 2 threads");
}

/// Refit, intersect, occluded and get_stats on a built tree: on failure
/// the tree answers as before.
void test_queries(void **) {
    const aacbvh_layout layouts[] = {AACBVH_LAYOUT_BINARY, AACBVH_LAYOUT_WIDE4};
    for (aacbvh_layout layout : layouts) {
        Handles h;
        Answers before;
        const Scene &sc = scene();
        std::vector<aacbvh_hit> hits(sc.rays.size());
        std::vector<uint8_t> occ(sc.rays.size());
        aacbvh_stats stats;
        const std::string suffix = layout == AACBVH_LAYOUT_WIDE4 ? ", wide4" : "";
        auto open = [&] {
            h.open(1, AACBVH_BUILDER_AAC_HQ, layout);
            assert_int_equal(aacbvh_bvh_build(h.bvh), AACBVH_OK);
            before = answers(h.bvh);
        };
        auto close = [&] {
            before = Answers();
            h.close();
        };
        auto kept = [&](const char *what, aacbvh_status s, int64_t k) {
            expect_ok_or_oom(s, h.bvh, what, k);
            if (!same(answers(h.bvh), before))
                fail_msg("%s, allocation %lld failing: the tree answers differently", what, (long long)k);
        };
        // Optimise (since 1.2): a failure keeps the tree bit for bit; success
        // changes it (the optimised tree is what a separate handle makes).
        const std::string optimize = "optimize" + suffix;
        Answers optimised;
        {
            Handles ref;
            ref.open(1, AACBVH_BUILDER_AAC_HQ, layout);
            assert_int_equal(aacbvh_bvh_set_param_int(ref.bvh, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_COPIED),
                             AACBVH_OK);
            assert_int_equal(aacbvh_bvh_build(ref.bvh), AACBVH_OK);
            assert_int_equal(aacbvh_bvh_optimize(ref.bvh, 2), AACBVH_OK);
            optimised = answers(ref.bvh);
            ref.close();
        }
        for_each_failure(
            optimize.c_str(),
            [&] {
                open();
                assert_int_equal(aacbvh_bvh_set_param_int(h.bvh, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_COPIED),
                                 AACBVH_OK);
                assert_int_equal(aacbvh_bvh_refit(h.bvh), AACBVH_OK); // makes the copy
                before = answers(h.bvh);
            },
            [&] { return aacbvh_bvh_optimize(h.bvh, 2); },
            [&](aacbvh_status s, bool, int64_t k) {
                expect_ok_or_oom(s, h.bvh, optimize.c_str(), k);
                const Answers now = answers(h.bvh);
                if (s != AACBVH_OK && !same(now, before))
                    fail_msg("%s, allocation %lld failing: the tree changed", optimize.c_str(), (long long)k);
                if (s == AACBVH_OK && !same(now, optimised))
                    fail_msg("%s, allocation %lld failing: not the optimised tree", optimize.c_str(), (long long)k);
            },
            close);
        const std::string refit = "refit" + suffix, intersect = "intersect" + suffix,
                          occluded = "occluded" + suffix, get_stats = "get_stats" + suffix;
        for_each_failure(
            refit.c_str(), open, [&] { return aacbvh_bvh_refit(h.bvh); },
            [&](aacbvh_status s, bool, int64_t k) { kept(refit.c_str(), s, k); }, close);
        for_each_failure(
            intersect.c_str(), open, [&] { return aacbvh_bvh_intersect(h.bvh, sc.rays.data(), hits.data(), hits.size()); },
            [&](aacbvh_status s, bool, int64_t k) {
                kept(intersect.c_str(), s, k);
                if (s == AACBVH_OK && std::memcmp(hits.data(), before.hits.data(), hits.size() * sizeof hits[0]) != 0)
                    fail_msg("%s, allocation %lld failing: wrong hits", intersect.c_str(), (long long)k);
            },
            close);
        for_each_failure(
            occluded.c_str(), open, [&] { return aacbvh_bvh_occluded(h.bvh, sc.rays.data(), occ.data(), occ.size()); },
            [&](aacbvh_status s, bool, int64_t k) {
                kept(occluded.c_str(), s, k);
                if (s == AACBVH_OK && occ != before.occluded)
                    fail_msg("%s, allocation %lld failing: wrong answers", occluded.c_str(), (long long)k);
            },
            close);
        for_each_failure(
            get_stats.c_str(), open,
            [&] {
                stats.struct_size = sizeof stats;
                return aacbvh_bvh_get_stats(h.bvh, &stats);
            },
            [&](aacbvh_status s, bool, int64_t k) { kept(get_stats.c_str(), s, k); }, close);
    }
}

/// Bytes of the scratch slabs kept for later builds (core/scratch_arena.h).
int64_t reserved_bytes() { return int64_t(aacbvh::ScratchArena::reserved_slabs() * aacbvh::kHugePageBytes); }

/// Destroying every handle gives back everything the library allocated:
/// objects and small arrays (operator new, counted above) and big build
/// blocks (aacbvh::testing::system_block_bytes), after builds on two threads
/// with large combines (AAC delta 1024: 4 MB distance matrices) and kept
/// build memory. Combine scratch once stayed with each thread after its
/// build; it belongs to the build now. The context's scratch slabs go with
/// the context.
void test_destroy_releases_everything(void **) {
    std::vector<float> vertices;
    std::vector<uint32_t> indices;
    Xorshift rng{0x9E3779B97F4A7C15ull};
    const size_t n = 120000;
    random_soup(n, 0.0f, 1.0f, 0.02f, rng, vertices, indices);
    const int64_t blocks_before = g_live_blocks.load();
    const int64_t system_before = aacbvh::testing::system_block_bytes.load();
    const int64_t reserve_before = reserved_bytes();
    aacbvh_context *ctx = nullptr;
    aacbvh_bvh *bvh = nullptr;
    assert_int_equal(aacbvh_context_create(2, &ctx), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_create(ctx, &bvh), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_KEEP_BUILD_MEMORY, 1), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_set_triangles(bvh, vertices.data(), vertices.size() / 3, 12, indices.data(), n),
                     AACBVH_OK);
    assert_int_equal(aacbvh_bvh_build(bvh), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_AAC_DELTA, 1024), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_build(bvh), AACBVH_OK);
    aacbvh_stats stats;
    stats.struct_size = sizeof stats;
    assert_int_equal(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
    // Everything held now is the handle's, and memory_bytes says so, but for
    // the scratch slabs the context keeps for later builds (core/scratch_arena.h).
    assert_true(aacbvh::ScratchArena::reserved_slabs() <= aacbvh::ScratchArena::kReserveSlabs);
    const int64_t system_held =
        aacbvh::testing::system_block_bytes.load() - system_before - (reserved_bytes() - reserve_before);
    if (system_held > int64_t(stats.memory_bytes))
        fail_msg("%lld bytes of big blocks held, memory_bytes says %llu", (long long)system_held,
                 (unsigned long long)stats.memory_bytes);
    assert_true(stats.kept_build_bytes > 0);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    // The other tests' contexts still live, and with them the slabs kept for
    // later builds: everything else is back.
    assert_int_equal(aacbvh::testing::system_block_bytes.load() - reserved_bytes(), system_before - reserve_before);
    if (g_live_blocks.load() != blocks_before)
        fail_msg("%lld blocks still held after destroy", (long long)(g_live_blocks.load() - blocks_before));
}

void test_summary(void **) { std::printf("%zu allocation failures injected in all\n", g_points); }

} // namespace

int main() {
    const CMUnitTest tests[] = {
        cmocka_unit_test(test_create),     cmocka_unit_test(test_set_geometry),
        cmocka_unit_test(test_fresh_build), cmocka_unit_test(test_rebuild_keeps_tree),
        cmocka_unit_test(test_queries),    cmocka_unit_test(test_destroy_releases_everything),
        cmocka_unit_test(test_summary),
    };
    for (uint32_t t = 0; t < 2; ++t)
        if (aacbvh_context_create(t + 1, &g_contexts[t]) != AACBVH_OK) return 1;
    const int failed = cmocka_run_group_tests(tests, nullptr, nullptr);
    for (aacbvh_context *ctx : g_contexts) aacbvh_context_destroy(ctx);
    return failed;
}
