/*
 * Closest hit against a double-precision brute force (tests/ray_reference.h):
 * the returned t lies within the tolerance documented at
 * aacbvh_bvh_intersect(), and the returned triangle is the nearest one unless
 * another ties with it within that tolerance. Scenes near the origin and far
 * from it (1e5), at unit and large scale, with rays of random windows; and
 * short rays, head-on and grazing, towards huge triangles.
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
    /* TS_RAYS: 1100 rays under ThreadSanitizer (these contexts run one
     * thread; the oracle's 600 triangles a ray were most of the time there). */
    enum { TRIS = 600, RAYS = TS_RAYS(3000) };
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

/* Short rays towards huge triangles, the case where a distance formed from
 * terms as large as the distance to the vertices cancels: triangles 2e4 wide,
 * at the origin and 1e5 from it, tilted, hit from 1e-3 to 10 away, head-on
 * and grazing (cos theta down to 1e-3). The reported t must keep the
 * documented bound, which here is within a few ulps of the exact distance
 * (the single-precision formula of the paper was 1e-3 off, relative). */
static void test_near_hits_on_huge_triangles(void **state) {
    (void)state;
    const float offsets[] = {0.0f, 1e5f, -3e4f};
    double worst = 0.0;
    ts_rng rng;
    ts_rng_seed(&rng, 1234);
    for (size_t o = 0; o < sizeof offsets / sizeof offsets[0]; ++o) {
        enum { TRIS = 40, RAYS = 4000 };
        float v[TRIS * 9];
        for (int t = 0; t < TRIS; ++t) {
            /* A big triangle around a point of a gently curved sheet. */
            const float cx = ts_rng_range(&rng, -1.0f, 1.0f) * 3e4f, cy = ts_rng_range(&rng, -1.0f, 1.0f) * 3e4f;
            for (int j = 0; j < 3; ++j) {
                const float x = cx + ts_rng_range(&rng, -1.0f, 1.0f) * 1e4f;
                const float y = cy + ts_rng_range(&rng, -1.0f, 1.0f) * 1e4f;
                v[9 * t + 3 * j + 0] = offsets[o] + x;
                v[9 * t + 3 * j + 1] = offsets[o] + y;
                v[9 * t + 3 * j + 2] = offsets[o] + 0.05f * x + 0.02f * y + 100.0f * (float)t;
            }
        }
        const rr_scene scene = rr_triangles(v, 3, NULL, TRIS);
        aacbvh_context *ctx;
        aacbvh_bvh *bvh;
        ts_create(1, &ctx, &bvh);
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 3 * TRIS, 12, NULL, TRIS), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
        size_t hits = 0;
        for (int i = 0; i < RAYS; ++i) {
            /* From just above a random point of a random triangle, towards it. */
            const int t = (int)ts_rng_below(&rng, TRIS);
            float a = ts_rng_float(&rng), b = ts_rng_float(&rng);
            if (a + b > 1.0f) { a = 1.0f - a; b = 1.0f - b; }
            double p[3], e1[3], e2[3], n[3], nl;
            for (int k = 0; k < 3; ++k) {
                const float *q = v + 9 * t;
                e1[k] = (double)q[3 + k] - q[k];
                e2[k] = (double)q[6 + k] - q[k];
                p[k] = q[k] + a * e1[k] + b * e2[k];
            }
            n[0] = e1[1] * e2[2] - e1[2] * e2[1];
            n[1] = e1[2] * e2[0] - e1[0] * e2[2];
            n[2] = e1[0] * e2[1] - e1[1] * e2[0];
            nl = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            const double height = pow(10.0, ts_rng_range(&rng, -3.0f, 1.0f));
            const double cosine = pow(10.0, ts_rng_range(&rng, -3.0f, 0.0f));
            /* A direction at angle theta from -n: its in-plane part along e1. */
            const double el = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
            const double sine = sqrt(1.0 - cosine * cosine);
            aacbvh_ray r;
            for (int k = 0; k < 3; ++k) {
                const double dir = -cosine * n[k] / nl + sine * e1[k] / el;
                r.dir[k] = (float)dir;
                r.org[k] = (float)(p[k] - dir * (height / cosine)); /* the plane `height` away */
            }
            r.tmin = 0.0f;
            r.tmax = INFINITY;
            aacbvh_hit h;
            uint8_t occ;
            char msg[256];
            TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &r, &h, 1), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &r, &occ, 1), AACBVH_OK);
            if (!rr_check_hit(&scene, &r, &h, occ, msg, sizeof msg, &worst))
                fail_msg("offset %g, ray %d (height %.3g, cos %.3g): %s", (double)offsets[o], i, height, cosine, msg);
            hits += h.prim_id != AACBVH_INVALID_ID;
        }
        if (hits < RAYS / 2) fail_msg("offset %g: only %zu of %d rays hit", (double)offsets[o], hits, (int)RAYS);
        aacbvh_bvh_destroy(bvh);
        aacbvh_context_destroy(ctx);
    }
    printf("near hits on huge triangles: largest |t - t_exact| is %.3g of the documented tolerance\n", worst);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_closest_hit_tolerance),
        cmocka_unit_test(test_nearest_of_stacked),
        cmocka_unit_test(test_near_hits_on_huge_triangles),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
