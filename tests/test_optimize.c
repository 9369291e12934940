/* aacbvh_bvh_optimize and AACBVH_PARAM_OPTIMIZE_PASSES (since 1.2): the SAH
 * never rises, every builder's tree keeps its invariants (each primitive once,
 * boxes enclose, leaf-size limit), the result is the same at 1, 2 and 3
 * threads, refit works on an optimised tree, both layouts and the triangle
 * copy answer like the brute-force oracle, cancel keeps the old tree bit for
 * bit, and the errors are those of the header. (Out-of-memory injection is in
 * test_out_of_memory.cpp.) */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "ray_reference.h"
#include "test_support.h"

static aacbvh_stats stats_of(const aacbvh_bvh *bvh) {
    aacbvh_stats s;
    memset(&s, 0, sizeof s);
    s.struct_size = sizeof s;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &s), AACBVH_OK);
    return s;
}

static void check_tree(const aacbvh_bvh *bvh, const float *boxes, size_t n, uint32_t leaf, const char *what) {
    char msg[512];
    if (!ts_check_tree(bvh, boxes, n, NULL, leaf, msg, sizeof msg)) fail_msg("%s: %s", what, msg);
}

/* Every builder, triangles and boxes, several leaf sizes: optimising never
 * raises the SAH, keeps every invariant, and lowers the SAH of the
 * agglomerative builders' trees on random triangles (where 5-leaf treelets
 * always find something). Under ThreadSanitizer each builder runs one leaf
 * size, in turn (AAC-HQ and PLOC at 4), so every builder and every leaf size
 * still runs, with the searches in tasks of 256 nodes on two threads. */
static void test_every_builder(void **state) {
    (void)state;
    const uint32_t leaf_sizes[] = {1, 4, 8};
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 3000, 11, &m));
    float *tri_boxes = ts_mesh_boxes(&m);
    float *boxes = ts_random_boxes(2500, 0.2f, 12);
    assert_non_null(tri_boxes);
    assert_non_null(boxes);
    for (int b = 0; aacbvh_builder_name((aacbvh_builder)b); ++b) {
        for (size_t l = 0; l < sizeof leaf_sizes / sizeof leaf_sizes[0]; ++l) {
            if (TS_UNDER_TSAN && l != (size_t)(b + 1) % 3) continue;
            for (int geometry = 0; geometry < 2; ++geometry) {
                char what[128];
                snprintf(what, sizeof what, "%s, leaf size %u, %s", aacbvh_builder_name((aacbvh_builder)b),
                         leaf_sizes[l], geometry ? "boxes" : "triangles");
                aacbvh_context *ctx;
                aacbvh_bvh *bvh;
                ts_create(2, &ctx, &bvh);
                TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, b), AACBVH_OK);
                TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, leaf_sizes[l]), AACBVH_OK);
                const float *pb = geometry ? boxes : tri_boxes;
                const size_t n = geometry ? 2500 : m.triangle_count;
                if (geometry)
                    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, boxes, n, 24), AACBVH_OK);
                else
                    ts_set_mesh(bvh, &m);
                TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
                const aacbvh_stats before = stats_of(bvh);
                TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 3), AACBVH_OK);
                const aacbvh_stats after = stats_of(bvh);
                if (!(after.sah_cost <= before.sah_cost))
                    fail_msg("%s: SAH rose from %.9g to %.9g", what, before.sah_cost, after.sah_cost);
                if (after.built_sah_cost != after.sah_cost)
                    fail_msg("%s: built_sah_cost %.9g is not the optimised tree's %.9g", what, after.built_sah_cost,
                             after.sah_cost);
                assert_int_equal(after.primitive_count, n);
                check_tree(bvh, pb, n, leaf_sizes[l], what);
                /* The agglomerative trees on random triangles always gain. */
                if (!geometry && leaf_sizes[l] == 4 && (b == AACBVH_BUILDER_AAC_HQ || b == AACBVH_BUILDER_PLOC) &&
                    !(after.sah_cost < 0.999 * before.sah_cost))
                    fail_msg("%s: SAH %.9g -> %.9g, expected a gain", what, before.sah_cost, after.sah_cost);
                /* A second round cannot rise either. */
                TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 1), AACBVH_OK);
                if (!(stats_of(bvh).sah_cost <= after.sah_cost)) fail_msg("%s: the second call raised the SAH", what);
                aacbvh_bvh_destroy(bvh);
                aacbvh_context_destroy(ctx);
            }
        }
    }
    free(boxes);
    free(tri_boxes);
    ts_mesh_free(&m);
}

