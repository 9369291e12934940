/*
 * AACBVH_LAYOUT_WIDE4 against AACBVH_LAYOUT_BINARY, through the public API.
 *
 * The same geometry is built twice, once per layout, and both answer the
 * same rays: closest hits must agree exactly (t, u, v bit for bit; prim_id
 * may differ only between two hits at exactly the same t, and then u, v
 * belong to the other primitive), any-hit answers must be identical. Rays
 * include axis-parallel directions with +0 and -0 components, origins on box
 * planes, bounded [tmin, tmax] intervals and invalid (NaN, infinite, zero)
 * rays. The comparison is repeated after the vertices move and both refit,
 * over several builders, leaf sizes and degenerate scenes.
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

/* ------------------------------------------------------------------ */
/* Rays                                                                */
/* ------------------------------------------------------------------ */

static float signed_zero(ts_rng *rng) { return (ts_rng_next(rng) & 1) ? 0.0f : -0.0f; }

/* `count` rays around the box (lo, hi) of a scene whose primitives have the
 * coordinates in `coords` (coord_count floats, x y z interleaved): most aim
 * at a point of the box, some run along axes (zero components of both
 * signs), some start on a coordinate plane of the scene, some have bounded
 * or negative intervals, and a few are invalid. */
static aacbvh_ray *make_rays(const float lo[3], const float hi[3], const float *coords, size_t coord_count,
                             size_t count, uint64_t seed) {
    aacbvh_ray *rays = malloc(count * sizeof *rays);
    ts_rng rng;
    size_t i;
    int k;
    assert_non_null(rays);
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
        if (coord_count > 0 && kind < 30) {
            /* Aim at (or start from) an actual vertex or box corner coordinate. */
            const size_t v = ts_rng_below(&rng, (uint32_t)(coord_count / 3));
            for (k = 0; k < 3; ++k) target[k] = coords[3 * v + k];
        }
        for (k = 0; k < 3; ++k) r->dir[k] = target[k] - r->org[k];
        if (kind >= 30 && kind < 55) {
            /* Axis-parallel: two zero components, origin level with a target. */
            const int axis = (int)ts_rng_below(&rng, 3);
            for (k = 0; k < 3; ++k)
                if (k != axis) {
                    r->dir[k] = signed_zero(&rng);
                    r->org[k] = target[k];
                }
            if (r->dir[axis] == 0.0f) r->dir[axis] = 1.0f;
        } else if (kind >= 55 && kind < 70) {
            /* One zero component, origin on that coordinate plane. */
            const int axis = (int)ts_rng_below(&rng, 3);
            r->dir[axis] = signed_zero(&rng);
            r->org[axis] = target[axis];
            if (r->dir[0] == 0.0f && r->dir[1] == 0.0f && r->dir[2] == 0.0f) r->dir[(axis + 1) % 3] = -1.0f;
        }
        r->tmin = 0.0f;
        r->tmax = INFINITY;
        if (kind >= 70 && kind < 80) {
            r->tmin = ts_rng_range(&rng, 0.0f, 0.8f);
            r->tmax = ts_rng_range(&rng, r->tmin, 1.5f);
        } else if (kind >= 80 && kind < 85) {
            r->tmin = -INFINITY;
        } else if (kind >= 85 && kind < 88) {
            r->tmin = ts_rng_range(&rng, -1.0f, 0.5f);
            r->tmax = r->tmin; /* a single point of the ray */
        }
        if (kind == 95) r->org[ts_rng_below(&rng, 3)] = NAN;
        if (kind == 96) r->dir[ts_rng_below(&rng, 3)] = NAN;
        if (kind == 97) r->tmin = NAN;
        if (kind == 98) r->dir[ts_rng_below(&rng, 3)] = -INFINITY;
        if (kind == 99) r->dir[0] = r->dir[1] = r->dir[2] = -0.0f;
    }
    return rays;
}

/* ------------------------------------------------------------------ */
/* Comparison                                                          */
/* ------------------------------------------------------------------ */

static int same_float(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }

/* Both BVHs answer `count` rays; fails the test on any difference. Returns
 * the number of closest hits that named different primitives at one t. */
