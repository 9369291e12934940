/*
 * Ray directions and intervals at the edges of the float range, through the
 * public API, in both traversal layouts:
 *   - direction components of exactly +0, -0 and denormals, and rays along
 *     each axis in both directions, against the double-precision brute force
 *     of tests/ray_reference.h;
 *   - rays starting on a surface (t = 0 counts with tmin = 0, not with
 *     tmin > 0), tmin = tmax (a hit only where the surface is exactly there),
 *     tmin > tmax (always a miss);
 *   - directions from the smallest denormal to near FLT_MAX hit what their
 *     normalised twins hit, where the answer fits a float;
 *   - invalid rays (zero direction, NaN in any field, infinite origin or
 *     direction) miss without disturbing the other rays of their batch, while
 *     an infinite tmax (or -infinite tmin) is an ordinary ray.
 */
#include <float.h>
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

static aacbvh_context *g_ctx;

static int setup_group(void **state) {
    (void)state;
    return aacbvh_context_create(1, &g_ctx) == AACBVH_OK ? 0 : -1;
}

static int teardown_group(void **state) {
    (void)state;
    aacbvh_context_destroy(g_ctx);
    return 0;
}

static const aacbvh_layout k_layouts[] = {AACBVH_LAYOUT_BINARY, AACBVH_LAYOUT_WIDE4, AACBVH_LAYOUT_WIDE8};
enum { LAYOUT_COUNT = sizeof k_layouts / sizeof k_layouts[0] };

/* A BVH over `m` with the given layout (leaves of up to 2 triangles). */
static aacbvh_bvh *build_mesh(const ts_mesh *m, aacbvh_layout layout) {
    aacbvh_bvh *bvh;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 2), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, m->vertices, m->vertex_count, 12, m->indices, m->triangle_count),
                     AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    return bvh;
}

/* Intersects `count` rays and checks each, with occluded(), against the
 * brute force (which also wants occluded() to agree with the closest hit).
 * Returns the hit count. */
static size_t check_rays(const aacbvh_bvh *bvh, const ts_mesh *m, const aacbvh_ray *rays, size_t count,
                         const char *what) {
    aacbvh_hit *hits = malloc(count * sizeof *hits);
    uint8_t *occ = malloc(count);
    size_t hit_count = 0;
    assert_non_null(hits);
    assert_non_null(occ);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, rays, hits, count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, rays, occ, count), AACBVH_OK);
    const rr_scene scene = rr_triangles(m->vertices, 3, m->indices, m->triangle_count);
    for (size_t i = 0; i < count; ++i) {
        char msg[256];
        if (!rr_check_hit(&scene, &rays[i], &hits[i], occ[i], msg, sizeof msg, NULL))
            fail_msg("%s, ray %zu (dir %a %a %a): %s", what, i, (double)rays[i].dir[0], (double)rays[i].dir[1],
                     (double)rays[i].dir[2], msg);
        hit_count += hits[i].prim_id != AACBVH_INVALID_ID;
    }
    free(hits);
    free(occ);
    return hit_count;
}

/* Rays along +-x, +-y, +-z from random points outside the scene's [-1, 1]^3
 * on that axis; the other two components are +0 or -0. */
