/*
 * AACBVH_PARAM_KEEP_BUILD_MEMORY, through the public API: rebuilds that reuse
 * the previous build's memory make exactly the trees that fresh builds make.
 *
 * Scenes are big enough (tens of thousands of triangles) for the build's
 * arrays to reach the 2 MiB blocks that are kept. For several builders and
 * both traversal layouts and triangle storages, one handle rebuilds with the
 * setting on while the geometry alternates between sizes and moves, and each
 * tree is compared node for node with a fresh handle's build of the same
 * geometry (setting off); the tree's invariants are checked too. A failed
 * rebuild (a NaN vertex) keeps the previous tree and the next build is still
 * right; switching the setting off and on between builds changes nothing.
 * Leaks of kept blocks would be caught by the sanitizer and valgrind runs of
 * this program.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "test_support.h"

static aacbvh_context *g_ctx;

static int setup_group(void **state) {
    (void)state;
    return aacbvh_context_create(2, &g_ctx) == AACBVH_OK ? 0 : -1;
}

static int teardown_group(void **state) {
    (void)state;
    aacbvh_context_destroy(g_ctx);
    return 0;
}

typedef struct setup {
    aacbvh_builder builder;
    aacbvh_layout layout;
    aacbvh_triangle_storage storage;
} setup;

static aacbvh_bvh *make_bvh(const setup *s, int keep) {
    aacbvh_bvh *bvh = NULL;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, s->builder), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, s->layout), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, s->storage), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_KEEP_BUILD_MEMORY, keep), AACBVH_OK);
    return bvh;
}

static void set_mesh(aacbvh_bvh *bvh, const ts_mesh *m) {
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, m->vertices, m->vertex_count, 3 * sizeof(float), m->indices,
                                              m->triangle_count),
                     AACBVH_OK);
}

/* The kept handle's current tree equals a fresh handle's build of m, and is a valid tree of m. */
static void expect_fresh_tree(const setup *s, const aacbvh_bvh *kept, const ts_mesh *m) {
    aacbvh_bvh *fresh = make_bvh(s, 0);
    ts_tree a, b;
    char msg[512];
    float *boxes = ts_mesh_boxes(m);
    set_mesh(fresh, m);
    TS_EXPECT_STATUS(aacbvh_bvh_build(fresh), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(kept, &a), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(fresh, &b), AACBVH_OK);
    if (!ts_tree_diff(&a, &b, msg, sizeof msg))
        fail_msg("builder %d layout %d storage %d: the rebuild with kept memory differs from a fresh build: %s",
                 (int)s->builder, (int)s->layout, (int)s->storage, msg);
    /* The peak counts each thread's combine scratch, which depends on which
     * thread runs which combine: equal up to a few scratch matrices. */
    assert_true(a.stats.build_peak_bytes <= b.stats.build_peak_bytes + b.stats.build_peak_bytes / 4);
    assert_true(b.stats.build_peak_bytes <= a.stats.build_peak_bytes + a.stats.build_peak_bytes / 4);
    /* memory_bytes counts the kept blocks too, and says how much of it they are. */
    assert_true(b.stats.kept_build_bytes == 0);
    assert_true(a.stats.memory_bytes == b.stats.memory_bytes + a.stats.kept_build_bytes);
    if (!ts_check_tree(kept, boxes, m->triangle_count, NULL, 4, msg, sizeof msg)) fail_msg("%s", msg);
    ts_tree_free(&a);
    ts_tree_free(&b);
    free(boxes);
    aacbvh_bvh_destroy(fresh);
}