static size_t compare_layouts(const aacbvh_bvh *binary, const aacbvh_bvh *wide, const aacbvh_ray *rays,
                              size_t count, const char *what) {
    aacbvh_hit *hb = malloc(count * sizeof *hb), *hw = malloc(count * sizeof *hw);
    uint8_t *ob = malloc(count), *ow = malloc(count);
    size_t i, ties = 0, hits = 0;
    assert_non_null(hb);
    assert_non_null(hw);
    assert_non_null(ob);
    assert_non_null(ow);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(binary, rays, hb, count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(wide, rays, hw, count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(binary, rays, ob, count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(wide, rays, ow, count), AACBVH_OK);
    for (i = 0; i < count; ++i) {
        const aacbvh_hit *b = &hb[i], *w = &hw[i];
        if (!same_float(b->t, w->t))
            fail_msg("%s: ray %zu: t %.9g (binary) vs %.9g (wide4), prims %u / %u", what, i, (double)b->t,
                     (double)w->t, b->prim_id, w->prim_id);
        if (b->prim_id == w->prim_id) {
            if (!same_float(b->u, w->u) || !same_float(b->v, w->v))
                fail_msg("%s: ray %zu: u, v (%.9g, %.9g) vs (%.9g, %.9g)", what, i, (double)b->u, (double)b->v,
                         (double)w->u, (double)w->v);
        } else {
            /* A tie: both hits, different primitives, the very same t. */
            if (b->prim_id == AACBVH_INVALID_ID || w->prim_id == AACBVH_INVALID_ID)
                fail_msg("%s: ray %zu: hit vs miss (%u / %u)", what, i, b->prim_id, w->prim_id);
            ++ties;
        }
        if (b->prim_id != AACBVH_INVALID_ID) ++hits;
        if (ob[i] != ow[i]) fail_msg("%s: ray %zu: occluded %u (binary) vs %u (wide4)", what, i, ob[i], ow[i]);
        if (ob[i] != (b->prim_id != AACBVH_INVALID_ID))
            fail_msg("%s: ray %zu: occluded %u but closest hit %u", what, i, ob[i], b->prim_id);
    }
    free(hb);
    free(hw);
    free(ob);
    free(ow);
    (void)hits;
    return ties;
}

static void set_builder(aacbvh_bvh *bvh, aacbvh_builder builder, uint32_t leaf, aacbvh_layout layout) {
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, leaf), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
}

static const aacbvh_builder kBuilders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST,
                                           AACBVH_BUILDER_BINNED_SAH};
static const uint32_t kLeafSizes[] = {1, 4};
enum { kRays = 3000 };

/* Builds a mesh with both layouts for every builder and leaf size, compares,
 * moves the vertices, refits and compares again. */
static void check_mesh(ts_mesh *mesh, const char *name, uint64_t seed) {
    size_t bi, li;
    float lo[3], hi[3];
    const size_t coords = 3 * mesh->vertex_count;
    float *original = malloc((coords ? coords : 1) * sizeof *original);
    assert_non_null(original);
    memcpy(original, mesh->vertices, coords * sizeof *original);
    for (bi = 0; bi < sizeof kBuilders / sizeof kBuilders[0]; ++bi)
        for (li = 0; li < sizeof kLeafSizes / sizeof kLeafSizes[0]; ++li) {
            aacbvh_bvh *binary, *wide;
            aacbvh_ray *rays;
            char what[160];
            memcpy(mesh->vertices, original, coords * sizeof *original);
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &wide), AACBVH_OK);
            set_builder(binary, kBuilders[bi], kLeafSizes[li], AACBVH_LAYOUT_BINARY);
            set_builder(wide, kBuilders[bi], kLeafSizes[li], AACBVH_LAYOUT_WIDE4);
            TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(binary, mesh->vertices, mesh->vertex_count, 12, mesh->indices,
                                                      mesh->triangle_count),
                             AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(wide, mesh->vertices, mesh->vertex_count, 12, mesh->indices,
                                                      mesh->triangle_count),
                             AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(wide), AACBVH_OK);
            if (mesh->triangle_count > 0) assert_true(ts_memory_bytes(wide) > ts_memory_bytes(binary));

            ts_coords_bounds(mesh->vertices, coords, lo, hi);
            rays = make_rays(lo, hi, mesh->vertices, coords, kRays, seed + 17 * bi + li);
            snprintf(what, sizeof what, "%s builder %d leaf %u", name, (int)kBuilders[bi], kLeafSizes[li]);
            compare_layouts(binary, wide, rays, kRays, what);
            free(rays);

            /* Move the vertices; both refit; compare on new rays. */
            ts_coords_bounds(mesh->vertices, coords, lo, hi);
            ts_jitter_coords(mesh->vertices, coords,
                             0.05f * (hi[0] - lo[0] + hi[1] - lo[1] + hi[2] - lo[2] + 1e-3f), seed + 99);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(wide), AACBVH_OK);
            ts_coords_bounds(mesh->vertices, coords, lo, hi);
            rays = make_rays(lo, hi, mesh->vertices, coords, kRays, seed + 1000 + 17 * bi + li);
            snprintf(what, sizeof what, "%s (refitted) builder %d leaf %u", name, (int)kBuilders[bi],
                     kLeafSizes[li]);
            compare_layouts(binary, wide, rays, kRays, what);
            free(rays);

            aacbvh_bvh_destroy(binary);
            aacbvh_bvh_destroy(wide);
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

