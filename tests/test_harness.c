/*
 * The tests' own tools can fail: self-tests of the comparison harness and
 * the scenes in test_support.h, and of the oracle in ray_reference.h, on
 * cases worked by hand.
 *   - ts_answers_equal notices one-bit changes (the sign of a zero, one ulp,
 *     another prim_id) and malformed answers; ts_tree_diff notices a changed
 *     node or primitive slot;
 *   - ts_make_rays makes the rays it promises (axis-parallel with +0 and -0,
 *     origins on the scene's planes, bounded, negative, one-point and empty
 *     windows, invalid rays);
 *   - the coplanar scenes are what they say: exact lattice coordinates, the
 *     planes z = 0, -1, -3, -7, no zero area, duplicates;
 *   - rr_point_in_triangle_2d and rr_box on hand-worked cases.
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

/* One-bit changes of an answer, and malformed answers, are reported. */
static void test_answers_equal_is_strict(void **state) {
    aacbvh_hit hits[2] = {{1.0f, 0.25f, 0.0f, 7u}, {INFINITY, 0.0f, 0.0f, AACBVH_INVALID_ID}};
    aacbvh_hit other[2];
    uint8_t occ[2] = {1, 0}, other_occ[2];
    ts_answers a = {hits, occ, 2}, b = {other, other_occ, 2};
    char msg[768];
    int change;
    (void)state;
    memcpy(other, hits, sizeof hits);
    memcpy(other_occ, occ, sizeof occ);
    assert_true(ts_answers_equal(&a, &b, NULL, msg, sizeof msg));
    for (change = 0; change < 8; ++change) {
        memcpy(other, hits, sizeof hits);
        memcpy(other_occ, occ, sizeof occ);
        switch (change) {
        case 0: other[0].v = -0.0f; break;                        /* the sign of a zero */
        case 1: other[0].t = nextafterf(1.0f, 2.0f); break;       /* one ulp */
        case 2: other[0].u = nextafterf(0.25f, 0.0f); break;
        case 3: other[0].prim_id = 6u; break;                     /* another primitive at the same t */
        case 4: other_occ[0] = 0; break;                          /* occluded disagrees with the hit */
        case 5: other_occ[1] = 2; break;                          /* neither 0 nor 1 */
        case 6: other[1].u = 1.0f; break;                         /* a miss must be (inf, 0, 0) */
        default: b.count = 1; break;
        }
        if (ts_answers_equal(&a, &b, NULL, msg, sizeof msg)) fail_msg("change %d went unnoticed", change);
        if (ts_answers_equal(&b, &a, NULL, msg, sizeof msg)) fail_msg("change %d (swapped) went unnoticed", change);
        b.count = 2;
    }
    /* The message names the ray and shows -0. */
    memcpy(other, hits, sizeof hits);
    other[0].v = -0.0f;
    assert_false(ts_answers_equal(&a, &b, NULL, msg, sizeof msg));
    assert_non_null(strstr(msg, "ray 0"));
    assert_non_null(strstr(msg, "-0x0p+0"));
}

/* A tree of a small scene, and the same tree with one change. */
static void test_tree_diff_is_strict(void **state) {
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_mesh mesh;
    ts_tree a, b;
    char msg[512];
    int change;
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 50, 1, &mesh));
    ts_create(1, &ctx, &bvh);
    ts_set_mesh(bvh, &mesh);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &a), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &b), AACBVH_OK);
    assert_true(ts_tree_diff(&a, &b, msg, sizeof msg));
    assert_true(ts_tree_equal(&a, &b));
    for (change = 0; change < 4; ++change) {
        ts_tree c;
        TS_EXPECT_STATUS(ts_tree_fetch(bvh, &c), AACBVH_OK);
        switch (change) {
        case 0: c.nodes[c.node_count - 1].upper[1] = nextafterf(c.nodes[c.node_count - 1].upper[1], INFINITY); break;
        case 1: c.prims[3] = c.prims[4]; break;
        case 2: c.nodes[0].first ^= 1u; break;
        default: c.node_count -= 1; break;
        }
        if (ts_tree_diff(&a, &c, msg, sizeof msg)) fail_msg("tree change %d went unnoticed", change);
        assert_false(ts_tree_equal(&c, &a));
        if (change == 1) assert_non_null(strstr(msg, "primitive slot 3"));
        if (change == 0) assert_non_null(strstr(msg, "node "));
        if (change == 3) c.node_count += 1;
        ts_tree_free(&c);
    }
    ts_tree_free(&a);
    ts_tree_free(&b);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    ts_mesh_free(&mesh);
}

