/*
 * AACBVH_TRIANGLES_COPIED against AACBVH_TRIANGLES_REFERENCED, through the
 * public API.
 *
 * The same geometry is built twice, once per storage, with the same builder
 * and layout (so the same tree), and both answer the same rays: the closest
 * hits must be bit-identical (memcmp of the hit records) and the any-hit
 * answers identical. Repeated after the vertices move and both refit, for
 * AAC-HQ and binned SAH, both traversal layouts, random, grid and degenerate
 * scenes. Also: the copy's memory (36 bytes per triangle), the parameter's
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
static const aacbvh_layout kLayouts[] = {AACBVH_LAYOUT_BINARY, AACBVH_LAYOUT_WIDE4};
enum { kRays = 4000 };

/* Rays from around the box (lo, hi): half aim at a vertex of the scene, the
 * rest at random points; some run along an axis, some have bounded
 * intervals. */
static aacbvh_ray *make_rays(const float *coords, size_t coord_count, size_t count, uint64_t seed) {
    aacbvh_ray *rays = malloc(count * sizeof *rays);
    float lo[3], hi[3];
    ts_rng rng;
    size_t i;
    int k;
    assert_non_null(rays);
    ts_coords_bounds(coords, coord_count, lo, hi);
    ts_rng_seed(&rng, seed);
    for (i = 0; i < count; ++i) {
        aacbvh_ray *r = &rays[i];
        float target[3];
        const uint32_t kind = ts_rng_below(&rng, 100);
        for (k = 0; k < 3; ++k) {
            const float ext = hi[k] - lo[k] > 0.0f ? hi[k] - lo[k] : 1.0f;
            r->org[k] = ts_rng_range(&rng, lo[k] - 0.5f * ext, hi[k] + 0.5f * ext);
            target[k] = ts_rng_range(&rng, lo[k], hi[k]);
        }
        if (coord_count >= 3 && kind < 50) {
            const size_t v = ts_rng_below(&rng, (uint32_t)(coord_count / 3));
            for (k = 0; k < 3; ++k) target[k] = coords[3 * v + k];
        }
        for (k = 0; k < 3; ++k) r->dir[k] = target[k] - r->org[k];
        if (kind >= 50 && kind < 65) {
            const int axis = (int)ts_rng_below(&rng, 3);
            for (k = 0; k < 3; ++k)
                if (k != axis) {
                    r->dir[k] = 0.0f;
                    r->org[k] = target[k];
                }
            if (r->dir[axis] == 0.0f) r->dir[axis] = 1.0f;
        }
        if (r->dir[0] == 0.0f && r->dir[1] == 0.0f && r->dir[2] == 0.0f) r->dir[2] = 1.0f;
        r->tmin = 0.0f;
        r->tmax = INFINITY;
        if (kind >= 65 && kind < 80) {
            r->tmin = ts_rng_range(&rng, 0.0f, 0.8f);
            r->tmax = ts_rng_range(&rng, r->tmin, 1.5f);
        }
    }
    return rays;
}

static aacbvh_bvh *make_bvh(aacbvh_builder builder, aacbvh_layout layout, aacbvh_triangle_storage storage) {
    aacbvh_bvh *bvh;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, storage), AACBVH_OK);
    return bvh;
}

