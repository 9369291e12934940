/*
 * Ray queries against brute force, through the public C API only.
 *
 * The reference is the tests' double-precision oracle (ray_reference.h):
 * triangles by the sides of the edges the ray passes on, boxes by a slab
 * test, over every primitive. Each primitive is classified per ray as a
 * certain hit, a certain miss, or "either" (within rounding distance of an
 * edge or face, of tmin or tmax, or nearly parallel), so the checks cannot
 * flake on rounding (rr_check):
 *   closest hit: a miss is wrong only if some certain hit exists; a hit must
 *     name a primitive that is not a certain miss, within the documented
 *     tolerance of its reference distance, no farther than the nearest
 *     certain hit and the nearest unless another ties with it, and
 *     (1-u-v) v0 + u v1 + v v2 must be org + t dir (u = v = 0 for boxes);
 *   any hit: agrees with the closest hit.
 * Watertightness, exact tmin/tmax bounds, barycentric order, invalid rays and
 * empty scenes have exact checks of their own.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include <aacbvh/aacbvh.h>

#include "ray_reference.h"

/* ------------------------------------------------------------------ */
/* Random numbers                                                     */
/* ------------------------------------------------------------------ */

typedef struct rng {
    uint64_t s;
} rng;

static uint64_t rng_next(rng *r) {
    uint64_t x = r->s;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    r->s = x;
    return x;
}
/* Uniform in [0, 1). */
static float rng_float(rng *r) { return (float)((double)(rng_next(r) >> 40) / 16777216.0); }
static float rng_range(rng *r, float lo, float hi) { return lo + (hi - lo) * rng_float(r); }
static uint32_t rng_below(rng *r, uint32_t n) { return (uint32_t)(rng_next(r) % n); }
static float rng_signed_zero(rng *r) { return (rng_next(r) & 1) ? 0.0f : -0.0f; }

/* ------------------------------------------------------------------ */
/* Scenes                                                             */
/* ------------------------------------------------------------------ */

enum { VERTEX_FLOATS = 4 }; /* stride 16 bytes; the 4th float is a NaN that must never be read */
enum { BOX_FLOATS = 7 };    /* stride 28 bytes; the 7th float is a NaN */

typedef struct scene {
    int is_boxes;
    float *data;        /* vertices (VERTEX_FLOATS each) or boxes (BOX_FLOATS each) */
    size_t vertex_count;
    uint32_t *indices;  /* NULL: triangle i is vertices 3i, 3i+1, 3i+2 */
    size_t prim_count;
} scene;

static void scene_free(scene *s) {
    free(s->data);
    free(s->indices);
    memset(s, 0, sizeof *s);
}

static void set_vertex(float *p, float x, float y, float z) {
    p[0] = x;
    p[1] = y;
    p[2] = z;
    p[3] = NAN;
}

/* A soup of n triangles in the unit cube: mostly small, some large, some
 * axis-aligned (flat bounding boxes), a few degenerate (zero area). */
static scene make_soup(uint32_t n, uint64_t seed) {
    rng r = {seed};
    scene s;
    memset(&s, 0, sizeof s);
    s.vertex_count = 3 * (size_t)n;
    s.prim_count = n;
    s.data = malloc(s.vertex_count * VERTEX_FLOATS * sizeof(float));
    assert_non_null(s.data);
    for (uint32_t i = 0; i < n; ++i) {
        const float c[3] = {rng_float(&r), rng_float(&r), rng_float(&r)};
        const float size = (i % 50 == 0) ? 0.5f : 0.06f;
        float p[3][3];
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) p[j][k] = c[k] + rng_range(&r, -size, size);
        const uint32_t kind = i % 10;
        if (kind == 1 || kind == 2) { /* axis-aligned */
            const uint32_t axis = rng_below(&r, 3);
            p[1][axis] = p[0][axis];
            p[2][axis] = p[0][axis];
        } else if (kind == 3 && i % 20 == 3) { /* degenerate: collinear or a point */
            for (int k = 0; k < 3; ++k) {
                p[2][k] = (i % 40 == 3) ? p[0][k] : 0.5f * (p[0][k] + p[1][k]);
                if (i % 40 == 3) p[1][k] = p[0][k];
            }
        }
        for (int j = 0; j < 3; ++j)
            set_vertex(s.data + (3 * (size_t)i + j) * VERTEX_FLOATS, p[j][0], p[j][1], p[j][2]);
    }
    return s;
}