static int is_plane_coord(const ts_mesh *m, int axis, float x) {
    size_t i;
    for (i = 0; i < m->vertex_count; ++i)
        if (m->vertices[3 * i + (size_t)axis] == x) return 1;
    return 0;
}

/* Counts of what ts_make_rays promises, over 20,000 rays of a grid. */
static void test_make_rays_covers_its_kinds(void **state) {
    enum { N = 20000 };
    ts_mesh m;
    aacbvh_ray *rays, *again;
    size_t i, axis_parallel = 0, neg_zero = 0, pos_zero = 0, on_plane = 0, bounded = 0, negative = 0,
              one_point = 0, empty = 0, minus_inf = 0, invalid = 0, at_vertex = 0;
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_GRID, 200, 3, &m));
    rays = ts_make_rays(m.vertices, 3 * m.vertex_count, N, 9);
    again = ts_make_rays(m.vertices, 3 * m.vertex_count, N, 9);
    assert_non_null(rays);
    assert_non_null(again);
    assert_memory_equal(rays, again, N * sizeof *rays); /* deterministic in the seed */
    for (i = 0; i < N; ++i) {
        const aacbvh_ray *r = &rays[i];
        int k, zeros = 0;
        if (!rr_ray_valid(r)) {
            ++invalid;
            continue;
        }
        for (k = 0; k < 3; ++k) {
            zeros += r->dir[k] == 0.0f;
            neg_zero += r->dir[k] == 0.0f && signbit(r->dir[k]);
            pos_zero += r->dir[k] == 0.0f && !signbit(r->dir[k]);
        }
        axis_parallel += zeros == 2;
        for (k = 0; k < 3; ++k)
            if (r->dir[k] != 0.0f && is_plane_coord(&m, k, r->org[k])) {
                ++on_plane;
                break;
            }
        {
            /* Aimed exactly at a vertex: org + dir is one (to rounding). */
            size_t v;
            for (v = 0; v < m.vertex_count; ++v)
                if (fabsf(r->org[0] + r->dir[0] - m.vertices[3 * v]) <= 1e-6f &&
                    fabsf(r->org[1] + r->dir[1] - m.vertices[3 * v + 1]) <= 1e-6f &&
                    fabsf(r->org[2] + r->dir[2] - m.vertices[3 * v + 2]) <= 1e-6f) {
                    ++at_vertex;
                    break;
                }
        }
        minus_inf += r->tmin == -INFINITY;
        bounded += r->tmax < INFINITY && r->tmax > 0.0f && r->tmin < r->tmax;
        negative += r->tmin < 0.0f && r->tmin > -INFINITY;
        one_point += r->tmin == r->tmax;
        empty += r->tmin > r->tmax;
    }
    if (axis_parallel < N / 5 || neg_zero < N / 10 || pos_zero < N / 10 || on_plane < N / 20 || bounded < N / 10 ||
        negative < N / 20 || one_point < N / 50 || empty < N / 100 || minus_inf < N / 50 || invalid < N / 40 ||
        invalid > N / 10 || at_vertex < N / 4)
        fail_msg("ray kinds: axis-parallel %zu, -0 %zu, +0 %zu, origin on a plane %zu, bounded %zu, negative %zu, "
                 "one point %zu, empty %zu, tmin -inf %zu, invalid %zu, aimed at a vertex %zu",
                 axis_parallel, neg_zero, pos_zero, on_plane, bounded, negative, one_point, empty, minus_inf,
                 invalid, at_vertex);
    free(rays);
    free(again);
    ts_mesh_free(&m);
}

/* The coplanar scenes: exact lattice coordinates on the promised planes,
 * exactly n triangles, none of zero area, and (for the stack) duplicates. */