/* Every generated scene kind (identical, zero-area, flat, wide-range ...),
 * with AAC-HQ and sweep SAH trees: no failure, no rise, every invariant. */
static void test_scene_kinds(void **state) {
    (void)state;
    const aacbvh_builder builders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_SWEEP_SAH};
    for (int k = 0; k < TS_SCENE_KIND_COUNT; ++k) {
        ts_mesh m;
        assert_true(ts_make_scene((ts_scene_kind)k, 1500, 71 + (uint64_t)k, &m));
        float *pb = ts_mesh_boxes(&m);
        assert_non_null(pb);
        for (size_t b = 0; b < sizeof builders / sizeof builders[0]; ++b) {
            char what[96];
            snprintf(what, sizeof what, "%s, %s", ts_scene_name((ts_scene_kind)k), aacbvh_builder_name(builders[b]));
            aacbvh_context *ctx;
            aacbvh_bvh *bvh;
            ts_create(2, &ctx, &bvh);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builders[b]), AACBVH_OK);
            ts_set_mesh(bvh, &m);
            TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
            const double before = stats_of(bvh).sah_cost;
            TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 4), AACBVH_OK);
            const double after = stats_of(bvh).sah_cost;
            if (!(after <= before)) fail_msg("%s: SAH rose from %.9g to %.9g", what, before, after);
            check_tree(bvh, pb, m.triangle_count, 4, what);
            aacbvh_bvh_destroy(bvh);
            aacbvh_context_destroy(ctx);
        }
        free(pb);
        ts_mesh_free(&m);
    }
}

/* A scene scaled by a power of two (2^100: coordinates near 1e30, whose areas
 * overflow single precision; 2^-100: near 1e-30, whose areas underflow it;
 * 2^60: areas near 2^120, just inside it) is the same scene to every builder
 * and to the optimiser: each weighs areas on extents scaled to the scene's,
 * so the tree built and then optimised at each scale is the one at scale 1,
 * its boxes scaled. Before, a scene of coordinates near 1e20 got infinite
 * flattening costs, leaves chosen by ties and SAH splits chosen blind. */
static void optimised_at_scale(const ts_mesh *m, aacbvh_builder builder, int exponent, ts_tree *built,
                               ts_tree *optimised) {
    ts_mesh scaled = *m;
    scaled.vertices = (float *)malloc(3 * m->vertex_count * sizeof(float));
    assert_non_null(scaled.vertices);
    for (size_t i = 0; i < 3 * m->vertex_count; ++i) scaled.vertices[i] = ldexpf(m->vertices[i], exponent);
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(2, &ctx, &bvh);
    ts_set_mesh(bvh, &scaled);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, built), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 2), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, optimised), AACBVH_OK);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    free(scaled.vertices);
    /* Back to scale 1, exactly. */
    ts_tree *trees[2] = {built, optimised};
    for (int t = 0; t < 2; ++t)
        for (size_t i = 0; i < trees[t]->node_count; ++i)
            for (int a = 0; a < 3; ++a) {
                trees[t]->nodes[i].lower[a] = ldexpf(trees[t]->nodes[i].lower[a], -exponent);
                trees[t]->nodes[i].upper[a] = ldexpf(trees[t]->nodes[i].upper[a], -exponent);
            }
}