static void test_rebuilds_match_fresh_builds(void **state) {
    const setup setups[] = {
        {AACBVH_BUILDER_AAC_HQ, AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED},
        {AACBVH_BUILDER_AAC_FAST, AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_COPIED},
        {AACBVH_BUILDER_BINNED_SAH, AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_COPIED},
        {AACBVH_BUILDER_PLOC, AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_REFERENCED},
        {AACBVH_BUILDER_AAC_HQ, AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_COPIED},
    };
    /* Sizes alternate so that kept blocks fit, fit loosely, or do not fit. */
    const size_t sizes[] = {60000, 60000, 20000, 90000, 61000, 60000};
    ts_mesh meshes[6];
    size_t si, i;
    (void)state;
    for (i = 0; i < 6; ++i) {
        assert_true(ts_make_scene(i % 2 ? TS_SCENE_GRID : TS_SCENE_RANDOM, sizes[i], 100 + i, &meshes[i]));
        if (i == 1) ts_jitter_coords(meshes[i].vertices, 3 * meshes[i].vertex_count, 0.01f, 7);
    }
    /* Under ThreadSanitizer (10-15 times slower) the first four meshes, which
     * already make kept blocks fit, fit loosely and not fit. */
    const size_t mesh_count = TS_UNDER_TSAN ? 4 : 6;
    for (si = 0; si < sizeof setups / sizeof setups[0]; ++si) {
        aacbvh_bvh *kept = make_bvh(&setups[si], 1);
        for (i = 0; i < mesh_count; ++i) {
            set_mesh(kept, &meshes[i]);
            TS_EXPECT_STATUS(aacbvh_bvh_build(kept), AACBVH_OK);
            expect_fresh_tree(&setups[si], kept, &meshes[i]);
        }
        {
            /* The last build's freed scratch and the replaced tree stay,
             * counted. How much the first build of a new size keeps depends
             * on how its arrays fit the blocks it freed (AAC's tree takes over
             * the input's box array from 87 K triangles, docs/PERFORMANCE.md
             * row 176, and the layouts are then cut from that block: 0.6 MB
             * kept after the 90 K-triangle mesh); a second build of the same
             * mesh keeps what a build of that size frees. */
            aacbvh_stats stats;
            stats.struct_size = sizeof stats;
            TS_EXPECT_STATUS(aacbvh_bvh_get_stats(kept, &stats), AACBVH_OK);
            assert_true(stats.kept_build_bytes > 0);
            TS_EXPECT_STATUS(aacbvh_bvh_build(kept), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_get_stats(kept, &stats), AACBVH_OK);
            assert_true(stats.kept_build_bytes >= ((uint64_t)2 << 20));
            assert_true(stats.memory_bytes > stats.kept_build_bytes);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(kept, AACBVH_PARAM_KEEP_BUILD_MEMORY, 0), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_get_stats(kept, &stats), AACBVH_OK);
            assert_true(stats.kept_build_bytes == 0);
        }
        aacbvh_bvh_destroy(kept);
    }
    for (i = 0; i < 6; ++i) ts_mesh_free(&meshes[i]);
}

static void test_failed_rebuild_keeps_tree(void **state) {
    const setup s = {AACBVH_BUILDER_AAC_FAST, AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED};
    aacbvh_bvh *kept = make_bvh(&s, 1);
    ts_mesh good, bad;
    ts_tree before, after;
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 50000, 5, &good));
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 50000, 6, &bad));
    bad.vertices[3 * 1234 + 1] = NAN;

    set_mesh(kept, &good);
    TS_EXPECT_STATUS(aacbvh_bvh_build(kept), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(kept), AACBVH_OK); /* reuses the first build's memory */
    TS_EXPECT_STATUS(ts_tree_fetch(kept, &before), AACBVH_OK);

    set_mesh(kept, &bad);
    TS_EXPECT_STATUS(aacbvh_bvh_build(kept), AACBVH_ERROR_INVALID_GEOMETRY);
    assert_true(strlen(aacbvh_bvh_last_error(kept)) > 0);
    set_mesh(kept, &good);
    TS_EXPECT_STATUS(aacbvh_bvh_refit(kept), AACBVH_OK); /* the old topology is still there */
    TS_EXPECT_STATUS(ts_tree_fetch(kept, &after), AACBVH_OK);
    assert_true(ts_tree_equal(&before, &after));
    ts_tree_free(&after);

    TS_EXPECT_STATUS(aacbvh_bvh_build(kept), AACBVH_OK);
    expect_fresh_tree(&s, kept, &good);

    /* Off frees the kept blocks; on again starts from nothing. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(kept, AACBVH_PARAM_KEEP_BUILD_MEMORY, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(kept), AACBVH_OK);
    expect_fresh_tree(&s, kept, &good);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(kept, AACBVH_PARAM_KEEP_BUILD_MEMORY, 1), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(kept), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(kept), AACBVH_OK);
    expect_fresh_tree(&s, kept, &good);

    ts_tree_free(&before);
    ts_mesh_free(&good);
    ts_mesh_free(&bad);
    aacbvh_bvh_destroy(kept);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rebuilds_match_fresh_builds),
        cmocka_unit_test(test_failed_rebuild_keeps_tree),
    };
    return cmocka_run_group_tests(tests, setup_group, teardown_group);
}