/* An n x n grid over [0,1]^2 with shared, indexed vertices at z = z0 + sx x + sy y
 * (sx = sy = 0: a flat, axis-aligned mesh whose leaves have flat boxes). */
static scene make_grid(uint32_t n, float z0, float sx, float sy) {
    scene s;
    memset(&s, 0, sizeof s);
    s.vertex_count = (size_t)(n + 1) * (n + 1);
    s.prim_count = 2 * (size_t)n * n;
    s.data = malloc(s.vertex_count * VERTEX_FLOATS * sizeof(float));
    s.indices = malloc(3 * s.prim_count * sizeof(uint32_t));
    assert_non_null(s.data);
    assert_non_null(s.indices);
    for (uint32_t i = 0; i <= n; ++i)
        for (uint32_t j = 0; j <= n; ++j) {
            const float x = (float)i / (float)n, y = (float)j / (float)n;
            set_vertex(s.data + ((size_t)i * (n + 1) + j) * VERTEX_FLOATS, x, y, z0 + sx * x + sy * y);
        }
    size_t t = 0;
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = 0; j < n; ++j) {
            const uint32_t a = i * (n + 1) + j, b = a + 1, c = a + n + 1, d = c + 1;
            /* alternate the diagonal and the winding */
            const uint32_t q[6] = {a, b, d, a, d, c};
            const uint32_t q2[6] = {a, c, b, b, c, d};
            for (int k = 0; k < 6; ++k) s.indices[t + k] = ((i + j) & 1) ? q2[k] : q[k];
            t += 6;
        }
    return s;
}

/* n boxes in the unit cube; some flat on one axis, a few on two or three. */
static scene make_boxes(uint32_t n, uint64_t seed) {
    rng r = {seed};
    scene s;
    memset(&s, 0, sizeof s);
    s.is_boxes = 1;
    s.prim_count = n;
    s.data = malloc((size_t)n * BOX_FLOATS * sizeof(float));
    assert_non_null(s.data);
    for (uint32_t i = 0; i < n; ++i) {
        float *b = s.data + (size_t)i * BOX_FLOATS;
        for (int k = 0; k < 3; ++k) {
            const float c = rng_float(&r);
            float e = rng_range(&r, 0.0f, (i % 40 == 0) ? 0.3f : 0.04f);
            if ((i % 7 == 0 && k == (int)(i % 3)) || (i % 31 == 0 && k != 0) || i % 97 == 0) e = 0.0f;
            b[k] = c - e;
            b[3 + k] = c + e;
        }
        b[6] = NAN;
    }
    return s;
}

/* ------------------------------------------------------------------ */
/* Rays                                                               */
/* ------------------------------------------------------------------ */