/* ------------------------------------------------------------------ */
/* Tests                                                               */
/* ------------------------------------------------------------------ */

static void test_random_soup(void **state) {
    (void)state;
    check_generated(TS_SCENE_RANDOM, 3000, 11);
}

static void test_grid(void **state) {
    (void)state;
    check_generated(TS_SCENE_GRID, 3000, 12);
}

static void test_bunny(void **state) {
    ts_mesh mesh;
    (void)state;
    if (ts_load_scene("bunny_npm_lowres.obj", &mesh)) {
        check_mesh(&mesh, "bunny_npm_lowres", 13);
        ts_mesh_free(&mesh);
    } else {
        print_message("bunny_npm_lowres.obj not available: using a generated grid instead\n");
        check_generated(TS_SCENE_GRID, 4000, 13);
    }
}

static void test_degenerate_scenes(void **state) {
    (void)state;
    check_generated(TS_SCENE_IDENTICAL, 500, 21);
    check_generated(TS_SCENE_FLAT, 1500, 22);
    check_generated(TS_SCENE_SAME_CENTROID, 500, 23);
    check_generated(TS_SCENE_ZERO_AREA, 500, 24);
    check_generated(TS_SCENE_SLIVERS, 1000, 25);
    check_generated(TS_SCENE_WIDE_RANGE, 1000, 26);
}

/* Many identical triangles in leaves of 1: a deep tree, whose traversal
 * stacks spill past their fixed part. */
static void test_deep_tree(void **state) {
    (void)state;
    check_generated(TS_SCENE_IDENTICAL, 3000, 27);
}

static void test_single_triangle(void **state) {
    (void)state;
    check_generated(TS_SCENE_RANDOM, 1, 31);
    check_generated(TS_SCENE_RANDOM, 2, 32);
    check_generated(TS_SCENE_RANDOM, 5, 33);
}

static void test_boxes(void **state) {
    size_t bi, li, i;
    const size_t count = 1500;
    (void)state;
    for (bi = 0; bi < sizeof kBuilders / sizeof kBuilders[0]; ++bi)
        for (li = 0; li < sizeof kLeafSizes / sizeof kLeafSizes[0]; ++li) {
            float *boxes = ts_random_boxes(count, 0.2f, 41 + bi);
            aacbvh_bvh *binary, *wide;
            aacbvh_ray *rays;
            const float lo[3] = {-1.0f, -1.0f, -1.0f}, hi[3] = {1.2f, 1.2f, 1.2f};
            char what[120];
            assert_non_null(boxes);
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &wide), AACBVH_OK);
            set_builder(binary, kBuilders[bi], kLeafSizes[li], AACBVH_LAYOUT_BINARY);
            set_builder(wide, kBuilders[bi], kLeafSizes[li], AACBVH_LAYOUT_WIDE4);
            TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(binary, boxes, count, 24), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(wide, boxes, count, 24), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(wide), AACBVH_OK);
            assert_true(ts_memory_bytes(wide) > ts_memory_bytes(binary));
            /* Coordinates of box corners: rays start on and aim at faces. */
            rays = make_rays(lo, hi, boxes, 6 * count, kRays, 51 + bi * 2 + li);
            snprintf(what, sizeof what, "boxes builder %d leaf %u", (int)kBuilders[bi], kLeafSizes[li]);
            compare_layouts(binary, wide, rays, kRays, what);
            free(rays);

            /* Shift every box; both refit. */
            for (i = 0; i < count; ++i) {
                const float dx = 0.01f * (float)(i % 7), dy = -0.02f * (float)(i % 3);
                boxes[6 * i] += dx;
                boxes[6 * i + 3] += dx;
                boxes[6 * i + 1] += dy;
                boxes[6 * i + 4] += dy;
            }
            TS_EXPECT_STATUS(aacbvh_bvh_refit(binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(wide), AACBVH_OK);
            rays = make_rays(lo, hi, boxes, 6 * count, kRays, 61 + bi * 2 + li);
            snprintf(what, sizeof what, "boxes (refitted) builder %d leaf %u", (int)kBuilders[bi], kLeafSizes[li]);
            compare_layouts(binary, wide, rays, kRays, what);
            free(rays);
            aacbvh_bvh_destroy(binary);
            aacbvh_bvh_destroy(wide);
            free(boxes);
        }
}