static void test_axis_parallel(void **state) {
    (void)state;
    enum { PER_DIRECTION = 400 };
    const ts_scene_kind kinds[] = {TS_SCENE_RANDOM, TS_SCENE_GRID, TS_SCENE_FLAT};
    for (size_t s = 0; s < sizeof kinds / sizeof kinds[0]; ++s) {
        ts_mesh m;
        assert_true(ts_make_scene(kinds[s], 500, 31 + s, &m));
        for (size_t l = 0; l < LAYOUT_COUNT; ++l) {
            aacbvh_bvh *bvh = build_mesh(&m, k_layouts[l]);
            for (int axis = 0; axis < 3; ++axis)
                for (int sign = -1; sign <= 1; sign += 2) {
                    aacbvh_ray rays[PER_DIRECTION];
                    ts_rng rng;
                    char what[96];
                    ts_rng_seed(&rng, 100 + 10 * (uint64_t)axis + (uint64_t)(sign + 1));
                    for (size_t i = 0; i < PER_DIRECTION; ++i) {
                        aacbvh_ray *r = &rays[i];
                        for (int k = 0; k < 3; ++k) {
                            /* Some origins on the grid's vertex lines (multiples of 1/16). */
                            r->org[k] = (i % 4 == 0) ? (float)ts_rng_below(&rng, 17) / 16.0f
                                                     : ts_rng_range(&rng, -1.1f, 1.1f);
                            r->dir[k] = (ts_rng_next(&rng) & 1) ? 0.0f : -0.0f;
                        }
                        r->org[axis] = -3.0f * (float)sign;
                        r->dir[axis] = (float)sign * ((i % 3 == 0) ? 1.0f : ts_rng_range(&rng, 0.01f, 100.0f));
                        r->tmin = 0.0f;
                        r->tmax = INFINITY;
                    }
                    snprintf(what, sizeof what, "%s, layout %d, axis %d, sign %d", ts_scene_name(kinds[s]),
                             (int)k_layouts[l], axis, sign);
                    const size_t hits = check_rays(bvh, &m, rays, PER_DIRECTION, what);
                    /* The grid and flat scenes lie (nearly) edge-on to x and y. */
                    if ((kinds[s] == TS_SCENE_RANDOM || axis == 2) && hits < PER_DIRECTION / 10)
                        fail_msg("%s: only %zu of %d rays hit", what, hits, PER_DIRECTION);
                }
            aacbvh_bvh_destroy(bvh);
        }
        ts_mesh_free(&m);
    }
}

/* Rays aimed at the scene, then one or two components replaced by +0, -0,
 * a denormal of either sign or FLT_MIN. */
static void test_zero_and_denormal_components(void **state) {
    (void)state;
    enum { RAYS = 3000 };
    const float specials[] = {0.0f, -0.0f, 1e-40f, -1e-40f, 1.4e-45f, -1.4e-45f, FLT_MIN, -FLT_MIN};
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 500, 8, &m));
    aacbvh_ray *rays = malloc(RAYS * sizeof *rays);
    assert_non_null(rays);
    ts_rng rng;
    ts_rng_seed(&rng, 77);
    for (size_t i = 0; i < RAYS; ++i) {
        aacbvh_ray *r = &rays[i];
        const uint32_t tri = ts_rng_below(&rng, (uint32_t)m.triangle_count);
        for (int k = 0; k < 3; ++k) {
            const float target = m.vertices[3 * m.indices[3 * tri] + k];
            r->org[k] = ts_rng_range(&rng, -3.0f, 3.0f);
            r->dir[k] = target - r->org[k];
        }
        const int a = (int)ts_rng_below(&rng, 3);
        r->dir[a] = specials[ts_rng_below(&rng, 8)];
        if (i % 2) r->dir[(a + 1) % 3] = specials[ts_rng_below(&rng, 8)];
        /* Keep the origin in line with the target on the zeroed axes, so
         * many rays still hit. */
        if (r->dir[a] == 0.0f || fabsf(r->dir[a]) < FLT_MIN) r->org[a] = m.vertices[3 * m.indices[3 * tri] + a] * 0.999f;
        if (r->dir[0] == 0.0f && r->dir[1] == 0.0f && r->dir[2] == 0.0f) r->dir[(a + 2) % 3] = 1.0f;
        r->tmin = 0.0f;
        r->tmax = INFINITY;
    }
    for (size_t l = 0; l < LAYOUT_COUNT; ++l) {
        aacbvh_bvh *bvh = build_mesh(&m, k_layouts[l]);
        const size_t hits = check_rays(bvh, &m, rays, RAYS, "zero/denormal components");
        if (hits < RAYS / 10) fail_msg("only %zu of %d rays hit", hits, RAYS);
        aacbvh_bvh_destroy(bvh);
    }
    free(rays);
    ts_mesh_free(&m);
}