static void test_power_of_two_scales(void **state) {
    (void)state;
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 3000, 31, &m));
    for (int b = 0; aacbvh_builder_name((aacbvh_builder)b); ++b) {
        const char *name = aacbvh_builder_name((aacbvh_builder)b);
        ts_tree built, optimised;
        optimised_at_scale(&m, (aacbvh_builder)b, 0, &built, &optimised);
        if (!(optimised.stats.sah_cost < built.stats.sah_cost))
            fail_msg("%s: SAH %.9g -> %.9g: expected a gain", name, built.stats.sah_cost, optimised.stats.sah_cost);
        /* Leaves of several primitives: the flattening decided something. */
        if (!(built.node_count < 2 * built.prim_count - 1)) fail_msg("%s: every leaf holds one primitive", name);
        const int exponents[] = {100, 60, -100};
        for (size_t k = 0; k < sizeof exponents / sizeof exponents[0]; ++k) {
            ts_tree bs, os;
            char msg[256];
            optimised_at_scale(&m, (aacbvh_builder)b, exponents[k], &bs, &os);
            if (!ts_tree_diff(&built, &bs, msg, sizeof msg))
                fail_msg("%s, built at 2^%d: %s", name, exponents[k], msg);
            if (!ts_tree_diff(&optimised, &os, msg, sizeof msg))
                fail_msg("%s, optimised at 2^%d: %s", name, exponents[k], msg);
            ts_tree_free(&bs);
            ts_tree_free(&os);
        }
        ts_tree_free(&built);
        ts_tree_free(&optimised);
    }
    ts_mesh_free(&m);
}

/* The tree of optimize(passes) and of a build with AACBVH_PARAM_OPTIMIZE_PASSES
 * at 1, 2 and 3 threads, on a scene large enough for parallel tasks; under
 * ThreadSanitizer 1 and 3 (the races need threads, not every count) on 20,000
 * triangles, whose treelet passes still fork at the root and its children
 * (8,192 primitives make a task). */
static void fetch_optimised(uint32_t threads, const ts_mesh *m, int via_param, ts_tree *out) {
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(threads, &ctx, &bvh);
    ts_set_mesh(bvh, m);
    if (via_param) TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_OPTIMIZE_PASSES, 2), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    if (!via_param) TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 2), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, out), AACBVH_OK);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
}

static void test_thread_counts(void **state) {
    (void)state;
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, TS_UNDER_TSAN ? 20000 : 40000, 21, &m));
    for (int via_param = 0; via_param < 2; ++via_param) {
        ts_tree one, other;
        fetch_optimised(1, &m, via_param, &one);
        for (uint32_t t = TS_UNDER_TSAN ? 3 : 2; t <= 3; ++t) {
            char msg[256];
            fetch_optimised(t, &m, via_param, &other);
            if (!ts_tree_diff(&one, &other, msg, sizeof msg))
                fail_msg("%s, %u threads differ from 1: %s", via_param ? "OPTIMIZE_PASSES" : "optimize()", t, msg);
            ts_tree_free(&other);
        }
        ts_tree_free(&one);
    }
    ts_mesh_free(&m);
}

/* AACBVH_PARAM_OPTIMIZE_PASSES: the build's SAH is at most the plain build's
 * and built_sah_cost is the optimised tree's. */
static void test_passes_in_build(void **state) {
    (void)state;
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_GRID, 8000, 3, &m));
    float *pb = ts_mesh_boxes(&m);
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(2, &ctx, &bvh);
    ts_set_mesh(bvh, &m);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    const aacbvh_stats plain = stats_of(bvh);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_OPTIMIZE_PASSES, 2), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    const aacbvh_stats opt = stats_of(bvh);
    if (!(opt.sah_cost <= plain.sah_cost)) fail_msg("SAH %.9g with passes, %.9g without", opt.sah_cost, plain.sah_cost);
    assert_true(opt.built_sah_cost == opt.sah_cost);
    check_tree(bvh, pb, m.triangle_count, 4, "OPTIMIZE_PASSES 2");
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    free(pb);
    ts_mesh_free(&m);
}

/* With AACBVH_PARAM_KEEP_BUILD_MEMORY, optimising reuses the kept blocks and
 * gives the same trees as without, build after build. */
