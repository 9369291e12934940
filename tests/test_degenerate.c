/*
 * Degenerate geometry with every builder: zero-area triangles, collinear
 * vertices, all triangles identical, all centroids equal (one Morton code),
 * coordinates from 1e-30 to 1e30, one and two primitives, zero primitives,
 * flat scenes, long thin slivers. Each scene must build, pass the tree
 * invariants (ts_check_tree) and give the closest hits of a double-precision
 * brute force (tests/ray_reference.h).
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

static const aacbvh_builder k_builders[] = {
    AACBVH_BUILDER_AAC_HQ,     AACBVH_BUILDER_AAC_FAST,        AACBVH_BUILDER_AAC,  AACBVH_BUILDER_SWEEP_SAH,
    AACBVH_BUILDER_BINNED_SAH, AACBVH_BUILDER_LOCALLY_ORDERED, AACBVH_BUILDER_PLOC,
};
enum { BUILDER_COUNT = sizeof k_builders / sizeof k_builders[0] };

/* Triangles at scales 10^e, e in [-30, 30], each centred at scale * c with
 * c in [-1, 1]^3: the scene spans 1e-30 to 1e30. */
static void make_full_range(size_t n, ts_mesh *m) {
    ts_rng rng;
    ts_rng_seed(&rng, 123);
    m->vertex_count = 3 * n;
    m->triangle_count = n;
    m->vertices = malloc(9 * n * sizeof(float));
    m->indices = malloc(3 * n * sizeof(uint32_t));
    assert_non_null(m->vertices);
    assert_non_null(m->indices);
    for (size_t i = 0; i < n; ++i) {
        const float scale = powf(10.0f, (float)((int)(i % 61) - 30));
        float c[3];
        for (int k = 0; k < 3; ++k) c[k] = ts_rng_range(&rng, -1.0f, 1.0f);
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k)
                m->vertices[9 * i + 3 * j + k] = scale * (c[k] + ts_rng_range(&rng, -0.2f, 0.2f));
        for (int j = 0; j < 3; ++j) m->indices[3 * i + j] = (uint32_t)(3 * i + j);
    }
}

/* Rays aimed at random points of random triangles from a point at the
 * triangle's own scale (so every decade gets rays), some from the origin. */
static aacbvh_ray *aimed_rays(const ts_mesh *m, size_t count, uint64_t seed) {
    aacbvh_ray *rays = malloc(count * sizeof *rays);
    assert_non_null(rays);
    ts_rng rng;
    ts_rng_seed(&rng, seed);
    for (size_t i = 0; i < count; ++i) {
        aacbvh_ray *r = &rays[i];
        const size_t tri = ts_rng_below(&rng, (uint32_t)m->triangle_count);
        const float *v[3];
        double extent = 0.0;
        for (int j = 0; j < 3; ++j) v[j] = m->vertices + 3 * (size_t)m->indices[3 * tri + j];
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) extent = fmax(extent, fabs((double)v[j][k]));
        if (extent == 0.0) extent = 1.0;
        float u = ts_rng_float(&rng), w = ts_rng_float(&rng);
        if (u + w > 1.0f) { u = 1.0f - u; w = 1.0f - w; }
        for (int k = 0; k < 3; ++k) {
            const float target = (1.0f - u - w) * v[0][k] + u * v[1][k] + w * v[2][k];
            r->org[k] = (i % 5 == 0) ? 0.0f : (float)(extent * ts_rng_range(&rng, -3.0f, 3.0f));
            r->dir[k] = target - r->org[k];
        }
        if (r->dir[0] == 0.0f && r->dir[1] == 0.0f && r->dir[2] == 0.0f) r->dir[2] = 1.0f;
        r->tmin = 0.0f;
        r->tmax = INFINITY;
    }
    return rays;
}