/* One triangle (0,0,0), (4,0,0), (0,4,0) in the plane z = 0. */
static const float k_tri[9] = {0, 0, 0, 4, 0, 0, 0, 4, 0};

static aacbvh_hit one_ray(const aacbvh_bvh *bvh, aacbvh_ray r, uint8_t *occluded) {
    aacbvh_hit h;
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &r, &h, 1), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &r, occluded, 1), AACBVH_OK);
    return h;
}

static void expect_hit(const aacbvh_bvh *bvh, aacbvh_ray r, float t, const char *what) {
    uint8_t occ;
    const aacbvh_hit h = one_ray(bvh, r, &occ);
    if (h.prim_id != 0 || h.t != t || occ != 1)
        fail_msg("%s: expected a hit at t = %g, got prim %u at t = %g (occluded %d)", what, (double)t, h.prim_id,
                 (double)h.t, occ);
}

static void expect_miss(const aacbvh_bvh *bvh, aacbvh_ray r, const char *what) {
    uint8_t occ;
    const aacbvh_hit h = one_ray(bvh, r, &occ);
    if (h.prim_id != AACBVH_INVALID_ID || h.t != INFINITY || h.u != 0.0f || h.v != 0.0f || occ != 0)
        fail_msg("%s: expected a miss, got prim %u at t = %g (occluded %d)", what, h.prim_id, (double)h.t, occ);
}

/* Rays that start on the surface, and windows [tmin, tmax] that are one
 * point or empty. The hit is at t = 0 or t = 1 exactly (dyadic values). */
static void test_surface_origin_and_windows(void **state) {
    (void)state;
    ts_mesh m = {(float *)k_tri, 3, NULL, 1};
    for (size_t l = 0; l < LAYOUT_COUNT; ++l) {
        aacbvh_bvh *bvh = build_mesh(&m, k_layouts[l]);
        const float dirs[][3] = {{0.25f, 0.5f, 1.0f}, {0.25f, 0.5f, -1.0f}, {0.0f, 0.0f, 1.0f}, {-0.0f, 0.0f, -2.0f}};
        for (size_t d = 0; d < 4; ++d) {
            aacbvh_ray r = {{1.0f, 0.5f, 0.0f}, 0.0f, {dirs[d][0], dirs[d][1], dirs[d][2]}, INFINITY};
            expect_hit(bvh, r, 0.0f, "origin on the surface, tmin = 0");
            r.tmin = -INFINITY;
            expect_hit(bvh, r, 0.0f, "origin on the surface, tmin = -inf");
            r.tmin = 1e-6f;
            expect_miss(bvh, r, "origin on the surface, tmin > 0");
            r.tmin = FLT_MIN;
            expect_miss(bvh, r, "origin on the surface, tmin = FLT_MIN");
            r.tmin = 0.0f;
            r.tmax = 0.0f;
            expect_hit(bvh, r, 0.0f, "origin on the surface, tmin = tmax = 0");
            r.tmax = -1.0f;
            expect_miss(bvh, r, "origin on the surface, tmin > tmax");
        }
        /* From z = -1 (or +1) straight at the plane: the surface is at t = 1. */
        for (int side = -1; side <= 1; side += 2) {
            aacbvh_ray r = {{1.0f, 0.5f, (float)side}, 1.0f, {0.0f, -0.0f, (float)-side}, 1.0f};
            expect_hit(bvh, r, 1.0f, "tmin = tmax = t");
            r.tmin = r.tmax = 0.5f;
            expect_miss(bvh, r, "tmin = tmax before the surface");
            r.tmin = r.tmax = 2.0f;
            expect_miss(bvh, r, "tmin = tmax past the surface");
            r.tmin = 0.0f;
            r.tmax = 1.0f;
            expect_hit(bvh, r, 1.0f, "tmax = t");
            r.tmin = 1.0f;
            r.tmax = INFINITY;
            expect_hit(bvh, r, 1.0f, "tmin = t");
            r.tmin = 2.0f;
            r.tmax = 0.5f;
            expect_miss(bvh, r, "tmin > tmax around the surface");
            r.tmin = 1.0f;
            r.tmax = 0.999f;
            expect_miss(bvh, r, "tmin > tmax just around the surface");
            r.tmin = INFINITY;
            r.tmax = INFINITY;
            expect_miss(bvh, r, "tmin = tmax = inf");
            r.tmin = INFINITY;
            r.tmax = -INFINITY;
            expect_miss(bvh, r, "tmin = inf > tmax = -inf");
            r.tmin = -INFINITY;
            r.tmax = INFINITY;
            expect_hit(bvh, r, 1.0f, "tmin = -inf, tmax = inf");
        }
        aacbvh_bvh_destroy(bvh);
    }
}