static void test_coplanar_scenes(void **state) {
    static const size_t sizes[] = {1, 2, 17, 1200};
    size_t s, i, j;
    int kind;
    (void)state;
    for (kind = TS_SCENE_COPLANAR; kind <= TS_SCENE_COPLANAR_STACK; ++kind)
        for (s = 0; s < sizeof sizes / sizeof sizes[0]; ++s) {
            ts_mesh m;
            size_t duplicates = 0, planes_seen[4] = {0, 0, 0, 0};
            assert_true(ts_make_scene((ts_scene_kind)kind, sizes[s], 7, &m));
            assert_int_equal(m.triangle_count, sizes[s]);
            for (i = 0; i < m.vertex_count; ++i) {
                const float *p = m.vertices + 3 * i;
                const float z = p[2];
                assert_true(p[0] * 256.0f == floorf(p[0] * 256.0f) && fabsf(p[0]) <= 1.2f);
                assert_true(p[1] * 256.0f == floorf(p[1] * 256.0f) && fabsf(p[1]) <= 1.2f);
                if (kind == TS_SCENE_COPLANAR) assert_true(z == 0.0f && !signbit(z));
                else assert_true(z == 0.0f || z == -1.0f || z == -3.0f || z == -7.0f);
            }
            for (i = 0; i < m.triangle_count; ++i) {
                const float *v[3];
                double area2;
                for (j = 0; j < 3; ++j) v[j] = m.vertices + 3 * (size_t)m.indices[3 * i + j];
                area2 = ((double)v[1][0] - v[0][0]) * ((double)v[2][1] - v[0][1]) -
                        ((double)v[1][1] - v[0][1]) * ((double)v[2][0] - v[0][0]);
                assert_true(area2 != 0.0);
                assert_true(v[0][2] == v[1][2] && v[1][2] == v[2][2]);
                ++planes_seen[v[0][2] == 0.0f ? 0 : v[0][2] == -1.0f ? 1 : v[0][2] == -3.0f ? 2 : 3];
                if (i > 0) {
                    /* The same three points as the triangle before, in any order. */
                    int same = 1;
                    size_t a;
                    for (a = 0; a < 3 && same; ++a) {
                        int found = 0;
                        for (j = 0; j < 3; ++j)
                            found |= memcmp(v[a], m.vertices + 3 * (size_t)m.indices[3 * (i - 1) + j],
                                            3 * sizeof(float)) == 0;
                        same = found;
                    }
                    duplicates += same;
                }
            }
            if (sizes[s] == 1200) {
                if (kind == TS_SCENE_COPLANAR_STACK) {
                    assert_true(duplicates > 1200 / 8);
                    for (j = 0; j < 4; ++j) assert_true(planes_seen[j] > 1200 / 8);
                } else {
                    assert_int_equal(duplicates, 0);
                }
            }
            ts_mesh_free(&m);
        }
}

/* The oracle's 2D test on a triangle worked by hand. */
static void test_point_in_triangle_oracle(void **state) {
    const float a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0};
    (void)state;
    assert_int_equal(rr_point_in_triangle_2d(0.25, 0.25, a, b, c, 1e-6), RR_HIT);
    assert_int_equal(rr_point_in_triangle_2d(0.25, 0.25, a, c, b, 1e-6), RR_HIT); /* either winding */
    assert_int_equal(rr_point_in_triangle_2d(0.6, 0.6, a, b, c, 1e-6), RR_MISS);
    assert_int_equal(rr_point_in_triangle_2d(0.5, 0.5, a, b, c, 1e-6), RR_EITHER); /* on the hypotenuse */
    assert_int_equal(rr_point_in_triangle_2d(0.5, 5e-7, a, b, c, 1e-6), RR_EITHER);
    assert_int_equal(rr_point_in_triangle_2d(0.5, 2e-6, a, b, c, 1e-6), RR_HIT);
    assert_int_equal(rr_point_in_triangle_2d(0.5, -2e-6, a, b, c, 1e-6), RR_MISS);
    /* Near an edge's line but far from the edge itself: a clear miss. */
    assert_int_equal(rr_point_in_triangle_2d(3.0, 1e-7, a, b, c, 1e-6), RR_MISS);
    assert_int_equal(rr_point_in_triangle_2d(-1e-7, -1e-7, a, b, c, 1e-6), RR_EITHER); /* at a vertex */
    /* Zero area: nothing inside, only the segment is near. */
    assert_int_equal(rr_point_in_triangle_2d(0.25, 0.25, a, b, b, 1e-6), RR_MISS);
    assert_int_equal(rr_point_in_triangle_2d(0.5, 0.0, a, b, b, 1e-6), RR_EITHER);
}