static void test_kept_memory(void **state) {
    (void)state;
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 60000, 81, &m)); /* arrays over 2 MiB: kept */
    aacbvh_context *ctx;
    aacbvh_bvh *kept, *plain;
    ts_create(2, &ctx, &kept);
    TS_EXPECT_STATUS(aacbvh_bvh_create(ctx, &plain), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(kept, AACBVH_PARAM_KEEP_BUILD_MEMORY, 1), AACBVH_OK);
    ts_set_mesh(kept, &m);
    ts_set_mesh(plain, &m);
    /* Under ThreadSanitizer two rounds: the second already builds from kept memory. */
    for (int round = 0; round < (TS_UNDER_TSAN ? 2 : 3); ++round) {
        ts_tree a, b;
        char msg[256];
        TS_EXPECT_STATUS(aacbvh_bvh_build(kept), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(plain), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_optimize(kept, 2), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_optimize(plain, 2), AACBVH_OK);
        TS_EXPECT_STATUS(ts_tree_fetch(kept, &a), AACBVH_OK);
        TS_EXPECT_STATUS(ts_tree_fetch(plain, &b), AACBVH_OK);
        if (!ts_tree_diff(&a, &b, msg, sizeof msg)) fail_msg("round %d: %s", round, msg);
        assert_true(a.stats.kept_build_bytes > 0);
        assert_int_equal(b.stats.kept_build_bytes, 0);
        ts_tree_free(&a);
        ts_tree_free(&b);
        ts_jitter_mesh(&m, 82 + (uint64_t)round);
    }
    aacbvh_bvh_destroy(kept);
    aacbvh_bvh_destroy(plain);
    aacbvh_context_destroy(ctx);
    ts_mesh_free(&m);
}

/* Refit after optimise follows the moved vertices; optimise after refit
 * lowers the drifted SAH and restarts the drift at 1. */
static void test_refit_and_optimize(void **state) {
    (void)state;
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 5000, 31, &m));
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(2, &ctx, &bvh);
    ts_set_mesh(bvh, &m);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 2), AACBVH_OK);
    ts_jitter_mesh(&m, 32);
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
    float *pb = ts_mesh_boxes(&m);
    check_tree(bvh, pb, m.triangle_count, 4, "refit after optimize");
    const aacbvh_stats drifted = stats_of(bvh);
    assert_true(drifted.sah_cost > drifted.built_sah_cost); /* the jitter grew the boxes */
    TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 1), AACBVH_OK);
    const aacbvh_stats recovered = stats_of(bvh);
    if (!(recovered.sah_cost < drifted.sah_cost))
        fail_msg("optimize after refit: SAH %.9g, was %.9g", recovered.sah_cost, drifted.sah_cost);
    assert_true(recovered.built_sah_cost == recovered.sah_cost);
    check_tree(bvh, pb, m.triangle_count, 4, "optimize after refit");
    /* The optimised tree answers like a fresh build on the moved mesh. */
    {
        aacbvh_context *c2;
        aacbvh_bvh *fresh;
        ts_create(1, &c2, &fresh);
        ts_set_mesh(fresh, &m);
        TS_EXPECT_STATUS(aacbvh_bvh_build(fresh), AACBVH_OK);
        aacbvh_ray *rays = ts_make_rays(m.vertices, 3 * m.vertex_count, 2000, 33);
        assert_non_null(rays);
        assert_true(ts_compare_answers(fresh, bvh, rays, 2000, "optimized after refit") > 100);
        free(rays);
        aacbvh_bvh_destroy(fresh);
        aacbvh_context_destroy(c2);
    }
    free(pb);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    ts_mesh_free(&m);
}

/* Every layout, both triangle storages: the optimised tree's answers pass the
 * brute-force oracle and equal an unoptimised tree's bit for bit. The oracle
 * (4000 triangles per ray) was most of this test's time under the sanitizers:
 * there it judges every fifth ray; every ray is still compared bit for bit. */