static void check_scene(const char *name, const ts_mesh *m, size_t ray_count) {
    float *boxes = m->triangle_count ? ts_mesh_boxes(m) : NULL;
    aacbvh_ray *rays = m->triangle_count ? aimed_rays(m, ray_count, 11) : NULL;
    aacbvh_hit *hits = malloc((ray_count ? ray_count : 1) * sizeof *hits);
    uint8_t *occ = malloc(ray_count ? ray_count : 1);
    const rr_scene scene = rr_triangles(m->vertices, 3, m->indices, m->triangle_count);
    assert_non_null(hits);
    assert_non_null(occ);
    if (!rays) {
        /* Empty scene: rays of every kind, all must miss. */
        rays = malloc(ray_count * sizeof *rays);
        assert_non_null(rays);
        for (size_t i = 0; i < ray_count; ++i) {
            aacbvh_ray r = {{0.0f, 0.0f, 0.0f}, 0.0f, {1.0f, (float)i, -1.0f}, INFINITY};
            rays[i] = r;
        }
    }
    for (size_t b = 0; b < BUILDER_COUNT; ++b)
        for (int leaf = 1; leaf <= 4; leaf += 3) {
            aacbvh_context *ctx;
            aacbvh_bvh *bvh;
            char msg[256];
            /* Under ThreadSanitizer one leaf size per builder, in turn (every
             * builder and both sizes still run): these scenes are below the
             * builds' task grains, only the queries run in tasks there. */
            if (TS_UNDER_TSAN && leaf != (b % 2 ? 4 : 1)) continue;
            ts_create(2, &ctx, &bvh);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, k_builders[b]), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, leaf), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, m->vertices, m->vertex_count, 12, m->indices,
                                                      m->triangle_count),
                             AACBVH_OK);
            if (aacbvh_bvh_build(bvh) != AACBVH_OK)
                fail_msg("%s, builder %d: build failed: %s", name, (int)k_builders[b], aacbvh_bvh_last_error(bvh));
            if (!ts_check_tree(bvh, boxes, m->triangle_count, NULL, (uint32_t)leaf, msg, sizeof msg))
                fail_msg("%s, builder %d, leaf %d: %s", name, (int)k_builders[b], leaf, msg);
            TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, rays, hits, ray_count), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, rays, occ, ray_count), AACBVH_OK);
            for (size_t i = 0; i < ray_count; ++i) {
                if (!rr_check_hit(&scene, &rays[i], &hits[i], occ[i], msg, sizeof msg, NULL))
                    fail_msg("%s, builder %d, leaf %d, ray %zu: %s", name, (int)k_builders[b], leaf, i, msg);
            }
            aacbvh_bvh_destroy(bvh);
            aacbvh_context_destroy(ctx);
        }
    free(boxes);
    free(rays);
    free(hits);
    free(occ);
}

static void run_kind(ts_scene_kind kind, size_t n) {
    ts_mesh m;
    assert_true(ts_make_scene(kind, n, 42, &m));
    check_scene(ts_scene_name(kind), &m, 600);
    ts_mesh_free(&m);
}

static void test_zero_area(void **state) { (void)state; run_kind(TS_SCENE_ZERO_AREA, 400); }
static void test_identical(void **state) { (void)state; run_kind(TS_SCENE_IDENTICAL, 300); }
static void test_same_centroid(void **state) { (void)state; run_kind(TS_SCENE_SAME_CENTROID, 400); }
static void test_flat(void **state) { (void)state; run_kind(TS_SCENE_FLAT, 400); }
static void test_slivers(void **state) { (void)state; run_kind(TS_SCENE_SLIVERS, 400); }
static void test_wide_range(void **state) { (void)state; run_kind(TS_SCENE_WIDE_RANGE, 400); }

static void test_full_float_range(void **state) {
    (void)state;
    ts_mesh m;
    memset(&m, 0, sizeof m);
    make_full_range(366, &m);
    check_scene("1e-30 to 1e30", &m, 1200);
    ts_mesh_free(&m);
}