/* Both handles answer the rays identically, bit for bit. Returns the hit count. */
static size_t compare(const aacbvh_bvh *referenced, const aacbvh_bvh *copied, const aacbvh_ray *rays, size_t count,
                      const char *what) {
    aacbvh_hit *hr = malloc(count * sizeof *hr), *hc = malloc(count * sizeof *hc);
    uint8_t *orr = malloc(count), *oc = malloc(count);
    size_t i, hits = 0;
    assert_non_null(hr);
    assert_non_null(hc);
    assert_non_null(orr);
    assert_non_null(oc);
    memset(hr, 0xAB, count * sizeof *hr);
    memset(hc, 0xCD, count * sizeof *hc);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(referenced, rays, hr, count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(copied, rays, hc, count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(referenced, rays, orr, count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(copied, rays, oc, count), AACBVH_OK);
    for (i = 0; i < count; ++i) {
        if (memcmp(&hr[i], &hc[i], sizeof hr[i]) != 0)
            fail_msg("%s: ray %zu: hit (t %.9g, u %.9g, v %.9g, prim %u) referenced vs (t %.9g, u %.9g, v %.9g, "
                     "prim %u) copied",
                     what, i, (double)hr[i].t, (double)hr[i].u, (double)hr[i].v, hr[i].prim_id, (double)hc[i].t,
                     (double)hc[i].u, (double)hc[i].v, hc[i].prim_id);
        if (orr[i] != oc[i]) fail_msg("%s: ray %zu: occluded %u referenced vs %u copied", what, i, orr[i], oc[i]);
        if (hr[i].prim_id != AACBVH_INVALID_ID) ++hits;
    }
    free(hr);
    free(hc);
    free(orr);
    free(oc);
    return hits;
}

static void check_mesh(ts_mesh *mesh, const char *name, uint64_t seed) {
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
            char what[160];
            float lo[3], hi[3];
            size_t hits;
            memcpy(mesh->vertices, original, coords * sizeof *original);
            TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(ref, mesh->vertices, mesh->vertex_count, 12, mesh->indices,
                                                      mesh->triangle_count),
                             AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(cop, mesh->vertices, mesh->vertex_count, 12, mesh->indices,
                                                      mesh->triangle_count),
                             AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(ref), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(cop), AACBVH_OK);
            /* Same tree: the storage changes nothing but where triangles are read. */
            TS_EXPECT_STATUS(ts_tree_fetch(ref, &tr), AACBVH_OK);
            TS_EXPECT_STATUS(ts_tree_fetch(cop, &tc), AACBVH_OK);
            assert_true(ts_tree_equal(&tr, &tc));
            ts_tree_free(&tr);
            ts_tree_free(&tc);
            assert_true(copy_bytes_match(ts_memory_bytes(cop) - ts_memory_bytes(ref), mesh->triangle_count));

            snprintf(what, sizeof what, "%s builder %d layout %d", name, (int)kBuilders[bi], (int)kLayouts[li]);
            rays = make_rays(mesh->vertices, coords, kRays, seed + 17 * bi + li);
            hits = compare(ref, cop, rays, kRays, what);
            if (mesh->triangle_count >= 100) assert_true(hits > 0);
            free(rays);

            /* Move the vertices; both refit; the copy follows. */
            ts_coords_bounds(mesh->vertices, coords, lo, hi);
            ts_jitter_coords(mesh->vertices, coords,
                             0.05f * (hi[0] - lo[0] + hi[1] - lo[1] + hi[2] - lo[2] + 1e-3f), seed + 99);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(ref), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(cop), AACBVH_OK);
            snprintf(what, sizeof what, "%s (refitted) builder %d layout %d", name, (int)kBuilders[bi],
                     (int)kLayouts[li]);
            rays = make_rays(mesh->vertices, coords, kRays, seed + 1000 + 17 * bi + li);
            compare(ref, cop, rays, kRays, what);

            /* Switching storage takes effect at refit, both ways. */
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(cop, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_REFERENCED),
                             AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(ref, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_COPIED),
                             AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(cop), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(ref), AACBVH_OK);
            assert_true(copy_bytes_match(ts_memory_bytes(ref) - ts_memory_bytes(cop), mesh->triangle_count));
            compare(cop, ref, rays, kRays, what);
            free(rays);

            aacbvh_bvh_destroy(ref);
            aacbvh_bvh_destroy(cop);
        }
    memcpy(mesh->vertices, original, coords * sizeof *original);
    free(original);
}

static void check_generated(ts_scene_kind kind, size_t triangles, uint64_t seed) {
    ts_mesh mesh;
    assert_true(ts_make_scene(kind, triangles, seed, &mesh));
    check_mesh(&mesh, ts_scene_name(kind), seed);
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
}

static void test_param(void **state) {
    aacbvh_bvh *bvh;
    int64_t value = -1;
    double f = 0.0;
    (void)state;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
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
        rays = make_rays(boxes, 6 * count, kRays, 211 + li);
        assert_true(compare(ref, cop, rays, kRays, "boxes") > 0);
        TS_EXPECT_STATUS(aacbvh_bvh_refit(cop), AACBVH_OK);
        assert_true(ts_memory_bytes(cop) == ts_memory_bytes(ref));
        compare(ref, cop, rays, kRays, "boxes (refitted)");
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
    compare(ref, cop, &ray, 1, "empty");
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
