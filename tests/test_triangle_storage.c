/*
 * AACBVH_TRIANGLES_COPIED against AACBVH_TRIANGLES_REFERENCED, through the
 * public API.
 *
 * The same geometry is built twice, once per storage, with the same builder
 * and layout (so the same tree), and both answer the same rays bit for bit
 * (ts_compare_answers: t, u, v, prim_id and occluded identical). Repeated
 * after the vertices move and both refit, for AAC-HQ and binned SAH, both
 * traversal layouts, random, grid, degenerate and coplanar scenes. Also: the copy's memory (36 bytes per triangle), the parameter's
 * round trip and bounds, and box geometry (where the setting is ignored).
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

/* The copy holds 36 bytes per triangle; memory_bytes counts what is held
 * from the system, big blocks in whole 2 MiB pages. */
static int copy_bytes_match(uint64_t extra, size_t triangles) {
    const uint64_t bytes = 36u * (uint64_t)triangles;
    const uint64_t page = (uint64_t)2 << 20;
    return bytes < page ? extra == bytes : extra == (bytes + page - 1) / page * page;
}

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

static const aacbvh_builder kBuilders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_BINNED_SAH};
static const aacbvh_layout kLayouts[] = {AACBVH_LAYOUT_BINARY, AACBVH_LAYOUT_WIDE4, AACBVH_LAYOUT_WIDE8};
enum { kRays = TS_RAYS(4000) };

static aacbvh_bvh *make_bvh(aacbvh_builder builder, aacbvh_layout layout, aacbvh_triangle_storage storage) {
    aacbvh_bvh *bvh;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, storage), AACBVH_OK);
    return bvh;
}

/* must_hit: the rays must hit something (not for scenes of zero-area triangles). */
static void check_mesh(ts_mesh *mesh, const char *name, uint64_t seed, int must_hit, size_t ray_count) {
    size_t bi, li;
    const size_t coords = 3 * mesh->vertex_count;
    float *original = malloc((coords ? coords : 1) * sizeof *original);
    assert_non_null(original);
    memcpy(original, mesh->vertices, coords * sizeof *original);
    for (bi = 0; bi < sizeof kBuilders / sizeof kBuilders[0]; ++bi)
        for (li = 0; li < sizeof kLayouts / sizeof kLayouts[0]; ++li) {
            aacbvh_bvh *ref = make_bvh(kBuilders[bi], kLayouts[li], AACBVH_TRIANGLES_REFERENCED);
            aacbvh_bvh *cop = make_bvh(kBuilders[bi], kLayouts[li], AACBVH_TRIANGLES_COPIED);
            aacbvh_ray *rays;
            ts_tree tr, tc;
            char what[160], msg[512];
            size_t hits;
            memcpy(mesh->vertices, original, coords * sizeof *original);
            ts_set_mesh(ref, mesh);
            ts_set_mesh(cop, mesh);
            TS_EXPECT_STATUS(aacbvh_bvh_build(ref), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(cop), AACBVH_OK);
            /* Same tree: the storage changes nothing but where triangles are read. */
            TS_EXPECT_STATUS(ts_tree_fetch(ref, &tr), AACBVH_OK);
            TS_EXPECT_STATUS(ts_tree_fetch(cop, &tc), AACBVH_OK);
            if (!ts_tree_diff(&tr, &tc, msg, sizeof msg)) fail_msg("%s: the trees differ: %s", name, msg);
            ts_tree_free(&tr);
            ts_tree_free(&tc);
            if (kLayouts[li] != AACBVH_LAYOUT_WIDE8)
                assert_true(copy_bytes_match(ts_memory_bytes(cop) - ts_memory_bytes(ref), mesh->triangle_count));
            else /* the packets are the copy (and change the wide tree's leaves): at least 36 bytes a triangle */
                assert_true(ts_memory_bytes(cop) >= 36u * (uint64_t)mesh->triangle_count);

            snprintf(what, sizeof what, "%s builder %d layout %d", name, (int)kBuilders[bi], (int)kLayouts[li]);
            rays = ts_make_rays(mesh->vertices, coords, ray_count, seed + 17 * bi + li);
            assert_non_null(rays);
            hits = ts_compare_answers(ref, cop, rays, ray_count, what);
            if (must_hit && hits == 0) fail_msg("%s: no ray hits anything", what);
            free(rays);

            /* Move the vertices; both refit; the copy follows. */
            ts_jitter_mesh(mesh, seed + 99);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(ref), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(cop), AACBVH_OK);
            snprintf(what, sizeof what, "%s (refitted) builder %d layout %d", name, (int)kBuilders[bi],
                     (int)kLayouts[li]);
            rays = ts_make_rays(mesh->vertices, coords, ray_count, seed + 1000 + 17 * bi + li);
            assert_non_null(rays);
            ts_compare_answers(ref, cop, rays, ray_count, what);

            /* Switching storage takes effect at refit, both ways. */
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(cop, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_REFERENCED),
                             AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(ref, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_COPIED),
                             AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(cop), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(ref), AACBVH_OK);
            if (kLayouts[li] != AACBVH_LAYOUT_WIDE8)
                assert_true(copy_bytes_match(ts_memory_bytes(ref) - ts_memory_bytes(cop), mesh->triangle_count));
            else /* switched at refit: the wide tree was remade with (ref) or without (cop) packets */
                assert_true(ts_memory_bytes(ref) >= 36u * (uint64_t)mesh->triangle_count);
            ts_compare_answers(cop, ref, rays, ray_count, what);
            free(rays);

            aacbvh_bvh_destroy(ref);
            aacbvh_bvh_destroy(cop);
        }
    memcpy(mesh->vertices, original, coords * sizeof *original);
    free(original);
}