/* Random rays with tmin > tmax over a real scene: all miss. */
static void test_empty_windows_always_miss(void **state) {
    (void)state;
    enum { RAYS = 2000 };
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_GRID, 500, 3, &m));
    aacbvh_ray rays[RAYS];
    aacbvh_hit hits[RAYS];
    uint8_t occ[RAYS];
    ts_rng rng;
    ts_rng_seed(&rng, 4);
    for (size_t i = 0; i < RAYS; ++i) {
        for (int k = 0; k < 3; ++k) {
            rays[i].org[k] = ts_rng_range(&rng, -3.0f, 3.0f);
            rays[i].dir[k] = ts_rng_range(&rng, -1.0f, 1.0f) - rays[i].org[k];
        }
        rays[i].tmin = ts_rng_range(&rng, 0.0f, 2.0f);
        rays[i].tmax = i % 2 ? nextafterf(rays[i].tmin, -INFINITY) : rays[i].tmin - ts_rng_range(&rng, 0.0f, 2.0f) - 1e-3f;
    }
    for (size_t l = 0; l < LAYOUT_COUNT; ++l) {
        aacbvh_bvh *bvh = build_mesh(&m, k_layouts[l]);
        TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, rays, hits, RAYS), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, rays, occ, RAYS), AACBVH_OK);
        for (size_t i = 0; i < RAYS; ++i)
            if (hits[i].prim_id != AACBVH_INVALID_ID || occ[i])
                fail_msg("layout %d, ray %zu: tmin %g > tmax %g but hit prim %u", (int)k_layouts[l], i,
                         (double)rays[i].tmin, (double)rays[i].tmax, hits[i].prim_id);
        aacbvh_bvh_destroy(bvh);
    }
    ts_mesh_free(&m);
}

/* Invalid rays interleaved with valid ones: the invalid miss, the valid get
 * exactly the answers they get in a batch of their own. Over triangles and
 * over boxes. */
