/*
 * The tie rule of closest hits, through the public API: of hits at exactly
 * the same t the one with the smaller prim_id wins, so every variant answers
 * bit for bit like the default (t, u, v, prim_id and occluded identical).
 *
 * - Coplanar stacks (TS_SCENE_COPLANAR: 1,200 overlapping triangles in one
 *   plane; TS_SCENE_COPLANAR_STACK: four parallel planes with duplicated,
 *   rotated and reversed triangles), where most rays meet several triangles
 *   at one t: binary vs wide4, referenced vs copied, 1 vs 2 vs 3 threads,
 *   other builders and leaf sizes, and the same BVH asked the rays in
 *   another order, all compared with the default (ts_compare_answers).
 * - The rule itself against an independent oracle: rays from z = 1 along -z
 *   meet the planes z = 0, -1, -3, -7 at t = 1, 2, 4, 8 exactly (also with
 *   |dir| = 1/2 and 2), so every triangle a ray crosses on the nearest plane
 *   ties; the expected prim_id is the smallest index among them, found by a
 *   2D point-in-triangle test in double (rr_point_in_triangle_2d), skipping
 *   rays within 1e-6 of any edge. Checked in every layout, storage and
 *   thread count.
 * - What the rule relies on: a hit's t does not depend on the window it is
 *   found in, so the same ray asked again with tmax = t, or with the window
 *   [t, t], gets the same answer.
 * - The comparison can fail: the same scene with its triangles in reverse
 *   order answers the tied rays with the other end of the tie, and
 *   ts_answers_equal reports that (test_harness.c checks it further).
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

/* Under ThreadSanitizer TS_RAYS(4000) = 1100 rays of each kind (3,300 in the
 * mixed batches), still more than a query task's grain of 1,024. */
enum { kTriangles = 1200, kRays = TS_RAYS(4000) };

static aacbvh_context *g_ctx[4]; /* g_ctx[n]: n threads */

static int setup_group(void **state) {
    uint32_t n;
    (void)state;
    for (n = 1; n <= 3; ++n)
        if (aacbvh_context_create(n, &g_ctx[n]) != AACBVH_OK) return -1;
    return 0;
}

static int teardown_group(void **state) {
    uint32_t n;
    (void)state;
    for (n = 1; n <= 3; ++n) aacbvh_context_destroy(g_ctx[n]);
    return 0;
}

/* One way to build and query a BVH. */
typedef struct variant {
    const char *name;
    aacbvh_layout layout;
    aacbvh_triangle_storage storage;
    uint32_t threads;
    aacbvh_builder builder;
    uint32_t leaf;
} variant;

/* The default: what every other variant must answer like. */
static const variant k_default = {"binary", AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED, 1,
                                  AACBVH_BUILDER_AAC_HQ, 4};

static const variant k_variants[] = {
    {"wide4", AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_REFERENCED, 1, AACBVH_BUILDER_AAC_HQ, 4},
    {"copied", AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_COPIED, 1, AACBVH_BUILDER_AAC_HQ, 4},
    {"wide4 copied", AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_COPIED, 1, AACBVH_BUILDER_AAC_HQ, 4},
    {"2 threads", AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED, 2, AACBVH_BUILDER_AAC_HQ, 4},
    {"3 threads", AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED, 3, AACBVH_BUILDER_AAC_HQ, 4},
    {"wide4 copied 3 threads", AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_COPIED, 3, AACBVH_BUILDER_AAC_HQ, 4},
    {"leaf 1", AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED, 1, AACBVH_BUILDER_AAC_HQ, 1},
    {"aac-fast wide4 leaf 1", AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_REFERENCED, 2, AACBVH_BUILDER_AAC_FAST, 1},
    {"binned-sah leaf 8", AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_COPIED, 3, AACBVH_BUILDER_BINNED_SAH, 8},
    {"ploc wide4 leaf 2", AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_REFERENCED, 1, AACBVH_BUILDER_PLOC, 2},
    {"wide8", AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_REFERENCED, 1, AACBVH_BUILDER_AAC_HQ, 4},
    {"wide8 copied", AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_COPIED, 1, AACBVH_BUILDER_AAC_HQ, 4},
    {"wide8 copied 3 threads", AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_COPIED, 3, AACBVH_BUILDER_AAC_HQ, 4},
    {"aac-fast wide8 copied leaf 1", AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_COPIED, 2, AACBVH_BUILDER_AAC_FAST, 1},
    {"binned-sah wide8 copied leaf 8", AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_COPIED, 1, AACBVH_BUILDER_BINNED_SAH, 8},
};
enum { VARIANT_COUNT = sizeof k_variants / sizeof k_variants[0] };