static void test_answers(void **state) {
    (void)state;
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 4000, 41, &m));
    const rr_scene scene = rr_triangles(m.vertices, 3, m.indices, m.triangle_count);
    enum { RAYS = 1500 };
    aacbvh_ray *rays = ts_make_rays(m.vertices, 3 * m.vertex_count, RAYS, 42);
    aacbvh_hit *hits = malloc(RAYS * sizeof *hits);
    uint8_t *occ = malloc(RAYS);
    assert_non_null(rays);
    assert_non_null(hits);
    assert_non_null(occ);
    aacbvh_context *ctx;
    aacbvh_bvh *ref;
    ts_create(1, &ctx, &ref);
    ts_set_mesh(ref, &m);
    TS_EXPECT_STATUS(aacbvh_bvh_build(ref), AACBVH_OK);
    for (int layout = 0; layout <= AACBVH_LAYOUT_WIDE8; ++layout) {
        for (int storage = 0; storage < 2; ++storage) {
            char what[96];
            snprintf(what, sizeof what, "layout %d, triangle storage %d", layout, storage);
            aacbvh_bvh *bvh;
            TS_EXPECT_STATUS(aacbvh_bvh_create(ctx, &bvh), AACBVH_OK);
            ts_set_mesh(bvh, &m);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, storage), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
            ts_tree built, optimised;
            TS_EXPECT_STATUS(ts_tree_fetch(bvh, &built), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 2), AACBVH_OK);
            TS_EXPECT_STATUS(ts_tree_fetch(bvh, &optimised), AACBVH_OK);
            if (ts_tree_equal(&built, &optimised)) fail_msg("%s: optimize changed nothing", what);
            ts_tree_free(&built);
            ts_tree_free(&optimised);
            TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, rays, hits, RAYS), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, rays, occ, RAYS), AACBVH_OK);
            for (size_t i = 0; i < RAYS; i += TS_UNDER_SANITIZER ? 5 : 1) {
                char msg[256];
                if (!rr_check_hit(&scene, &rays[i], &hits[i], occ[i], msg, sizeof msg, NULL))
                    fail_msg("%s, ray %zu: %s", what, i, msg);
            }
            assert_true(ts_compare_answers(ref, bvh, rays, RAYS, what) > RAYS / 10);
            aacbvh_bvh_destroy(bvh);
        }
    }
    aacbvh_bvh_destroy(ref);
    aacbvh_context_destroy(ctx);
    free(rays);
    free(hits);
    free(occ);
    ts_mesh_free(&m);
}

/* Cancel at the k-th progress call: the tree stays bit for bit as it was. The
 * callback also tries to optimise its own handle, which is refused. The calls
 * are counted first on a twin handle (same build, optimised to the end); then
 * the first four calls are cancelled, then every (calls / 16)-th, and from
 * eight calls before the twin's end every one until the call completes
 * (every k up to completion made the test quadratic in the calls: minutes
 * under ThreadSanitizer). Long phases call back on a timer, so the count
 * varies a little from run to run. */
typedef struct cancel_state {
    aacbvh_bvh *bvh;
    int calls;
    int cancel_at;
    aacbvh_status nested;
    double last;
    int backwards;
} cancel_state;

static bool cancel_cb(void *user, double fraction) {
    cancel_state *s = (cancel_state *)user;
    if (fraction < s->last) s->backwards = 1;
    s->last = fraction;
    if (s->calls == 0) s->nested = aacbvh_bvh_optimize(s->bvh, 1);
    return s->calls++ != s->cancel_at;
}

/* The cancel test's handle and its twin: copied triangles, the 4-wide layout. */
static void build_for_cancel(aacbvh_bvh *bvh, const ts_mesh *m) {
    ts_set_mesh(bvh, m);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_COPIED), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
}