static void test_layout_param(void **state) {
    aacbvh_bvh *bvh;
    int64_t value = -1;
    double f;
    (void)state;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_LAYOUT_BINARY);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_LAYOUT_WIDE4);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, 2),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, -1),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, 1.0),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, &f),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_LAYOUT_WIDE4);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_BINARY), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_LAYOUT_BINARY);
    aacbvh_bvh_destroy(bvh);
}

/* The layout takes effect at the next build or refit; memory follows it. */
static void test_layout_switch(void **state) {
    ts_mesh mesh;
    aacbvh_bvh *binary, *bvh;
    aacbvh_ray *rays;
    float lo[3], hi[3];
    uint64_t mem_binary, mem_wide;
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 2000, 71, &mesh));
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &binary), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(binary, mesh.vertices, mesh.vertex_count, 12, mesh.indices,
                                              mesh.triangle_count),
                     AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 12, mesh.indices,
                                              mesh.triangle_count),
                     AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(binary), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    mem_binary = ts_memory_bytes(bvh);
    assert_int_equal(mem_binary, ts_memory_bytes(binary));

    ts_coords_bounds(mesh.vertices, 3 * mesh.vertex_count, lo, hi);
    rays = make_rays(lo, hi, mesh.vertices, 3 * mesh.vertex_count, kRays, 72);

    /* Switched to WIDE4 and refitted: the wide tree appears. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4), AACBVH_OK);
    assert_int_equal(ts_memory_bytes(bvh), mem_binary);
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
    mem_wide = ts_memory_bytes(bvh);
    assert_true(mem_wide > mem_binary);
    compare_layouts(binary, bvh, rays, kRays, "switched to wide4 by refit");

    /* Rebuilt with WIDE4: same memory as after the refit. */
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    assert_int_equal(ts_memory_bytes(bvh), mem_wide);
    compare_layouts(binary, bvh, rays, kRays, "rebuilt with wide4");

    /* Back to BINARY: the wide tree is freed at the next build. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_BINARY), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    assert_int_equal(ts_memory_bytes(bvh), mem_binary);
    compare_layouts(binary, bvh, rays, kRays, "back to binary");

    free(rays);
    aacbvh_bvh_destroy(binary);
    aacbvh_bvh_destroy(bvh);
    ts_mesh_free(&mesh);
}

static void test_empty_scene(void **state) {
    aacbvh_bvh *bvh;
    aacbvh_ray ray = {{0.0f, 0.0f, 0.0f}, 0.0f, {1.0f, 0.5f, 0.25f}, INFINITY};
    aacbvh_hit hit;
    uint8_t occ = 7;
    aacbvh_stats st;
    (void)state;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, NULL, 0, 12, NULL, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
    assert_int_equal(hit.prim_id, AACBVH_INVALID_ID);
    assert_true(isinf(hit.t) && hit.t > 0.0f);
    assert_true(hit.u == 0.0f && hit.v == 0.0f);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &ray, &occ, 1), AACBVH_OK);
    assert_int_equal(occ, 0);
    memset(&st, 0, sizeof st);
    st.struct_size = sizeof st;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &st), AACBVH_OK);
    assert_int_equal(st.node_count, 0);
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
    assert_int_equal(hit.prim_id, AACBVH_INVALID_ID);
    aacbvh_bvh_destroy(bvh);
}

/* A query before any build fails the same way in both layouts. */
static void test_query_before_build(void **state) {
    aacbvh_bvh *bvh;
    aacbvh_ray ray = {{0.0f, 0.0f, 0.0f}, 0.0f, {1.0f, 0.0f, 0.0f}, INFINITY};
    aacbvh_hit hit;
    (void)state;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_ERROR_INVALID_OPERATION);
    aacbvh_bvh_destroy(bvh);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layout_param),
        cmocka_unit_test(test_empty_scene),
        cmocka_unit_test(test_query_before_build),
        cmocka_unit_test(test_single_triangle),
        cmocka_unit_test(test_random_soup),
        cmocka_unit_test(test_grid),
        cmocka_unit_test(test_bunny),
        cmocka_unit_test(test_boxes),
        cmocka_unit_test(test_degenerate_scenes),
        cmocka_unit_test(test_deep_tree),
        cmocka_unit_test(test_layout_switch),
    };
    return cmocka_run_group_tests(tests, setup_group, teardown_group);
}