static aacbvh_bvh *build_variant(const variant *v, const ts_mesh *mesh) {
    aacbvh_bvh *bvh;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx[v->threads], &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, v->layout), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, v->storage), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, v->builder), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, v->leaf), AACBVH_OK);
    ts_set_mesh(bvh, mesh);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    return bvh;
}

static float signed_zero(ts_rng *rng) { return (ts_rng_next(rng) & 1) ? 0.0f : -0.0f; }

/* Rays from z = 1 straight down (dir z = -1, -1/2 or -2, x and y +0 or -0),
 * so that a ray meets the planes z = 1 - 2^k at exact powers of two. With
 * on_lattice, the origins lie on the scene's lattice (multiples of 1/256,
 * or halfway between): through vertices and along edges. */
static aacbvh_ray *vertical_rays(size_t count, int on_lattice, uint64_t seed) {
    static const float dz[3] = {-1.0f, -0.5f, -2.0f};
    aacbvh_ray *rays = malloc(count * sizeof *rays);
    ts_rng rng;
    size_t i;
    int k;
    assert_non_null(rays);
    ts_rng_seed(&rng, seed);
    for (i = 0; i < count; ++i) {
        aacbvh_ray *r = &rays[i];
        for (k = 0; k < 2; ++k) {
            r->org[k] = on_lattice ? (float)((int)ts_rng_below(&rng, 2 * 600 + 1) - 600) / 512.0f
                                   : ts_rng_range(&rng, -1.2f, 1.2f);
            r->dir[k] = signed_zero(&rng);
        }
        r->org[2] = 1.0f;
        r->dir[2] = dz[ts_rng_below(&rng, 3)];
        r->tmin = 0.0f;
        r->tmax = INFINITY;
    }
    return rays;
}

/* kRays rays of ts_make_rays over the scene, then kRays vertical rays on
 * the lattice and kRays off it: 3 * kRays rays in all. */
static aacbvh_ray *tie_rays(const ts_mesh *mesh, uint64_t seed) {
    aacbvh_ray *rays = ts_make_rays(mesh->vertices, 3 * mesh->vertex_count, 3 * kRays, seed);
    aacbvh_ray *lattice = vertical_rays(kRays, 1, seed + 1), *off = vertical_rays(kRays, 0, seed + 2);
    assert_non_null(rays);
    memcpy(rays + kRays, lattice, kRays * sizeof *rays);
    memcpy(rays + 2 * kRays, off, kRays * sizeof *rays);
    free(lattice);
    free(off);
    return rays;
}

/* ------------------------------------------------------------------ */
/* Every variant answers like the default                              */
/* ------------------------------------------------------------------ */