/* Random rays of several kinds around the unit cube. */
static aacbvh_ray *make_rays(size_t count, uint64_t seed) {
    rng r = {seed};
    aacbvh_ray *rays = malloc(count * sizeof *rays);
    assert_non_null(rays);
    for (size_t i = 0; i < count; ++i) {
        aacbvh_ray *ray = &rays[i];
        const uint32_t kind = (uint32_t)(i % 6);
        for (int k = 0; k < 3; ++k) ray->org[k] = rng_range(&r, -0.2f, 1.2f);
        ray->tmin = 0.0f;
        ray->tmax = INFINITY;
        if (kind == 0) { /* from outside, aimed into the cube */
            double d[3], len;
            do {
                for (int k = 0; k < 3; ++k) d[k] = rng_range(&r, -1.0f, 1.0f);
                len = rr_len(d);
            } while (len < 0.1 || len > 1.0);
            for (int k = 0; k < 3; ++k) {
                ray->org[k] = (float)(0.5 + 2.0 * d[k] / len);
                ray->dir[k] = rng_float(&r) - ray->org[k];
            }
        } else if (kind == 1) { /* from inside, any direction */
            for (int k = 0; k < 3; ++k) {
                ray->org[k] = rng_float(&r);
                ray->dir[k] = rng_range(&r, -1.0f, 1.0f);
            }
        } else if (kind == 2) { /* axis-parallel, signed zeros elsewhere */
            const uint32_t axis = rng_below(&r, 3);
            for (int k = 0; k < 3; ++k) ray->dir[k] = rng_signed_zero(&r);
            ray->dir[axis] = (rng_next(&r) & 1) ? 1.0f : -1.0f;
        } else if (kind == 3) { /* one zero component */
            for (int k = 0; k < 3; ++k) ray->dir[k] = rng_range(&r, -1.0f, 1.0f);
            ray->dir[rng_below(&r, 3)] = rng_signed_zero(&r);
        } else { /* random, with a tmin/tmax window (sometimes negative tmin) */
            for (int k = 0; k < 3; ++k) ray->dir[k] = rng_range(&r, -1.0f, 1.0f);
            ray->tmin = rng_range(&r, kind == 5 ? -1.0f : 0.0f, 1.0f);
            ray->tmax = ray->tmin + rng_range(&r, 0.0f, 1.5f);
        }
        if (ray->dir[0] == 0.0f && ray->dir[1] == 0.0f && ray->dir[2] == 0.0f) ray->dir[0] = 1.0f;
    }
    return rays;
}

/* ------------------------------------------------------------------ */
/* Library helpers                                                    */
/* ------------------------------------------------------------------ */

static aacbvh_context *g_context;

static int setup(void **state) {
    (void)state;
    return aacbvh_context_create(2, &g_context) == AACBVH_OK ? 0 : -1;
}
static int teardown(void **state) {
    (void)state;
    aacbvh_context_destroy(g_context);
    return 0;
}

static aacbvh_bvh *build_scene(const scene *s, aacbvh_builder builder, int64_t max_leaf) {
    aacbvh_bvh *bvh = NULL;
    assert_int_equal(aacbvh_bvh_create(g_context, &bvh), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, max_leaf), AACBVH_OK);
    if (s->is_boxes)
        assert_int_equal(aacbvh_bvh_set_boxes(bvh, s->data, s->prim_count, BOX_FLOATS * sizeof(float)),
                         AACBVH_OK);
    else
        assert_int_equal(aacbvh_bvh_set_triangles(bvh, s->data, s->vertex_count,
                                                  VERTEX_FLOATS * sizeof(float), s->indices,
                                                  s->prim_count),
                         AACBVH_OK);
    assert_int_equal(aacbvh_bvh_build(bvh), AACBVH_OK);
    return bvh;
}

/* The scene as the reference sees it. */
static rr_scene reference_scene(const scene *s) {
    if (s->is_boxes) return rr_boxes(s->data, BOX_FLOATS, s->prim_count);
    return rr_triangles(s->data, VERTEX_FLOATS, s->indices, s->prim_count);
}

static const aacbvh_builder k_builders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST};
static const int64_t k_leaf_sizes[] = {1, 4, 16};