/* Three triangles whose unions' surface areas overflow float (4e60): the
 * clustering builders once lost every nearest neighbour to infinite
 * distances. Then the same at +-3e38, where even a scene extent overflows. */
static void test_overflowing_areas(void **state) {
    (void)state;
    float v[27] = {1e30f, 1e30f, 1e30f, 2e30f, 1e30f, 1e30f, 1e30f, 2e30f, 1e30f,
                   -1e30f, -1e30f, -1e30f, -2e30f, -1e30f, -1e30f, -1e30f, -2e30f, -1e30f,
                   0, 0, 0, 1, 0, 0, 0, 1, 0};
    ts_mesh m = {v, 9, NULL, 3};
    uint32_t idx[9];
    for (uint32_t i = 0; i < 9; ++i) idx[i] = i;
    m.indices = idx;
    check_scene("areas above FLT_MAX", &m, 300);

    for (int i = 0; i < 18; ++i) v[i] = v[i] < 0.0f ? -3e38f : 3e38f;
    v[3] = 3.4e38f;
    v[7] = 3.4e38f;
    v[12] = -3.4e38f;
    v[16] = -3.4e38f;
    float *boxes = ts_mesh_boxes(&m);
    for (size_t b = 0; b < BUILDER_COUNT; ++b) {
        aacbvh_context *ctx;
        aacbvh_bvh *bvh;
        char msg[256];
        ts_create(1, &ctx, &bvh);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, k_builders[b]), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 1), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 9, 12, idx, 3), AACBVH_OK);
        if (aacbvh_bvh_build(bvh) != AACBVH_OK)
            fail_msg("+-3e38, builder %d: build failed: %s", (int)k_builders[b], aacbvh_bvh_last_error(bvh));
        if (!ts_check_tree(bvh, boxes, 3, NULL, 1, msg, sizeof msg))
            fail_msg("+-3e38, builder %d: %s", (int)k_builders[b], msg);
        aacbvh_bvh_destroy(bvh);
        aacbvh_context_destroy(ctx);
    }
    free(boxes);
}

/* Exactly collinear vertices with non-dyadic spacing, mixed with real triangles. */
static void test_collinear_mixed(void **state) {
    (void)state;
    ts_mesh zero, real, m;
    assert_true(ts_make_scene(TS_SCENE_ZERO_AREA, 200, 3, &zero));
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 200, 4, &real));
    m.vertex_count = zero.vertex_count + real.vertex_count;
    m.triangle_count = zero.triangle_count + real.triangle_count;
    m.vertices = malloc(3 * m.vertex_count * sizeof(float));
    m.indices = malloc(3 * m.triangle_count * sizeof(uint32_t));
    assert_non_null(m.vertices);
    assert_non_null(m.indices);
    memcpy(m.vertices, zero.vertices, 3 * zero.vertex_count * sizeof(float));
    memcpy(m.vertices + 3 * zero.vertex_count, real.vertices, 3 * real.vertex_count * sizeof(float));
    for (size_t i = 0; i < 3 * zero.triangle_count; ++i) m.indices[i] = zero.indices[i];
    for (size_t i = 0; i < 3 * real.triangle_count; ++i)
        m.indices[3 * zero.triangle_count + i] = real.indices[i] + (uint32_t)zero.vertex_count;
    check_scene("collinear + random", &m, 800);
    ts_mesh_free(&m);
    ts_mesh_free(&zero);
    ts_mesh_free(&real);
}

static void test_one_and_two_primitives(void **state) {
    (void)state;
    for (size_t n = 1; n <= 2; ++n) {
        ts_mesh m;
        assert_true(ts_make_scene(TS_SCENE_RANDOM, n, 8 + n, &m));
        check_scene(n == 1 ? "one triangle" : "two triangles", &m, 400);
        ts_mesh_free(&m);
        assert_true(ts_make_scene(TS_SCENE_IDENTICAL, n, 8, &m));
        check_scene(n == 1 ? "one triangle (identical)" : "two identical triangles", &m, 400);
        ts_mesh_free(&m);
    }
}