static void check_variants(ts_scene_kind kind, uint64_t seed) {
    ts_mesh mesh;
    aacbvh_bvh *reference;
    aacbvh_ray *rays;
    char what[160];
    size_t i;
    assert_true(ts_make_scene(kind, kTriangles, seed, &mesh));
    rays = tie_rays(&mesh, seed);
    reference = build_variant(&k_default, &mesh);
    for (i = 0; i < VARIANT_COUNT; ++i) {
        aacbvh_bvh *bvh = build_variant(&k_variants[i], &mesh);
        snprintf(what, sizeof what, "%s scene, %s vs default", ts_scene_name(kind), k_variants[i].name);
        if (ts_compare_answers(reference, bvh, rays, 3 * kRays, what) < kRays)
            fail_msg("%s: too few hits for the comparison to mean much", what);
        if (k_variants[i].threads == 3) {
            snprintf(what, sizeof what, "%s scene, %s", ts_scene_name(kind), k_variants[i].name);
            ts_compare_batch_orders(bvh, rays, 3 * kRays, seed + i, what);
        }
        aacbvh_bvh_destroy(bvh);
    }
    snprintf(what, sizeof what, "%s scene, default", ts_scene_name(kind));
    ts_compare_batch_orders(reference, rays, 3 * kRays, seed + 99, what);
    aacbvh_bvh_destroy(reference);
    free(rays);
    ts_mesh_free(&mesh);
}

/* The scene kind is the test's state (see main). */
static void test_variants(void **state) { check_variants(*(const ts_scene_kind *)*state, 1); }

/* ------------------------------------------------------------------ */
/* The rule against an oracle                                          */
/* ------------------------------------------------------------------ */

/* What a vertical ray must answer: the smallest index among the triangles
 * of the nearest plane containing the ray's (x, y). Returns 0 when the ray
 * passes within 1e-6 of an edge (not judged). */
typedef struct expected {
    uint32_t prim;  /* AACBVH_INVALID_ID: a miss */
    double t;       /* exact distance (a power of two here) */
    size_t tied;    /* triangles hit at that t */
} expected;

static int oracle(const ts_mesh *mesh, const aacbvh_ray *ray, expected *out) {
    size_t i;
    out->prim = AACBVH_INVALID_ID;
    out->t = INFINITY;
    out->tied = 0;
    for (i = 0; i < mesh->triangle_count; ++i) {
        const float *v[3];
        double t;
        int j, cls;
        for (j = 0; j < 3; ++j) v[j] = mesh->vertices + 3 * (size_t)mesh->indices[3 * i + (size_t)j];
        cls = rr_point_in_triangle_2d(ray->org[0], ray->org[1], v[0], v[1], v[2], 1e-6);
        if (cls == RR_EITHER) return 0;
        if (cls == RR_MISS) continue;
        t = ((double)v[0][2] - ray->org[2]) / ray->dir[2];
        if (t < out->t) {
            out->t = t;
            out->prim = (uint32_t)i;
            out->tied = 1;
        } else if (t == out->t) {
            ++out->tied; /* i is larger: the first one found stays */
        }
    }
    return 1;
}