/* Every builder and leaf size against the reference, over `count` rays. */
static void run_differential(const scene *s, size_t count, uint64_t seed) {
    aacbvh_ray *rays = make_rays(count, seed);
    rr_answer *refs = malloc(count * sizeof *refs);
    aacbvh_hit *hits = malloc(count * sizeof *hits);
    uint8_t *occ = malloc(count);
    const rr_scene ref_scene = reference_scene(s);
    assert_non_null(refs);
    assert_non_null(hits);
    assert_non_null(occ);
    size_t certain = 0;
    for (size_t i = 0; i < count; ++i) {
        refs[i] = rr_reference(&ref_scene, &rays[i]);
        certain += refs[i].best != (size_t)-1;
    }
    /* The rays must actually hit things for the test to mean anything. */
    assert_true(certain > count / 10);
    for (size_t b = 0; b < sizeof k_builders / sizeof k_builders[0]; ++b)
        for (size_t l = 0; l < sizeof k_leaf_sizes / sizeof k_leaf_sizes[0]; ++l) {
            aacbvh_bvh *bvh = build_scene(s, k_builders[b], k_leaf_sizes[l]);
            assert_int_equal(aacbvh_bvh_intersect(bvh, rays, hits, count), AACBVH_OK);
            assert_int_equal(aacbvh_bvh_occluded(bvh, rays, occ, count), AACBVH_OK);
            for (size_t i = 0; i < count; ++i) {
                char msg[320];
                if (!rr_check(&ref_scene, &refs[i], &rays[i], &hits[i], occ[i], msg, sizeof msg, NULL))
                    fail_msg("builder %d, leaf %d, ray %zu: %s", (int)k_builders[b], (int)k_leaf_sizes[l], i, msg);
            }
            aacbvh_bvh_destroy(bvh);
        }
    free(occ);
    free(hits);
    free(refs);
    free(rays);
}

/* ------------------------------------------------------------------ */
/* Tests                                                              */
/* ------------------------------------------------------------------ */

static void test_soup_matches_brute_force(void **state) {
    (void)state;
    scene s = make_soup(1500, 0x9E3779B97F4A7C15ull);
    run_differential(&s, 4000, 12345);
    scene_free(&s);
}

static void test_grid_matches_brute_force(void **state) {
    (void)state;
    scene flat = make_grid(32, 0.5f, 0.0f, 0.0f);
    run_differential(&flat, 3000, 777);
    scene_free(&flat);
    scene tilted = make_grid(32, 0.2f, 0.3f, 0.25f);
    run_differential(&tilted, 3000, 778);
    scene_free(&tilted);
}

static void test_boxes_match_brute_force(void **state) {
    (void)state;
    scene s = make_boxes(1500, 4242);
    run_differential(&s, 4000, 99);
    scene_free(&s);
}

/* Rays through vertices and edges of a closed mesh must hit it: the
 * watertight test leaves no gap, and the box test must not cull rays that
 * run exactly along a node's face (direction +-0 with the origin on the
 * plane) or hit flat boxes. */
static void test_watertight_grid(void **state) {
    (void)state;
    const uint32_t n = 16;
    const float tilt[2][3] = {{0.5f, 0.0f, 0.0f}, {0.2f, 0.3f, 0.25f}};
    rng r = {31337};
    for (int g = 0; g < 2; ++g) {
        scene s = make_grid(n, tilt[g][0], tilt[g][1], tilt[g][2]);
        for (size_t b = 0; b < sizeof k_builders / sizeof k_builders[0]; ++b)
            for (size_t l = 0; l < sizeof k_leaf_sizes / sizeof k_leaf_sizes[0]; ++l) {
                aacbvh_bvh *bvh = build_scene(&s, k_builders[b], k_leaf_sizes[l]);
                /* Origins on a lattice 4x finer than the grid (vertices, edges, interiors). */
                const uint32_t m = 4 * n;
                const size_t count = (size_t)(m - 1) * (m - 1);
                aacbvh_ray *rays = malloc(count * sizeof *rays);
                aacbvh_hit *hits = malloc(count * sizeof *hits);
                uint8_t *occ = malloc(count);
                assert_non_null(rays);
                assert_non_null(hits);
                assert_non_null(occ);
                size_t k = 0;
                for (uint32_t i = 1; i < m; ++i)
                    for (uint32_t j = 1; j < m; ++j, ++k) {
                        aacbvh_ray *ray = &rays[k];
                        const int down = (int)((i + j) & 1);
                        ray->org[0] = (float)i / (float)m;
                        ray->org[1] = (float)j / (float)m;
                        ray->org[2] = down ? 2.0f : -1.0f;
                        ray->dir[0] = rng_signed_zero(&r);
                        ray->dir[1] = rng_signed_zero(&r);
                        ray->dir[2] = down ? -1.0f : 1.0f;
                        if (k % 3 == 0) ray->dir[2] *= 3.0f;
                        ray->tmin = 0.0f;
                        ray->tmax = INFINITY;
                    }
                assert_int_equal(aacbvh_bvh_intersect(bvh, rays, hits, count), AACBVH_OK);
                assert_int_equal(aacbvh_bvh_occluded(bvh, rays, occ, count), AACBVH_OK);
                for (k = 0; k < count; ++k) {
                    if (hits[k].prim_id == AACBVH_INVALID_ID || !occ[k])
                        fail_msg("grid %d, ray %zu at (%g, %g) leaked through", g, k, rays[k].org[0],
                                 rays[k].org[1]);
                    const double z = tilt[g][0] + tilt[g][1] * rays[k].org[0] + tilt[g][2] * rays[k].org[1];
                    const double t = (z - rays[k].org[2]) / rays[k].dir[2];
                    assert_true(fabs(hits[k].t - t) <= 1e-5 * fabs(t));
                }
                free(occ);
                free(hits);
                free(rays);
                aacbvh_bvh_destroy(bvh);
            }
        scene_free(&s);
    }
}