static void test_zero_primitives(void **state) {
    (void)state;
    ts_mesh m;
    memset(&m, 0, sizeof m);
    check_scene("empty", &m, 50);
    /* Vertices but no triangles. */
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    m.vertices = (float *)v;
    m.vertex_count = 3;
    check_scene("vertices, no triangles", &m, 50);
}

/* SAH of the subtree under `root`, normalised by its own box's area (the
 * formula of aacbvh_stats: traversal cost 1, intersection cost 1). */
static double subtree_sah(const ts_tree *t, uint32_t root) {
    double sum = 0.0;
    uint32_t stack[128];
    size_t top = 0;
    stack[top++] = root;
    while (top > 0) {
        const aacbvh_node *n = &t->nodes[stack[--top]];
        const double dx = (double)n->upper[0] - n->lower[0], dy = (double)n->upper[1] - n->lower[1],
                     dz = (double)n->upper[2] - n->lower[2];
        const double area = dx * dy + dy * dz + dz * dx;
        if (n->count > 0) {
            sum += area * n->count;
        } else {
            sum += area;
            assert_true(top + 2 <= sizeof stack / sizeof stack[0]);
            stack[top++] = n->first;
            stack[top++] = n->first + 1;
        }
    }
    const aacbvh_node *r = &t->nodes[root];
    const double dx = (double)r->upper[0] - r->lower[0], dy = (double)r->upper[1] - r->lower[1],
                 dz = (double)r->upper[2] - r->lower[2];
    return sum / (dx * dy + dy * dz + dz * dx);
}

/* Builds `count` triangles of `v` with `builder` on `threads` threads and
 * reads the tree back. */
static void build_and_fetch(const float *v, size_t count, aacbvh_builder builder, uint32_t threads, ts_tree *out) {
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(threads, &ctx, &bvh);
    assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_set_triangles(bvh, v, 3 * count, 12, NULL, count), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_build(bvh), AACBVH_OK);
    assert_int_equal(ts_tree_fetch(bvh, out), AACBVH_OK);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
}

/* A cluster of small triangles with one triangle very far away (1e30): the
 * scene's Morton grid puts the whole cluster in one cell and its clustering
 * distances, scaled by the scene's extent, underflow to 0. The AAC
 * presets' trees over the cluster must still be about as good as without
 * the outlier, PLOC's within 3 times: AAC once split such a range in input
 * order and merged across it, and traced such a scene (100 K triangles)
 * about 2,700 times slower than a SAH tree; PLOC kept such a run in input
 * order (SAH 42 times the tree without the outlier). */
