/*
 * Closest hit against a double-precision brute force (tests/ray_reference.h):
 * the returned t lies within the tolerance documented at
 * aacbvh_bvh_intersect(), and the returned triangle is the nearest one unless
 * another ties with it within that tolerance. Scenes near the origin and far
 * from it (1e5), at unit and large scale, with rays of random windows.
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

#include "ray_reference.h"
#include "test_support.h"

/* Moves and scales a mesh in place: v' = offset + scale * v. */
static void transform_mesh(ts_mesh *m, float offset, float scale) {
    for (size_t i = 0; i < 3 * m->vertex_count; ++i) m->vertices[i] = offset + scale * m->vertices[i];
}

/* A ray from a random point around the scene towards a random point of a
 * random triangle (so most rays hit), with a random window. */
static aacbvh_ray aimed_ray(ts_rng *rng, const ts_mesh *m, float offset, float scale) {
    aacbvh_ray r;
    const size_t tri = ts_rng_below(rng, (uint32_t)m->triangle_count);
    float u = ts_rng_float(rng), v = ts_rng_float(rng);
    if (u + v > 1.0f) { u = 1.0f - u; v = 1.0f - v; }
    float target[3];
    for (int k = 0; k < 3; ++k) {
        const float a = m->vertices[3 * m->indices[3 * tri] + k];
        const float b = m->vertices[3 * m->indices[3 * tri + 1] + k];
        const float c = m->vertices[3 * m->indices[3 * tri + 2] + k];
        target[k] = (1.0f - u - v) * a + u * b + v * c;
        r.org[k] = offset + scale * ts_rng_range(rng, -3.0f, 3.0f);
    }
    const float len = ts_rng_range(rng, 0.25f, 4.0f); /* dir not normalised */
    for (int k = 0; k < 3; ++k) r.dir[k] = (target[k] - r.org[k]) * len;
    switch (ts_rng_below(rng, 4)) {
    case 0: r.tmin = 0.0f; r.tmax = INFINITY; break;
    case 1: r.tmin = ts_rng_range(rng, 0.0f, 0.5f); r.tmax = INFINITY; break;
    case 2: r.tmin = 0.0f; r.tmax = ts_rng_range(rng, 0.1f, 1.0f); break;
    default: r.tmin = -INFINITY; r.tmax = INFINITY; break;
    }
    return r;
}

static void run_scene(ts_scene_kind kind, float offset, float scale, double *worst) {
    enum { TRIS = 600, RAYS = 3000 };
    const aacbvh_builder builders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_SWEEP_SAH};
    ts_mesh m;
    assert_true(ts_make_scene(kind, TRIS, 77, &m));
    transform_mesh(&m, offset, scale);
    aacbvh_ray *rays = malloc(RAYS * sizeof *rays);
    aacbvh_hit *hits = malloc(RAYS * sizeof *hits);
    uint8_t *occ = malloc(RAYS);
    const rr_scene scene = rr_triangles(m.vertices, 3, m.indices, m.triangle_count);
    assert_non_null(rays);
    assert_non_null(hits);
    assert_non_null(occ);
    ts_rng rng;
    ts_rng_seed(&rng, 5);
    for (size_t i = 0; i < RAYS; ++i) rays[i] = aimed_ray(&rng, &m, offset, scale);
    for (size_t b = 0; b < sizeof builders / sizeof builders[0]; ++b) {
        aacbvh_context *ctx;
        aacbvh_bvh *bvh;
        ts_create(1, &ctx, &bvh);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builders[b]), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, m.vertices, m.vertex_count, 12, m.indices, m.triangle_count),
                         AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, rays, hits, RAYS), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, rays, occ, RAYS), AACBVH_OK);
        size_t hit_count = 0;
        for (size_t i = 0; i < RAYS; ++i) {
            char msg[256];
            if (!rr_check_hit(&scene, &rays[i], &hits[i], occ[i], msg, sizeof msg, worst))
                fail_msg("%s, offset %g, scale %g, builder %d, ray %zu: %s", ts_scene_name(kind), (double)offset,
                         (double)scale, (int)builders[b], i, msg);
            hit_count += hits[i].prim_id != AACBVH_INVALID_ID;
        }
        if (hit_count < RAYS / 4)
            fail_msg("%s, offset %g, scale %g: only %zu of %d rays hit", ts_scene_name(kind), (double)offset,
                     (double)scale, hit_count, RAYS);
        aacbvh_bvh_destroy(bvh);
        aacbvh_context_destroy(ctx);
    }
    free(rays);
    free(hits);
    free(occ);
    ts_mesh_free(&m);
}

static void test_closest_hit_tolerance(void **state) {
    (void)state;
    /* (offset, scale): near the origin at three scales, and far from it with
     * the scene still many float steps wide. */
    const float placements[][2] = {{0.0f, 1.0f}, {0.0f, 1000.0f}, {0.0f, 1e-3f},
                                   {1e4f, 1.0f}, {1e5f, 100.0f},  {-3e4f, 10.0f}};
    double worst = 0.0;
    for (size_t i = 0; i < sizeof placements / sizeof placements[0]; ++i) {
        run_scene(TS_SCENE_RANDOM, placements[i][0], placements[i][1], &worst);
        run_scene(TS_SCENE_GRID, placements[i][0], placements[i][1], &worst);
    }
    printf("closest hit: largest |t - t_exact| is %.3g of the documented tolerance\n", worst);
}

/* Two parallel squares 1e-3 apart: the nearer always wins; at 0 apart (a
 * tie) either may. */
static void test_nearest_of_stacked(void **state) {
    (void)state;
    const float gaps[] = {1e-3f, 1e-2f, 0.0f};
    for (size_t g = 0; g < 3; ++g) {
        const float z1 = 1e5f, z2 = 1e5f + gaps[g] * 1e5f;
        const float v[] = {-1, -1, z1, 1, -1, z1, 0, 1, z1, -1, -1, z2, 1, -1, z2, 0, 1, z2};
        aacbvh_context *ctx;
        aacbvh_bvh *bvh;
        ts_create(1, &ctx, &bvh);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 1), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 6, 12, NULL, 2), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
        ts_rng rng;
        ts_rng_seed(&rng, 9);
        for (int i = 0; i < 2000; ++i) {
            const int up = i & 1;
            aacbvh_ray r = {{ts_rng_range(&rng, -0.3f, 0.3f), ts_rng_range(&rng, -0.5f, 0.0f), up ? 0.0f : 3e5f},
                            0.0f,
                            {ts_rng_range(&rng, -1e-7f, 1e-7f), ts_rng_range(&rng, -1e-7f, 1e-7f), up ? 1.0f : -1.0f},
                            INFINITY};
            aacbvh_hit h;
            TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &r, &h, 1), AACBVH_OK);
            assert_true(h.prim_id != AACBVH_INVALID_ID);
            if (gaps[g] > 0.0f) assert_int_equal(h.prim_id, up ? 0u : 1u);
        }
        aacbvh_bvh_destroy(bvh);
        aacbvh_context_destroy(ctx);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_closest_hit_tolerance),
        cmocka_unit_test(test_nearest_of_stacked),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