static void test_invalid_rays_in_a_batch(void **state) {
    (void)state;
    enum { VALID = 64, MAX_RAYS = 4 * VALID };
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 300, 12, &m));
    float *boxes = ts_mesh_boxes(&m);
    aacbvh_ray valid[VALID];
    ts_rng rng;
    ts_rng_seed(&rng, 21);
    for (size_t i = 0; i < VALID; ++i) {
        const uint32_t tri = ts_rng_below(&rng, (uint32_t)m.triangle_count);
        for (int k = 0; k < 3; ++k) {
            valid[i].org[k] = ts_rng_range(&rng, -3.0f, 3.0f);
            const float centroid = (m.vertices[3 * m.indices[3 * tri] + k] + m.vertices[3 * m.indices[3 * tri + 1] + k] +
                                    m.vertices[3 * m.indices[3 * tri + 2] + k]) / 3.0f;
            valid[i].dir[k] = centroid - valid[i].org[k];
        }
        /* Infinite tmax and -infinite tmin are ordinary rays. */
        valid[i].tmin = i % 3 == 0 ? -INFINITY : 0.0f;
        valid[i].tmax = INFINITY;
    }
    /* The invalid kinds: a NaN in each of the 8 fields, +-inf in each of the
     * 6 origin and direction fields, a zero direction of each sign. */
    aacbvh_ray rays[MAX_RAYS];
    int is_valid[MAX_RAYS];
    size_t n = 0, v = 0;
    for (int kind = 0; kind < 8 + 12 + 2; ++kind) {
        for (int rep = 0; rep < 2; ++rep) {
            aacbvh_ray r = valid[(size_t)(kind * 2 + rep) % VALID];
            float *field = (float *)&r;
            if (kind < 8) {
                field[kind] = NAN;
            } else if (kind < 20) {
                const int f = (kind - 8) / 2; /* org x y z, dir x y z */
                field[f < 3 ? f : f + 1] = (kind % 2) ? -INFINITY : INFINITY;
            } else {
                const float z = kind == 20 ? 0.0f : -0.0f;
                r.dir[0] = r.dir[1] = r.dir[2] = z;
            }
            rays[n] = r;
            is_valid[n++] = 0;
            rays[n] = valid[v++ % VALID];
            is_valid[n++] = 1;
        }
    }
    while (v < VALID) {
        rays[n] = valid[v++];
        is_valid[n++] = 1;
    }
    for (int geometry = 0; geometry < 2; ++geometry)
        for (size_t l = 0; l < LAYOUT_COUNT; ++l) {
            aacbvh_bvh *bvh;
            aacbvh_hit hits[MAX_RAYS], alone[VALID];
            uint8_t occ[MAX_RAYS], occ_alone[VALID];
            size_t hit_count = 0;
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, k_layouts[l]), AACBVH_OK);
            if (geometry == 0)
                TS_EXPECT_STATUS(
                    aacbvh_bvh_set_triangles(bvh, m.vertices, m.vertex_count, 12, m.indices, m.triangle_count),
                    AACBVH_OK);
            else
                TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, boxes, m.triangle_count, 24), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, rays, hits, n), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, rays, occ, n), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, valid, alone, VALID), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, valid, occ_alone, VALID), AACBVH_OK);
            for (size_t i = 0, j = 0; i < n; ++i) {
                if (!is_valid[i]) {
                    if (hits[i].prim_id != AACBVH_INVALID_ID || hits[i].t != INFINITY || hits[i].u != 0.0f ||
                        hits[i].v != 0.0f || occ[i] != 0)
                        fail_msg("%s, layout %d: invalid ray %zu (org %g %g %g, tmin %g, dir %g %g %g, tmax %g) hit "
                                 "prim %u at t = %g",
                                 geometry ? "boxes" : "triangles", (int)k_layouts[l], i, (double)rays[i].org[0],
                                 (double)rays[i].org[1], (double)rays[i].org[2], (double)rays[i].tmin,
                                 (double)rays[i].dir[0], (double)rays[i].dir[1], (double)rays[i].dir[2],
                                 (double)rays[i].tmax, hits[i].prim_id, (double)hits[i].t);
                    continue;
                }
                const aacbvh_hit *a = &alone[j];
                if (memcmp(&hits[i], a, sizeof *a) != 0 || occ[i] != occ_alone[j])
                    fail_msg("%s, layout %d: valid ray %zu answered differently beside invalid ones",
                             geometry ? "boxes" : "triangles", (int)k_layouts[l], i);
                hit_count += a->prim_id != AACBVH_INVALID_ID;
                ++j;
            }
            if (hit_count < VALID / 2)
                fail_msg("only %zu of %d valid rays hit: the batch checks too little", hit_count, VALID);
            aacbvh_bvh_destroy(bvh);
        }
    free(boxes);
    ts_mesh_free(&m);
}