/* u weighs vertex 1 and v vertex 2; hits exactly at tmin or tmax count. */
static void test_barycentrics_and_bounds(void **state) {
    (void)state;
    /* vertex 3 is never referenced */
    const float verts[4 * 3] = {0, 0, 2, 1, 0, 2, 0, 1, 2, 9, 9, 9};
    const uint32_t idx[3] = {0, 1, 2};
    aacbvh_bvh *bvh = NULL;
    assert_int_equal(aacbvh_bvh_create(g_context, &bvh), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_set_triangles(bvh, verts, 4, 12, idx, 1), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_build(bvh), AACBVH_OK);

    aacbvh_ray rays[6];
    for (int i = 0; i < 6; ++i) {
        const aacbvh_ray ray = {{0.25f, 0.5f, 0.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, INFINITY};
        rays[i] = ray;
    }
    rays[1].tmax = 2.0f;
    rays[2].tmax = nextafterf(2.0f, 0.0f);
    rays[3].tmin = 2.0f;
    rays[4].tmin = nextafterf(2.0f, 3.0f);
    /* from the other side, reversed winding: two-sided */
    rays[5].org[2] = 4.0f;
    rays[5].dir[2] = -0.5f;
    aacbvh_hit hits[6];
    uint8_t occ[6];
    assert_int_equal(aacbvh_bvh_intersect(bvh, rays, hits, 6), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_occluded(bvh, rays, occ, 6), AACBVH_OK);
    const int expect_hit[6] = {1, 1, 0, 1, 0, 1};
    for (int i = 0; i < 6; ++i) {
        assert_int_equal(occ[i], expect_hit[i]);
        if (!expect_hit[i]) {
            assert_int_equal(hits[i].prim_id, AACBVH_INVALID_ID);
            continue;
        }
        assert_int_equal(hits[i].prim_id, 0);
        assert_true(hits[i].t == (i == 5 ? 4.0f : 2.0f));
        assert_true(fabsf(hits[i].u - 0.25f) < 1e-6f);
        assert_true(fabsf(hits[i].v - 0.5f) < 1e-6f);
    }
    aacbvh_bvh_destroy(bvh);
}

/* Box hits: entry distance, clamped to tmin when the origin is inside; the
 * box is closed. */
static void test_box_entry_distance(void **state) {
    (void)state;
    const float boxes[2 * 6] = {0, 0, 0, 1, 1, 1, 0.25f, 0.25f, 3, 0.75f, 0.75f, 3};
    aacbvh_bvh *bvh = NULL;
    assert_int_equal(aacbvh_bvh_create(g_context, &bvh), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_set_boxes(bvh, boxes, 2, 24), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_build(bvh), AACBVH_OK);
    enum { N = 7 };
    aacbvh_ray rays[N];
    for (int i = 0; i < N; ++i) {
        const aacbvh_ray ray = {{0.5f, 0.5f, -1.0f}, 0.0f, {-0.0f, 0.0f, 1.0f}, INFINITY};
        rays[i] = ray;
    }
    rays[1].tmin = 1.5f;                    /* inside the first box: t = tmin */
    rays[2].tmax = nextafterf(1.0f, 0.0f);  /* stops short */
    rays[3].tmin = 2.0f;                    /* exactly at the exit face: closed box */
    rays[4].tmin = 2.5f;                    /* past the first box: the flat one at z = 3 */
    rays[5].org[0] = 1.0f;                  /* along the face x = 1 with dir x = -0 */
    rays[6].tmin = nextafterf(4.0f, 5.0f);  /* past everything */
    const float expect_t[N] = {1.0f, 1.5f, INFINITY, 2.0f, 4.0f, 1.0f, INFINITY};
    const uint32_t expect_id[N] = {0, 0, AACBVH_INVALID_ID, 0, 1, 0, AACBVH_INVALID_ID};
    aacbvh_hit hits[N];
    uint8_t occ[N];
    assert_int_equal(aacbvh_bvh_intersect(bvh, rays, hits, N), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_occluded(bvh, rays, occ, N), AACBVH_OK);
    for (int i = 0; i < N; ++i) {
        if (hits[i].prim_id != expect_id[i] || hits[i].t != expect_t[i])
            fail_msg("box ray %d: got prim %u t %.9g, expected %u t %.9g", i, hits[i].prim_id, hits[i].t,
                     expect_id[i], expect_t[i]);
        assert_true(hits[i].u == 0.0f && hits[i].v == 0.0f);
        assert_int_equal(occ[i], expect_id[i] != AACBVH_INVALID_ID);
    }
    aacbvh_bvh_destroy(bvh);
}

static void expect_miss(const aacbvh_hit *hit) {
    assert_true(isinf(hit->t) && hit->t > 0);
    assert_true(hit->u == 0.0f && hit->v == 0.0f);
    assert_int_equal(hit->prim_id, AACBVH_INVALID_ID);
}

static void test_empty_scene(void **state) {
    (void)state;
    for (int boxes = 0; boxes < 2; ++boxes) {
        aacbvh_bvh *bvh = NULL;
        assert_int_equal(aacbvh_bvh_create(g_context, &bvh), AACBVH_OK);
        if (boxes)
            assert_int_equal(aacbvh_bvh_set_boxes(bvh, NULL, 0, 24), AACBVH_OK);
        else
            assert_int_equal(aacbvh_bvh_set_triangles(bvh, NULL, 0, 12, NULL, 0), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_build(bvh), AACBVH_OK);
        const size_t count = 200;
        aacbvh_ray *rays = make_rays(count, 5 + boxes);
        aacbvh_hit hits[200];
        uint8_t occ[200];
        memset(occ, 7, sizeof occ);
        assert_int_equal(aacbvh_bvh_intersect(bvh, rays, hits, count), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_occluded(bvh, rays, occ, count), AACBVH_OK);
        for (size_t i = 0; i < count; ++i) {
            expect_miss(&hits[i]);
            assert_int_equal(occ[i], 0);
        }
        /* zero rays is fine, even with NULL buffers */
        assert_int_equal(aacbvh_bvh_intersect(bvh, NULL, NULL, 0), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_occluded(bvh, NULL, NULL, 0), AACBVH_OK);
        free(rays);
        aacbvh_bvh_destroy(bvh);
    }
}

/* Rays with NaN fields, infinite origins or directions, or a zero direction
 * miss; the valid rays of the same batch get exactly the answers they get alone. */
static void test_invalid_rays_miss(void **state) {
    (void)state;
    for (int boxes = 0; boxes < 2; ++boxes) {
        scene s = boxes ? make_boxes(500, 8) : make_soup(500, 8);
        aacbvh_bvh *bvh = build_scene(&s, AACBVH_BUILDER_AAC_HQ, 4);
        enum { N = 300 };
        aacbvh_ray *rays = make_rays(N, 21);
        aacbvh_ray valid[N];
        aacbvh_hit hits[N], alone[N];
        uint8_t occ[N], occ_alone[N];
        int bad[N];
        size_t nvalid = 0;
        for (size_t i = 0; i < N; ++i) {
            bad[i] = (i % 3 == 1);
            if (bad[i]) {
                switch ((i / 3) % 9) {
                case 0: rays[i].org[i % 3] = NAN; break;
                case 1: rays[i].dir[i % 3] = NAN; break;
                case 2: rays[i].tmin = NAN; break;
                case 3: rays[i].tmax = NAN; break;
                case 4: rays[i].org[i % 3] = INFINITY; break;
                case 5: rays[i].org[i % 3] = -INFINITY; break;
                case 6: rays[i].dir[i % 3] = -INFINITY; break;
                case 7: rays[i].dir[0] = 0.0f; rays[i].dir[1] = -0.0f; rays[i].dir[2] = 0.0f; break;
                default: rays[i].dir[0] = -0.0f; rays[i].dir[1] = -0.0f; rays[i].dir[2] = -0.0f; break;
                }
            } else {
                valid[nvalid++] = rays[i];
            }
        }
        assert_int_equal(aacbvh_bvh_intersect(bvh, rays, hits, N), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_occluded(bvh, rays, occ, N), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_intersect(bvh, valid, alone, nvalid), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_occluded(bvh, valid, occ_alone, nvalid), AACBVH_OK);
        size_t v = 0, hit_count = 0;
        for (size_t i = 0; i < N; ++i) {
            if (bad[i]) {
                expect_miss(&hits[i]);
                assert_int_equal(occ[i], 0);
                continue;
            }
            assert_memory_equal(&hits[i], &alone[v], sizeof hits[i]);
            assert_int_equal(occ[i], occ_alone[v]);
            hit_count += hits[i].prim_id != AACBVH_INVALID_ID;
            ++v;
        }
        assert_true(hit_count > 0);
        /* Infinite tmin/tmax are valid: [0, inf) and (-inf, inf) windows. */
        aacbvh_ray wide = valid[0];
        wide.tmin = -INFINITY;
        aacbvh_hit h;
        assert_int_equal(aacbvh_bvh_intersect(bvh, &wide, &h, 1), AACBVH_OK);
        free(rays);
        aacbvh_bvh_destroy(bvh);
        scene_free(&s);
    }
}

/* A query before any build is an error, not a crash. */
static void test_intersect_before_build(void **state) {
    (void)state;
    aacbvh_bvh *bvh = NULL;
    assert_int_equal(aacbvh_bvh_create(g_context, &bvh), AACBVH_OK);
    aacbvh_ray ray = {{0, 0, 0}, 0, {1, 0, 0}, INFINITY};
    aacbvh_hit hit;
    uint8_t occ;
    assert_int_equal(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_ERROR_INVALID_OPERATION);
    assert_int_equal(aacbvh_bvh_occluded(bvh, &ray, &occ, 1), AACBVH_ERROR_INVALID_OPERATION);
    assert_int_equal(aacbvh_bvh_intersect(NULL, &ray, &hit, 1), AACBVH_ERROR_INVALID_ARGUMENT);
    aacbvh_bvh_destroy(bvh);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_barycentrics_and_bounds),
        cmocka_unit_test(test_box_entry_distance),
        cmocka_unit_test(test_empty_scene),
        cmocka_unit_test(test_invalid_rays_miss),
        cmocka_unit_test(test_intersect_before_build),
        cmocka_unit_test(test_watertight_grid),
        cmocka_unit_test(test_soup_matches_brute_force),
        cmocka_unit_test(test_grid_matches_brute_force),
        cmocka_unit_test(test_boxes_match_brute_force),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