static void test_cancel_keeps_tree(void **state) {
    (void)state;
    ts_mesh m;
    /* Under a sanitizer 12,000 triangles, whose treelet pass still forks at
     * the root (8,192 primitives make a task) and whose searches run in
     * tasks of 256 nodes. */
    assert_true(ts_make_scene(TS_SCENE_RANDOM, TS_UNDER_SANITIZER ? 12000 : 30000, 51, &m));
    /* Under ThreadSanitizer (10-15 times slower) two threads only: one
     * thread has no race to find. */
    for (uint32_t threads = TS_UNDER_TSAN ? 2 : 1; threads <= 2; ++threads) {
        aacbvh_context *ctx;
        aacbvh_bvh *bvh;
        ts_create(threads, &ctx, &bvh);
        build_for_cancel(bvh, &m);
        ts_tree before;
        TS_EXPECT_STATUS(ts_tree_fetch(bvh, &before), AACBVH_OK);
        aacbvh_ray *rays = ts_make_rays(m.vertices, 3 * m.vertex_count, 500, 52);
        ts_answers answers_before;
        ts_answers_query(bvh, rays, 500, &answers_before);
        /* The twin: how many progress calls a whole optimisation makes. */
        int total_calls;
        {
            aacbvh_bvh *twin;
            TS_EXPECT_STATUS(aacbvh_bvh_create(ctx, &twin), AACBVH_OK);
            build_for_cancel(twin, &m);
            cancel_state s = {twin, 0, -1, AACBVH_OK, -1.0, 0};
            TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(twin, cancel_cb, &s), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_optimize(twin, 3), AACBVH_OK);
            total_calls = s.calls;
            aacbvh_bvh_destroy(twin);
        }
        assert_true(total_calls >= 8);
        const int step = total_calls / 16 > 1 ? total_calls / 16 : 1;
        int k, completed = 0, cancelled = 0, last_cancel = -1, completed_calls = 0;
        for (k = 0; k < 1000 && !completed; k += k < 3 || k >= total_calls - 8 ? 1 : step) {
            cancel_state s = {bvh, 0, k, AACBVH_OK, -1.0, 0};
            TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(bvh, cancel_cb, &s), AACBVH_OK);
            const aacbvh_status st = aacbvh_bvh_optimize(bvh, 3);
            TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(bvh, NULL, NULL), AACBVH_OK);
            TS_EXPECT_STATUS(s.nested, AACBVH_ERROR_INVALID_OPERATION);
            assert_false(s.backwards);
            if (st == AACBVH_OK) {
                completed = 1;
                completed_calls = s.calls;
                assert_true(s.calls <= k); /* finished before the k-th call */
                assert_true(s.last == 1.0);
                break;
            }
            TS_EXPECT_STATUS(st, AACBVH_ERROR_CANCELLED);
            ++cancelled;
            last_cancel = k;
            assert_int_equal(s.calls, k + 1); /* no call after the cancelling one */
            ts_tree now;
            char msg[256];
            TS_EXPECT_STATUS(ts_tree_fetch(bvh, &now), AACBVH_OK);
            if (!ts_tree_diff(&before, &now, msg, sizeof msg)) fail_msg("cancel at call %d changed the tree: %s", k, msg);
            ts_tree_free(&now);
            ts_answers answers_now;
            ts_answers_query(bvh, rays, 500, &answers_now);
            if (!ts_answers_equal(&answers_before, &answers_now, rays, msg, sizeof msg))
                fail_msg("cancel at call %d: the tree answers differently: %s", k, msg);
            ts_answers_free(&answers_now);
        }
        assert_true(completed);
        /* cancelled at the start, during, and within a step of the end */
        assert_true(cancelled >= 4 && last_cancel >= 3 && completed_calls - 1 - last_cancel <= step);
        ts_answers_free(&answers_before);
        free(rays);
        ts_tree_free(&before);
        aacbvh_bvh_destroy(bvh);
        aacbvh_context_destroy(ctx);
    }
    ts_mesh_free(&m);
}

static void test_errors(void **state) {
    (void)state;
    TS_EXPECT_STATUS(aacbvh_bvh_optimize(NULL, 1), AACBVH_ERROR_INVALID_ARGUMENT);
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 500, 61, &m));
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(1, &ctx, &bvh);
    TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 1), AACBVH_ERROR_INVALID_OPERATION); /* no geometry, no tree */
    assert_true(strlen(aacbvh_bvh_last_error(bvh)) > 0);
    ts_set_mesh(bvh, &m);
    TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 1), AACBVH_ERROR_INVALID_OPERATION); /* no tree */
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    ts_tree before, now;
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &before), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, AACBVH_MAX_OPTIMIZE_PASSES + 1), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 0), AACBVH_OK); /* nothing to do */
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &now), AACBVH_OK);
    assert_true(ts_tree_equal(&before, &now));
    ts_tree_free(&now);
    /* New geometry since the build: the tree no longer matches it. */
    ts_set_mesh(bvh, &m);
    TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 1), AACBVH_ERROR_INVALID_OPERATION);
    ts_tree_free(&before);
    /* Empty and tiny scenes: nothing to restructure, and no failure. */
    for (size_t n = 0; n <= 3; ++n) {
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, m.vertices, m.vertex_count, 12, m.indices, n), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_optimize(bvh, 4), AACBVH_OK);
        assert_int_equal(stats_of(bvh).primitive_count, n);
    }
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    ts_mesh_free(&m);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_builder),   cmocka_unit_test(test_scene_kinds),
        cmocka_unit_test(test_thread_counts),   cmocka_unit_test(test_power_of_two_scales),
        cmocka_unit_test(test_passes_in_build), cmocka_unit_test(test_kept_memory),
        cmocka_unit_test(test_refit_and_optimize),
        cmocka_unit_test(test_answers),         cmocka_unit_test(test_cancel_keeps_tree),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