/* Found by the fuzzer: a box primitive approached along a denormal direction
 * component would be entered beyond FLT_MAX; it was reported as a hit at
 * t = +inf. No float t describes that hit, so it is a miss (as for triangles),
 * in both layouts. */
static void test_box_entry_beyond_float(void **state) {
    (void)state;
    const float box[6] = {-4.0f, -4.0f, -0.5f, 4.0f, 4.0f, 0.5f};
    const aacbvh_ray ray = {{0.25f, -2.0f, -1.5f}, 0.0f, {0.0f, 0.0f, 1.1e-41f}, INFINITY};
    for (int layout = AACBVH_LAYOUT_BINARY; layout <= AACBVH_LAYOUT_WIDE8; ++layout) {
        aacbvh_context *ctx;
        aacbvh_bvh *bvh;
        ts_create(1, &ctx, &bvh);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, box, 1, sizeof box), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
        aacbvh_hit hit;
        uint8_t occluded = 7;
        TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &ray, &occluded, 1), AACBVH_OK);
        if (hit.prim_id != AACBVH_INVALID_ID || occluded != 0)
            fail_msg("layout %d: prim %u at t = %g, occluded %u; want a miss", layout, hit.prim_id, hit.t, occluded);
        aacbvh_bvh_destroy(bvh);
        aacbvh_context_destroy(ctx);
    }
}

/* Found by the fuzzer, the mirror case: a ray inside a box primitive, with
 * tmin = -inf and a direction component so small that the box's slab is
 * entered before -FLT_MAX, was reported at t = -inf. It is a hit (the ray is
 * inside the box for every t), at t = -FLT_MAX, the nearest float; a box
 * left before -FLT_MAX is a miss. Both layouts. */
static void test_box_entry_before_float(void **state) {
    (void)state;
    const float box[6] = {-4.0f, -4.0f, -0.5f, 4.0f, 4.0f, 0.5f};
    const aacbvh_ray inside = {{0.25f, -2.0f, 0.0f}, -INFINITY, {0.0f, 1e-40f, 0.0f}, INFINITY};
    const aacbvh_ray behind = {{0.25f, -2.0f, 3.0f}, -INFINITY, {0.0f, 0.0f, 1.1e-41f}, 0.0f};
    for (int layout = AACBVH_LAYOUT_BINARY; layout <= AACBVH_LAYOUT_WIDE8; ++layout) {
        aacbvh_context *ctx;
        aacbvh_bvh *bvh;
        aacbvh_hit hit;
        uint8_t occluded = 7;
        ts_create(1, &ctx, &bvh);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, box, 1, sizeof box), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &inside, &hit, 1), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &inside, &occluded, 1), AACBVH_OK);
        if (hit.prim_id != 0 || hit.t != -FLT_MAX || occluded != 1)
            fail_msg("layout %d, inside: prim %u at t = %g, occluded %u; want prim 0 at -FLT_MAX", layout,
                     hit.prim_id, hit.t, occluded);
        TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &behind, &hit, 1), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &behind, &occluded, 1), AACBVH_OK);
        if (hit.prim_id != AACBVH_INVALID_ID || occluded != 0)
            fail_msg("layout %d, behind: prim %u at t = %g, occluded %u; want a miss", layout, hit.prim_id, hit.t,
                     occluded);
        aacbvh_bvh_destroy(bvh);
        aacbvh_context_destroy(ctx);
    }
}

/* Every finite non-zero direction hits what its normalised twin hits, at
 * the t that makes the same point, wherever that t fits a float: a square of
 * two triangles (and a box) in the plane x = 0.001, rays from near the
 * origin with directions from the smallest denormal to near FLT_MAX. Once
 * 1 / dir overflowed in the ray set-up and (1e-40, 0, 0) missed a triangle
 * it reaches at t = 1e37. */