static void check_oracle(ts_scene_kind kind, uint64_t seed) {
    ts_mesh mesh;
    aacbvh_ray *rays;
    expected *want;
    size_t i, v, judged = 0, ties = 0;
    assert_true(ts_make_scene(kind, kTriangles, seed, &mesh));
    rays = vertical_rays(kRays, 0, seed);
    want = malloc(kRays * sizeof *want);
    assert_non_null(want);
    for (i = 0; i < kRays; ++i) {
        if (!oracle(&mesh, &rays[i], &want[i])) {
            want[i].tied = (size_t)-1; /* not judged */
            continue;
        }
        ++judged;
        ties += want[i].tied >= 2;
        /* The setup: every distance is a power of two, exact in float. */
        if (want[i].prim != AACBVH_INVALID_ID) assert_true((double)(float)want[i].t == want[i].t);
    }
    /* Few rays pass near an edge; most cross several triangles at one t. */
    if (judged < kRays * 9 / 10 || ties < judged / 2)
        fail_msg("%s scene: %zu rays judged, %zu of them ties: the scene does not test the rule",
                 ts_scene_name(kind), judged, ties);
    for (v = 0; v <= VARIANT_COUNT; ++v) {
        const variant *var = v == 0 ? &k_default : &k_variants[v - 1];
        aacbvh_bvh *bvh = build_variant(var, &mesh);
        ts_answers got;
        ts_answers_query(bvh, rays, kRays, &got);
        for (i = 0; i < kRays; ++i) {
            const aacbvh_hit *h = &got.hits[i];
            const expected *w = &want[i];
            if (w->tied == (size_t)-1) continue;
            if (h->prim_id != w->prim || got.occluded[i] != (w->prim != AACBVH_INVALID_ID) ||
                (w->prim != AACBVH_INVALID_ID && h->t != (float)w->t))
                fail_msg("%s scene, %s, ray %zu at (%a, %a) dir z %g: prim %u at t = %a (occluded %u), expected "
                         "prim %u at t = %a (%zu tied)",
                         ts_scene_name(kind), var->name, i, (double)rays[i].org[0], (double)rays[i].org[1],
                         (double)rays[i].dir[2], h->prim_id, (double)h->t, got.occluded[i], w->prim, w->t,
                         w->tied);
            if (w->prim != AACBVH_INVALID_ID) {
                /* (1 - u - v) v0 + u v1 + v v2 is the ray's (x, y). */
                const float *p[3];
                int j, k;
                for (j = 0; j < 3; ++j) p[j] = mesh.vertices + 3 * (size_t)mesh.indices[3 * (size_t)w->prim + j];
                for (k = 0; k < 2; ++k) {
                    const double x = (1.0 - h->u - h->v) * p[0][k] + (double)h->u * p[1][k] + (double)h->v * p[2][k];
                    if (fabs(x - rays[i].org[k]) > 1e-5)
                        fail_msg("%s scene, %s, ray %zu: u, v (%g, %g) put the hit %g off on axis %d",
                                 ts_scene_name(kind), var->name, i, (double)h->u, (double)h->v,
                                 x - rays[i].org[k], k);
                }
            }
        }
        ts_answers_free(&got);
        aacbvh_bvh_destroy(bvh);
    }
    free(want);
    free(rays);
    ts_mesh_free(&mesh);
}

static void test_oracle(void **state) { check_oracle(*(const ts_scene_kind *)*state, 3); }

/* ------------------------------------------------------------------ */
/* A hit's t does not depend on the window                             */
/* ------------------------------------------------------------------ */

/* Asks every hit ray again with tmax = t and with tmin = tmax = t: the
 * answers must be the same, bit for bit. */
static void check_windows(const aacbvh_bvh *bvh, const aacbvh_ray *rays, size_t count, const char *what) {
    ts_answers first, again;
    aacbvh_ray *shrunk = malloc(count * sizeof *shrunk);
    char msg[768];
    size_t i, hits = 0;
    int pass;
    assert_non_null(shrunk);
    ts_answers_query(bvh, rays, count, &first);
    for (pass = 0; pass < 2; ++pass) {
        for (i = 0; i < count; ++i) {
            shrunk[i] = rays[i];
            if (first.hits[i].prim_id == AACBVH_INVALID_ID) continue;
            shrunk[i].tmax = first.hits[i].t;
            if (pass == 1) shrunk[i].tmin = first.hits[i].t;
            hits += pass == 0;
        }
        ts_answers_query(bvh, shrunk, count, &again);
        if (!ts_answers_equal(&first, &again, shrunk, msg, sizeof msg))
            fail_msg("%s, window %s: %s", what, pass == 0 ? "[tmin, t]" : "[t, t]", msg);
        ts_answers_free(&again);
    }
    if (hits < count / 10) fail_msg("%s: only %zu of %zu rays hit", what, hits, count);
    ts_answers_free(&first);
    free(shrunk);
}