/* The oracle's box test on the unit box, by hand. */
static void test_box_oracle(void **state) {
    const float box[6] = {0, 0, 0, 1, 1, 1};
    aacbvh_ray r = {{0.5f, 0.5f, -1.0f}, 0.0f, {0.0f, -0.0f, 2.0f}, INFINITY};
    rr_prim p;
    (void)state;
    p = rr_box(&r, box);
    assert_int_equal(p.cls, RR_HIT);
    assert_true(fabs(p.t - 0.5) < 1e-12 && p.tol > 0.0 && p.tol < 1e-4);
    r.tmin = 0.75f; /* inside the box: t is tmin */
    p = rr_box(&r, box);
    assert_int_equal(p.cls, RR_HIT);
    assert_true(p.t == 0.75);
    r.tmin = 1.0f; /* exactly at the exit face */
    assert_int_equal(rr_box(&r, box).cls, RR_EITHER);
    r.tmin = 1.5f; /* past it */
    assert_int_equal(rr_box(&r, box).cls, RR_MISS);
    r.tmin = 0.0f;
    r.tmax = 0.25f; /* stops short */
    assert_int_equal(rr_box(&r, box).cls, RR_MISS);
    r.tmax = INFINITY;
    r.org[0] = 1.0f; /* along the face x = 1 */
    assert_int_equal(rr_box(&r, box).cls, RR_EITHER);
    r.org[0] = 1.5f; /* beside the box */
    assert_int_equal(rr_box(&r, box).cls, RR_MISS);
}

/* rr_check on answers made by hand: right ones pass, wrong ones are caught. */
static void test_check_by_hand(void **state) {
    /* Two triangles in the planes z = 1 and z = 2 over the unit square. */
    const float v[18] = {0, 0, 1, 1, 0, 1, 0, 1, 1, 0, 0, 2, 1, 0, 2, 0, 1, 2};
    const rr_scene s = rr_triangles(v, 3, NULL, 2);
    const aacbvh_ray r = {{0.25f, 0.25f, 0.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, INFINITY};
    const aacbvh_ray bad = {{0.25f, 0.25f, 0.0f}, NAN, {0.0f, 0.0f, 1.0f}, INFINITY};
    aacbvh_hit h = {1.0f, 0.25f, 0.25f, 0};
    const aacbvh_hit miss = {INFINITY, 0.0f, 0.0f, AACBVH_INVALID_ID};
    char msg[320];
    (void)state;
    assert_true(rr_check_hit(&s, &r, &h, 1, msg, sizeof msg, NULL));
    assert_true(rr_check_hit(&s, &bad, &miss, 0, msg, sizeof msg, NULL));
    assert_false(rr_check_hit(&s, &r, &h, 0, msg, sizeof msg, NULL));    /* occluded disagrees */
    assert_false(rr_check_hit(&s, &r, &miss, 0, msg, sizeof msg, NULL)); /* a miss where a hit is certain */
    assert_false(rr_check_hit(&s, &bad, &h, 1, msg, sizeof msg, NULL));  /* an invalid ray hit */
    h.prim_id = 1;                                                       /* the farther triangle */
    assert_false(rr_check_hit(&s, &r, &h, 1, msg, sizeof msg, NULL));
    h.t = 2.0f;
    assert_false(rr_check_hit(&s, &r, &h, 1, msg, sizeof msg, NULL));
    h.prim_id = 0;
    h.t = 1.001f; /* off by more than the tolerance */
    assert_false(rr_check_hit(&s, &r, &h, 1, msg, sizeof msg, NULL));
    h.t = 1.0f;
    h.u = 0.5f; /* the barycentrics put the point elsewhere */
    assert_false(rr_check_hit(&s, &r, &h, 1, msg, sizeof msg, NULL));
    assert_non_null(strstr(msg, "u, v"));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_answers_equal_is_strict),
        cmocka_unit_test(test_tree_diff_is_strict),
        cmocka_unit_test(test_make_rays_covers_its_kinds),
        cmocka_unit_test(test_coplanar_scenes),
        cmocka_unit_test(test_point_in_triangle_oracle),
        cmocka_unit_test(test_box_oracle),
        cmocka_unit_test(test_check_by_hand),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