static void test_tiny_and_huge_directions(void **state) {
    (void)state;
    const float square[] = {0.001f, -1.0f, -1.0f, 0.001f, 1.0f, -1.0f, 0.001f, 1.0f, 1.0f, 0.001f, -1.0f, 1.0f};
    const uint32_t indices[] = {0, 1, 2, 0, 2, 3};
    const float box[6] = {0.001f, -1.0f, -1.0f, 0.002f, 1.0f, 1.0f};
    const float scales[] = {1.4e-45f, 1e-44f, 1e-41f, 1e-40f, 1e-38f, 1e-30f, 1e-12f, 1.0f, 1e12f, 1e30f, 3e38f};
    const float shapes[][3] = {{1, 0, 0}, {1, 0.1f, 0}, {1, 0.1f, 0.2f}, {1, -0.3f, 0.05f}};
    for (int geometry = 0; geometry < 2; ++geometry)
        for (int layout = AACBVH_LAYOUT_BINARY; layout <= AACBVH_LAYOUT_WIDE8; ++layout) {
            aacbvh_context *ctx;
            aacbvh_bvh *bvh;
            ts_create(1, &ctx, &bvh);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
            if (geometry == 0)
                TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, square, 4, 12, indices, 2), AACBVH_OK);
            else
                TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, box, 1, sizeof box), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
            for (size_t si = 0; si < sizeof shapes / sizeof shapes[0]; ++si) {
                aacbvh_ray twin = {{0.0f, 0.1f, 0.2f}, 0.0f, {0, 0, 0}, INFINITY};
                aacbvh_hit want;
                double len = 0.0;
                for (int k = 0; k < 3; ++k) len += (double)shapes[si][k] * shapes[si][k];
                for (int k = 0; k < 3; ++k) twin.dir[k] = (float)(shapes[si][k] / sqrt(len));
                TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &twin, &want, 1), AACBVH_OK);
                assert_int_not_equal(want.prim_id, AACBVH_INVALID_ID);
                for (size_t ci = 0; ci < sizeof scales / sizeof scales[0]; ++ci) {
                    aacbvh_ray ray = twin;
                    aacbvh_hit hit;
                    uint8_t occluded = 7;
                    for (int k = 0; k < 3; ++k) ray.dir[k] = shapes[si][k] * scales[ci];
                    if (ray.dir[1] == 0.0f && shapes[si][1] != 0.0f) continue; /* a component underflowed */
                    if (ray.dir[2] == 0.0f && shapes[si][2] != 0.0f) continue;
                    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
                    TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &ray, &occluded, 1), AACBVH_OK);
                    /* The exact t makes x = 0.001 (the entry face of the box too); a denormal t
                     * (huge directions) is as exact as its few bits allow. */
                    const double exact = (0.001f - (double)ray.org[0]) / (double)ray.dir[0];
                    if (exact > FLT_MAX) {
                        if (hit.prim_id != AACBVH_INVALID_ID || occluded)
                            fail_msg("geometry %d layout %d dir %a %a %a: exact t %g is past FLT_MAX, got prim %u "
                                     "at %g", geometry, layout, (double)ray.dir[0], (double)ray.dir[1],
                                     (double)ray.dir[2], exact, hit.prim_id, (double)hit.t);
                        continue;
                    }
                    if (hit.prim_id != want.prim_id || !occluded || !(fabs(hit.t - exact) <= 4e-7 * exact + 3e-45))
                        fail_msg("geometry %d layout %d dir %a %a %a: prim %u at t = %.9g (occluded %u); its "
                                 "normalised twin hits prim %u, exact t %.9g",
                                 geometry, layout, (double)ray.dir[0], (double)ray.dir[1], (double)ray.dir[2],
                                 hit.prim_id, (double)hit.t, occluded, want.prim_id, exact);
                }
            }
            aacbvh_bvh_destroy(bvh);
            aacbvh_context_destroy(ctx);
        }
}