static void test_far_outlier(void **state) {
    (void)state;
    enum { N = 6000 };
    ts_rng rng;
    ts_rng_seed(&rng, 77);
    float *v = malloc(9 * (size_t)(N + 1) * sizeof(float));
    assert_non_null(v);
    for (size_t i = 0; i < N; ++i) {
        float c[3];
        for (int k = 0; k < 3; ++k) c[k] = ts_rng_range(&rng, 0.0f, 1.0f);
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) v[9 * i + 3 * j + k] = c[k] + ts_rng_range(&rng, -0.01f, 0.01f);
    }
    const float far[9] = {1e30f, 0, 0, 1e30f, 1, 0, 1e30f, 0, 1};
    memcpy(&v[9 * (size_t)N], far, sizeof far);
    /* The presets and PLOC; the paper's AAC, which merges all of the root's
     * clusters greedily with no split first, still merges the cluster's top
     * clusters at distances that underflow (docs/PERFORMANCE.md, change 146). */
    const aacbvh_builder morton_builders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_PLOC};
    /* PLOC gets the Morton order back but not the distances: they still
     * underflow across the cluster, so its merges there follow the order
     * alone (2.2 times the SAH without the outlier; 0.2 ms against 230 ms
     * for the probe's 1,000 rays, docs/PERFORMANCE.md change 147). */
    const double limit[] = {1.1, 1.1, 3.0};
    for (size_t b = 0; b < sizeof morton_builders / sizeof morton_builders[0]; ++b) {
        double sah[2];
        for (int with_outlier = 0; with_outlier < 2; ++with_outlier) {
            ts_tree t;
            build_and_fetch(v, (size_t)(N + with_outlier), morton_builders[b], 1, &t);
            /* The cluster's subtree: the root without the outlier; with it,
             * the root's child whose box stays near [0, 1]^3. */
            uint32_t root = 0;
            if (with_outlier) {
                assert_true(t.nodes[0].count == 0);
                root = t.nodes[t.nodes[0].first].upper[0] < 10.0f ? t.nodes[0].first : t.nodes[0].first + 1;
                assert_true(t.nodes[root].upper[0] < 10.0f);
            }
            sah[with_outlier] = subtree_sah(&t, root);
            if (with_outlier) {
                /* The same tree on three threads: the cluster's range is
                 * refined inside a task, beside the outlier's. */
                ts_tree t3;
                build_and_fetch(v, (size_t)(N + 1), morton_builders[b], 3, &t3);
                if (!ts_tree_equal(&t, &t3))
                    fail_msg("%s: the far-outlier tree differs on three threads", aacbvh_builder_name(morton_builders[b]));
                ts_tree_free(&t3);
            }
            ts_tree_free(&t);
        }
        if (!(sah[1] <= limit[b] * sah[0]))
            fail_msg("%s: the cluster's SAH is %.2f with a far outlier, %.2f without", aacbvh_builder_name(morton_builders[b]),
                     sah[1], sah[0]);
    }
    free(v);
}

/* Found by the fuzzer: two triangles whose x extent overflows float before
 * any scaling (-2.2e38 .. 2.9e38), so every clustering distance was inf; AAC
 * then paired a cluster with itself and dropped a primitive while reporting
 * success. Every builder must keep each primitive exactly once. */
static void test_extent_beyond_float(void **state) {
    (void)state;
    const float v[21] = {0x0p+0f, 0x1.93e594p+99f, -0x1.cp+0f, -0x1.8p-1f, -0x1.0c1c14p+127f, 0x1.fffffep-126f,
                         0x0p+0f, 0x1.b6p+127f, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (int builder = AACBVH_BUILDER_AAC_HQ; builder <= AACBVH_BUILDER_PLOC; ++builder) {
        aacbvh_context *ctx;
        aacbvh_bvh *bvh;
        ts_create(1, &ctx, &bvh);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 7, 12, NULL, 2), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
        uint32_t p[2] = {9, 9};
        TS_EXPECT_STATUS(aacbvh_bvh_get_primitive_indices(bvh, 0, 2, p), AACBVH_OK);
        if (!((p[0] == 0 && p[1] == 1) || (p[0] == 1 && p[1] == 0)))
            fail_msg("builder %d: primitive indices %u %u, want 0 and 1 once each", builder, p[0], p[1]);
        aacbvh_bvh_destroy(bvh);
        aacbvh_context_destroy(ctx);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_zero_area),
        cmocka_unit_test(test_collinear_mixed),
        cmocka_unit_test(test_identical),
        cmocka_unit_test(test_same_centroid),
        cmocka_unit_test(test_flat),
        cmocka_unit_test(test_slivers),
        cmocka_unit_test(test_wide_range),
        cmocka_unit_test(test_full_float_range),
        cmocka_unit_test(test_overflowing_areas),
        cmocka_unit_test(test_extent_beyond_float),
        cmocka_unit_test(test_far_outlier),
        cmocka_unit_test(test_one_and_two_primitives),
        cmocka_unit_test(test_zero_primitives),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