static void check_generated(ts_scene_kind kind, size_t triangles, uint64_t seed) {
    /* A ray crosses most of the tree of the identical and wide-range scenes
     * (two thirds of this test's time under a sanitizer): there 300 rays,
     * still more than the 8-wide query's grain of 256. */
    const int dense = kind == TS_SCENE_IDENTICAL || kind == TS_SCENE_WIDE_RANGE;
    ts_mesh mesh;
    assert_true(ts_make_scene(kind, triangles, seed, &mesh));
    check_mesh(&mesh, ts_scene_name(kind), seed, kind != TS_SCENE_ZERO_AREA,
               TS_UNDER_SANITIZER && dense ? 300 : (size_t)kRays);
    ts_mesh_free(&mesh);
}

static void test_random_scene(void **state) {
    (void)state;
    check_generated(TS_SCENE_RANDOM, 3000, 101);
}

static void test_grid_scene(void **state) {
    (void)state;
    check_generated(TS_SCENE_GRID, 3000, 102);
}

static void test_degenerate_scenes(void **state) {
    (void)state;
    check_generated(TS_SCENE_ZERO_AREA, 500, 103);
    check_generated(TS_SCENE_IDENTICAL, 300, 104);
    check_generated(TS_SCENE_WIDE_RANGE, 1000, 105);
    check_generated(TS_SCENE_COPLANAR, 1200, 106);
    check_generated(TS_SCENE_COPLANAR_STACK, 1200, 107);
}

static void test_param(void **state) {
    aacbvh_bvh *bvh;
    int64_t value = -1;
    double f = 0.0;
    (void)state;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_TRIANGLES_COPIED); /* the default since 1.2 */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_REFERENCED), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_TRIANGLES_REFERENCED);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_COPIED), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_TRIANGLES_COPIED);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, 2), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, -1), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, 1.0),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, &f),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_TRIANGLES_COPIED); /* rejections changed nothing */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_REFERENCED),
                     AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_TRIANGLES_REFERENCED);
    aacbvh_bvh_destroy(bvh);
}

/* Box geometry ignores the setting: no copy, same answers. */
static void test_boxes(void **state) {
    const size_t count = 1500;
    size_t li;
    (void)state;
    for (li = 0; li < sizeof kLayouts / sizeof kLayouts[0]; ++li) {
        float *boxes = ts_random_boxes(count, 0.2f, 201 + li);
        aacbvh_bvh *ref = make_bvh(AACBVH_BUILDER_AAC_HQ, kLayouts[li], AACBVH_TRIANGLES_REFERENCED);
        aacbvh_bvh *cop = make_bvh(AACBVH_BUILDER_AAC_HQ, kLayouts[li], AACBVH_TRIANGLES_COPIED);
        aacbvh_ray *rays;
        assert_non_null(boxes);
        TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(ref, boxes, count, 24), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(cop, boxes, count, 24), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(ref), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(cop), AACBVH_OK);
        assert_true(ts_memory_bytes(cop) == ts_memory_bytes(ref));
        rays = ts_make_rays(boxes, 6 * count, kRays, 211 + li);
        assert_non_null(rays);
        assert_true(ts_compare_answers(ref, cop, rays, kRays, "boxes") > kRays / 10);
        TS_EXPECT_STATUS(aacbvh_bvh_refit(cop), AACBVH_OK);
        assert_true(ts_memory_bytes(cop) == ts_memory_bytes(ref));
        ts_compare_answers(ref, cop, rays, kRays, "boxes (refitted)");
        free(rays);
        free(boxes);
        aacbvh_bvh_destroy(ref);
        aacbvh_bvh_destroy(cop);
    }
}

/* An empty scene with COPIED builds, reports no extra memory, misses. */
static void test_empty_scene(void **state) {
    aacbvh_bvh *ref = make_bvh(AACBVH_BUILDER_AAC_HQ, AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_REFERENCED);
    aacbvh_bvh *cop = make_bvh(AACBVH_BUILDER_AAC_HQ, AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_COPIED);
    aacbvh_ray ray = {{0.0f, 0.0f, -1.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, INFINITY};
    (void)state;
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(ref, NULL, 0, 12, NULL, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(cop, NULL, 0, 12, NULL, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(ref), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(cop), AACBVH_OK);
    assert_true(ts_memory_bytes(cop) == ts_memory_bytes(ref));
    assert_int_equal(ts_compare_answers(ref, cop, &ray, 1, "empty"), 0);
    aacbvh_bvh_destroy(ref);
    aacbvh_bvh_destroy(cop);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_param),
        cmocka_unit_test(test_empty_scene),
        cmocka_unit_test(test_random_scene),
        cmocka_unit_test(test_grid_scene),
        cmocka_unit_test(test_degenerate_scenes),
        cmocka_unit_test(test_boxes),
    };
    return cmocka_run_group_tests(tests, setup_group, teardown_group);
}