/* Found by the fuzzer: a tiny direction (scaled inside by a power of two)
 * with a window of denormals. [0, -2^-149] is empty and must stay empty once
 * scaled (it became [0, -0] and hit at t = 0); a window whose bounds scale
 * into the denormals must not let in a hit outside it. */
static void test_tiny_direction_denormal_windows(void **state) {
    (void)state;
    const float square[] = {-1.0f, -1.0f, 0.0f, 1.0f, -1.0f, 0.0f, 1.0f, 1.0f, 0.0f, -1.0f, 1.0f, 0.0f};
    const uint32_t indices[] = {0, 1, 2, 0, 2, 3};
    for (int layout = AACBVH_LAYOUT_BINARY; layout <= AACBVH_LAYOUT_WIDE8; ++layout) {
        aacbvh_context *ctx;
        aacbvh_bvh *bvh;
        ts_create(1, &ctx, &bvh);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, square, 4, 12, indices, 2), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
        /* Origins on the square (t = 0) and above it (t = 1e-41 / 1.4e-40 = 0.07...). */
        const float heights[] = {0.0f, 1e-41f, -1e-41f};
        const float windows[][2] = {{0.0f, -0x1p-149f}, {0x1p-149f, 0x1p-148f}, {-0x1p-149f, 0.0f},
                                    {0x1p-149f, INFINITY}, {0.0f, 0.0f}, {0.5f, 0.01f}};
        for (size_t hi = 0; hi < sizeof heights / sizeof heights[0]; ++hi)
            for (size_t wi = 0; wi < sizeof windows / sizeof windows[0]; ++wi) {
                const aacbvh_ray ray = {{0.25f, 0.5f, heights[hi]}, windows[wi][0], {0.0f, 0.0f, -1.4e-40f},
                                        windows[wi][1]};
                aacbvh_hit hit;
                uint8_t occluded = 7;
                TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
                TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &ray, &occluded, 1), AACBVH_OK);
                /* The exact t of the plane z = 0. */
                const double exact = (double)heights[hi] / 1.4e-40;
                const int inside = exact >= windows[wi][0] && exact <= windows[wi][1] && fabs(exact) <= FLT_MAX;
                if (hit.prim_id != AACBVH_INVALID_ID &&
                    !(hit.t >= windows[wi][0] && hit.t <= windows[wi][1] && isfinite(hit.t)))
                    fail_msg("layout %d, height %g, window [%a, %a]: hit at t = %a outside the window", layout,
                             (double)heights[hi], (double)windows[wi][0], (double)windows[wi][1], (double)hit.t);
                if ((hit.prim_id != AACBVH_INVALID_ID) != (occluded == 1))
                    fail_msg("layout %d: occluded %u but closest hit %u", layout, occluded, hit.prim_id);
                if (windows[wi][0] > windows[wi][1] && hit.prim_id != AACBVH_INVALID_ID)
                    fail_msg("layout %d: an empty window [%a, %a] hit", layout, (double)windows[wi][0],
                             (double)windows[wi][1]);
                if (inside && exact > 1e-30 && hit.prim_id == AACBVH_INVALID_ID)
                    fail_msg("layout %d, height %g, window [%a, %a]: missed the square at t = %g", layout,
                             (double)heights[hi], (double)windows[wi][0], (double)windows[wi][1], exact);
            }
        aacbvh_bvh_destroy(bvh);
        aacbvh_context_destroy(ctx);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_axis_parallel),
        cmocka_unit_test(test_zero_and_denormal_components),
        cmocka_unit_test(test_box_entry_beyond_float),
        cmocka_unit_test(test_box_entry_before_float),
        cmocka_unit_test(test_tiny_and_huge_directions),
        cmocka_unit_test(test_tiny_direction_denormal_windows),
        cmocka_unit_test(test_surface_origin_and_windows),
        cmocka_unit_test(test_empty_windows_always_miss),
        cmocka_unit_test(test_invalid_rays_in_a_batch),
    };
    return cmocka_run_group_tests(tests, setup_group, teardown_group);
}