static void test_window_shrunk_to_the_hit(void **state) {
    static const ts_scene_kind kinds[] = {TS_SCENE_COPLANAR, TS_SCENE_COPLANAR_STACK, TS_SCENE_GRID,
                                          TS_SCENE_RANDOM, TS_SCENE_FLAT};
    size_t s, l;
    (void)state;
    for (s = 0; s < sizeof kinds / sizeof kinds[0]; ++s) {
        ts_mesh mesh;
        aacbvh_ray *rays;
        assert_true(ts_make_scene(kinds[s], kTriangles, 20 + s, &mesh));
        rays = tie_rays(&mesh, 30 + s);
        for (l = 0; l < 3; ++l) {
            variant v = k_default;
            char what[96];
            aacbvh_bvh *bvh;
            v.layout = (aacbvh_layout)l; /* binary, wide4, wide8 */
            bvh = build_variant(&v, &mesh);
            snprintf(what, sizeof what, "%s scene, layout %d", ts_scene_name(kinds[s]), (int)v.layout);
            check_windows(bvh, rays, 3 * kRays, what);
            aacbvh_bvh_destroy(bvh);
        }
        free(rays);
        ts_mesh_free(&mesh);
    }
}

/* ------------------------------------------------------------------ */
/* The comparison catches a tie broken the other way                  */
/* ------------------------------------------------------------------ */

/* The coplanar scene with its triangles in reverse order: a tied ray now
 * gets the tied triangle of the largest original index. Mapped back to
 * the original indices, the answers differ exactly on ties, and there the
 * default's is the smaller index at the same t. */
static void test_reversed_scene_breaks_ties_the_other_way(void **state) {
    ts_mesh mesh, reversed;
    aacbvh_bvh *a, *b;
    aacbvh_ray *rays;
    ts_answers fa, fb;
    char msg[768];
    size_t i, n, differ = 0;
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_COPLANAR, kTriangles, 5, &mesh));
    assert_true(ts_make_scene(TS_SCENE_COPLANAR, kTriangles, 5, &reversed));
    n = mesh.triangle_count;
    for (i = 0; i < n; ++i) memcpy(reversed.indices + 3 * i, mesh.indices + 3 * (n - 1 - i), 3 * sizeof(uint32_t));
    a = build_variant(&k_default, &mesh);
    b = build_variant(&k_default, &reversed);
    rays = vertical_rays(kRays, 0, 6);
    ts_answers_query(a, rays, kRays, &fa);
    ts_answers_query(b, rays, kRays, &fb);
    for (i = 0; i < kRays; ++i) {
        aacbvh_hit *h = &fb.hits[i];
        if (h->prim_id != AACBVH_INVALID_ID) h->prim_id = (uint32_t)(n - 1 - h->prim_id);
        if (h->prim_id == fa.hits[i].prim_id) continue;
        ++differ;
        assert_true(h->t == fa.hits[i].t);
        assert_true(fa.hits[i].prim_id < h->prim_id);
    }
    assert_true(differ > kRays / 4);
    assert_false(ts_answers_equal(&fa, &fb, rays, msg, sizeof msg));
    assert_non_null(strstr(msg, "the answers differ"));
    ts_answers_free(&fa);
    ts_answers_free(&fb);
    free(rays);
    aacbvh_bvh_destroy(a);
    aacbvh_bvh_destroy(b);
    ts_mesh_free(&mesh);
    ts_mesh_free(&reversed);
}

int main(void) {
    static ts_scene_kind coplanar = TS_SCENE_COPLANAR, stack = TS_SCENE_COPLANAR_STACK;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reversed_scene_breaks_ties_the_other_way),
        {"test_oracle_coplanar", test_oracle, NULL, NULL, &coplanar},
        {"test_oracle_coplanar_stack", test_oracle, NULL, NULL, &stack},
        {"test_variants_coplanar", test_variants, NULL, NULL, &coplanar},
        {"test_variants_coplanar_stack", test_variants, NULL, NULL, &stack},
        cmocka_unit_test(test_window_shrunk_to_the_hit),
    };
    return cmocka_run_group_tests(tests, setup_group, teardown_group);
}
