/* Structural invariants of the built tree, for every builder, leaf size and
 * a range of scenes (random, grid, degenerate, boxes, a real mesh), checked
 * through the public API only; stats against a recount; determinism. */
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

typedef struct builder_config {
    const char *name;
    aacbvh_builder builder;
    int64_t delta;  /* 0: the builder's own */
    double c, alpha;
    size_t max_n;   /* largest scene this builder gets here */
} builder_config;

static const builder_config k_builders[] = {
    {"AAC_HQ", AACBVH_BUILDER_AAC_HQ, 0, 0, 0, 20000},
    {"AAC_FAST", AACBVH_BUILDER_AAC_FAST, 0, 0, 0, 20000},
    {"AAC(2, 0.5, 0.2)", AACBVH_BUILDER_AAC, 2, 0.5, 0.2, 20000},
    {"AAC(50, 3, 0.45)", AACBVH_BUILDER_AAC, 50, 3.0, 0.45, 20000},
    {"SWEEP_SAH", AACBVH_BUILDER_SWEEP_SAH, 0, 0, 0, 20000},
    {"BINNED_SAH", AACBVH_BUILDER_BINNED_SAH, 0, 0, 0, 20000},
    {"LOCALLY_ORDERED", AACBVH_BUILDER_LOCALLY_ORDERED, 0, 0, 0, 1000},
    {"PLOC", AACBVH_BUILDER_PLOC, 0, 0, 0, 20000},
};
#define BUILDER_COUNT (sizeof k_builders / sizeof k_builders[0])

static const size_t k_sizes[] = {1, 2, 3, 17, 1000};
static const uint32_t k_leaf_sizes[] = {1, 2, 4, 8};

static aacbvh_context *g_ctx;

static int setup_group(void **state) {
    (void)state;
    return aacbvh_context_create(4, &g_ctx) == AACBVH_OK ? 0 : -1;
}

static int teardown_group(void **state) {
    (void)state;
    aacbvh_context_destroy(g_ctx);
    return 0;
}

static aacbvh_bvh *make_bvh(const builder_config *cfg, uint32_t leaf) {
    aacbvh_bvh *bvh = NULL;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, cfg->builder), AACBVH_OK);
    if (cfg->delta) {
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_AAC_DELTA, cfg->delta), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_C, cfg->c), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_ALPHA, cfg->alpha), AACBVH_OK);
    }
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, leaf), AACBVH_OK);
    return bvh;
}

/* Builds the current geometry and checks the tree; also the memory figure. */
static void build_and_check(aacbvh_bvh *bvh, const float *boxes, size_t n, uint32_t leaf, const char *what) {
    char msg[512];
    aacbvh_stats stats;
    aacbvh_status s = aacbvh_bvh_build(bvh);
    if (s != AACBVH_OK)
        fail_msg("%s: build returned %s (%s)", what, aacbvh_status_string(s), aacbvh_bvh_last_error(bvh));
    if (!ts_check_tree(bvh, boxes, n, NULL, leaf, msg, sizeof msg)) fail_msg("%s: %s", what, msg);
    memset(&stats, 0, sizeof stats);
    stats.struct_size = sizeof stats;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
    /* At least the primitive indices and a byte per node (the default
     * layout keeps the binary tree's shape, not its 32-byte nodes). */
    if (stats.memory_bytes < stats.node_count + stats.primitive_count * sizeof(uint32_t))
        fail_msg("%s: memory_bytes %llu is less than the tree itself", what, (unsigned long long)stats.memory_bytes);
    if (stats.build_peak_bytes < stats.node_count * sizeof(aacbvh_node))
        fail_msg("%s: build_peak_bytes %llu is less than the finished tree", what,
                 (unsigned long long)stats.build_peak_bytes);
    if (!(stats.build_seconds >= 0.0)) fail_msg("%s: build_seconds %g", what, stats.build_seconds);
    if (!(fabs(stats.built_sah_cost - stats.sah_cost) <= 1e-9 * stats.sah_cost))
        fail_msg("%s: built_sah_cost %.17g != sah_cost %.17g right after a build", what, stats.built_sah_cost,
                 stats.sah_cost);
}

/* Sets `data` (n boxes, `stride` bytes apart; `boxes` the same packed) as
 * the geometry, builds and checks; failures name the builder and `label`. */
static void check_boxes(aacbvh_bvh *bvh, const float *data, size_t stride, const float *boxes, size_t n,
                        uint32_t leaf, const char *builder, const char *label) {
    char what[256];
    snprintf(what, sizeof what, "%s, %s, n = %zu, leaf %u", builder, label, n, leaf);
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, data, n, stride), AACBVH_OK);
    build_and_check(bvh, boxes, n, leaf, what);
}

static void check_mesh(aacbvh_bvh *bvh, const ts_mesh *mesh, uint32_t leaf, const char *what) {
    float *boxes = ts_mesh_boxes(mesh);
    assert_non_null(boxes);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh->vertices, mesh->vertex_count, 3 * sizeof(float),
                                              mesh->indices, mesh->triangle_count), AACBVH_OK);
    build_and_check(bvh, boxes, mesh->triangle_count, leaf, what);
    free(boxes);
}

static void run_builder(const builder_config *cfg) {
    size_t li, si, k;
    char what[256];
    for (li = 0; li < sizeof k_leaf_sizes / sizeof k_leaf_sizes[0]; ++li) {
        uint32_t leaf = k_leaf_sizes[li];
        aacbvh_bvh *bvh = make_bvh(cfg, leaf);
        for (k = 0; k < TS_SCENE_KIND_COUNT; ++k)
            for (si = 0; si < sizeof k_sizes / sizeof k_sizes[0]; ++si) {
                ts_mesh mesh;
                size_t n = k_sizes[si];
                if (n > cfg->max_n) continue;
                /* Keep the run short: the big scenes of every kind with the
                 * default leaf size, half of the kinds with the others. */
                if (n >= 1000 && leaf != 4 && (k + li) % 2) continue;
                assert_true(ts_make_scene((ts_scene_kind)k, n, 1000 * k + n, &mesh));
                assert_int_equal(mesh.triangle_count, n);
                snprintf(what, sizeof what, "%s, leaf %u, %s scene, n = %zu", cfg->name, leaf,
                         ts_scene_name((ts_scene_kind)k), n);
                check_mesh(bvh, &mesh, leaf, what);
                ts_mesh_free(&mesh);
            }
        aacbvh_bvh_destroy(bvh);
    }
    /* Large scenes, default leaf size. */
    if (cfg->max_n >= 20000) {
        const ts_scene_kind kinds[] = {TS_SCENE_RANDOM, TS_SCENE_GRID};
        aacbvh_bvh *bvh = make_bvh(cfg, 4);
        /* The grid once for the default builder, random soup for all. */
        for (k = 0; k < (cfg->builder == AACBVH_BUILDER_AAC_HQ ? 2u : 1u); ++k) {
            ts_mesh mesh;
            assert_true(ts_make_scene(kinds[k], 20000, 77 + k, &mesh));
            snprintf(what, sizeof what, "%s, leaf 4, %s scene, n = 20000", cfg->name, ts_scene_name(kinds[k]));
            check_mesh(bvh, &mesh, 4, what);
            ts_mesh_free(&mesh);
        }
        aacbvh_bvh_destroy(bvh);
    }
}

static void test_aac_hq(void **state) { (void)state; run_builder(&k_builders[0]); }
static void test_aac_fast(void **state) { (void)state; run_builder(&k_builders[1]); }
static void test_aac_custom_small(void **state) { (void)state; run_builder(&k_builders[2]); }
static void test_aac_custom_large(void **state) { (void)state; run_builder(&k_builders[3]); }
static void test_sweep_sah(void **state) { (void)state; run_builder(&k_builders[4]); }
static void test_binned_sah(void **state) { (void)state; run_builder(&k_builders[5]); }
static void test_locally_ordered(void **state) { (void)state; run_builder(&k_builders[6]); }
static void test_ploc(void **state) { (void)state; run_builder(&k_builders[7]); }

/* Box primitives, packed and with a stride, for every builder. */
/* Trees deeper and leaves wider than the layout's first stack blocks
 * (64 entries, build/flatten.cpp): boxes at x = 2^(i/8), each farther than
 * the last, which the SAH builders peel off one at a time into a chain, and
 * coincident boxes, which a leaf size of 1000 keeps in one leaf of 400. */
static void test_deep_and_wide(void **state) {
    const size_t n = 400;
    size_t b, i;
    float *chain = malloc(6 * n * sizeof(float));
    float *same = malloc(6 * n * sizeof(float));
    (void)state;
    assert_non_null(chain);
    assert_non_null(same);
    for (i = 0; i < n; ++i) {
        const float x = ldexpf(1.0f, (int)(i / 8)) * (1.0f + (float)(i % 8) / 8.0f);
        const float c[6] = {x, 0.0f, 0.0f, x + 0.5f, 1.0f, 1.0f};
        const float u[6] = {0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f};
        memcpy(chain + 6 * i, c, sizeof c);
        memcpy(same + 6 * i, u, sizeof u);
    }
    for (b = 0; b < BUILDER_COUNT; ++b) {
        aacbvh_bvh *deep = make_bvh(&k_builders[b], 1), *wide = make_bvh(&k_builders[b], 1000);
        check_boxes(deep, chain, 24, chain, n, 1, k_builders[b].name, "a chain of boxes");
        check_boxes(wide, same, 24, same, n, 1000, k_builders[b].name, "coincident boxes");
        aacbvh_bvh_destroy(deep);
        aacbvh_bvh_destroy(wide);
    }
    free(chain);
    free(same);
}

static void test_boxes(void **state) {
    const size_t sizes[] = {1, 2, 17, 1000};
    size_t b, si, i;
    (void)state;
    for (b = 0; b < BUILDER_COUNT; ++b) {
        aacbvh_bvh *bvh = make_bvh(&k_builders[b], 2);
        for (si = 0; si < sizeof sizes / sizeof sizes[0]; ++si) {
            size_t n = sizes[si];
            float *boxes = ts_random_boxes(n, 0.2f, 31 + n);
            float *strided = malloc(8 * n * sizeof(float));
            float *points = malloc(6 * n * sizeof(float));
            assert_non_null(boxes);
            assert_non_null(strided);
            assert_non_null(points);
            for (i = 0; i < n; ++i) {
                memcpy(strided + 8 * i, boxes + 6 * i, 6 * sizeof(float));
                strided[8 * i + 6] = NAN; /* padding is never read */
                strided[8 * i + 7] = NAN;
                /* Points: zero-size boxes, half of them at one spot. */
                memcpy(points + 6 * i, boxes + 6 * i, 3 * sizeof(float));
                if (i % 2) memset(points + 6 * i, 0, 3 * sizeof(float));
                memcpy(points + 6 * i + 3, points + 6 * i, 3 * sizeof(float));
            }
            check_boxes(bvh, boxes, 24, boxes, n, 2, k_builders[b].name, "boxes");
            check_boxes(bvh, strided, 32, boxes, n, 2, k_builders[b].name, "strided boxes");
            check_boxes(bvh, points, 24, points, n, 2, k_builders[b].name, "point boxes");
            free(boxes);
            free(strided);
            free(points);
        }
        aacbvh_bvh_destroy(bvh);
    }
}

/* Vertices with a stride and non-indexed triangles. */
static void test_strided_and_unindexed(void **state) {
    ts_mesh mesh;
    const size_t n = 500;
    float *soup, *strided;
    size_t i, j, b;
    char what[256];
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, n, 4, &mesh));
    soup = malloc(9 * n * sizeof(float));
    strided = malloc(5 * mesh.vertex_count * sizeof(float));
    assert_non_null(soup);
    assert_non_null(strided);
    for (i = 0; i < n; ++i)
        for (j = 0; j < 3; ++j) memcpy(soup + 9 * i + 3 * j, mesh.vertices + 3 * mesh.indices[3 * i + j], 12);
    for (i = 0; i < mesh.vertex_count; ++i) {
        memcpy(strided + 5 * i, mesh.vertices + 3 * i, 12);
        strided[5 * i + 3] = NAN;
        strided[5 * i + 4] = INFINITY;
    }
    for (b = 0; b < BUILDER_COUNT; ++b) {
        aacbvh_bvh *bvh = make_bvh(&k_builders[b], 4);
        float *boxes = ts_mesh_boxes(&mesh);
        snprintf(what, sizeof what, "%s, unindexed", k_builders[b].name);
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, soup, 3 * n, 12, NULL, n), AACBVH_OK);
        build_and_check(bvh, boxes, n, 4, what);
        snprintf(what, sizeof what, "%s, vertex stride 20", k_builders[b].name);
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, strided, mesh.vertex_count, 20, mesh.indices, n),
                         AACBVH_OK);
        build_and_check(bvh, boxes, n, 4, what);
        free(boxes);
        aacbvh_bvh_destroy(bvh);
    }
    free(soup);
    free(strided);
    ts_mesh_free(&mesh);
}

/* A real mesh when available, else a generated stand-in (said out loud). */
static void test_real_mesh(void **state) {
    ts_mesh mesh;
    size_t b;
    char what[256];
    (void)state;
    if (!ts_load_scene("bunny_npm_lowres.obj", &mesh)) {
        print_message("note: scene bunny_npm_lowres.obj not available (AACBVH_SCENES_DIR=%s); "
                      "using a generated 3674-triangle grid instead\n", AACBVH_SCENES_DIR);
        assert_true(ts_make_scene(TS_SCENE_GRID, 3674, 11, &mesh));
    }
    for (b = 0; b < BUILDER_COUNT; ++b) {
        aacbvh_bvh *bvh = make_bvh(&k_builders[b], 4);
        snprintf(what, sizeof what, "%s, mesh of %zu triangles", k_builders[b].name, mesh.triangle_count);
        check_mesh(bvh, &mesh, 4, what);
        aacbvh_bvh_destroy(bvh);
    }
    ts_mesh_free(&mesh);
}

/* The build's peak against its budget. AAC's peak is its recursion
 * (docs/PERFORMANCE.md, rows 175-177): the builders' tree (boxes 48,
 * children 8 and primitive ids 4 bytes a primitive), the flattening choices
 * (costs 4, counts 8, packet choices 5), the common prefix lengths of
 * neighbouring Morton codes (1) and the clusters with their free node ids
 * (8) are alive; nothing else may be (the 8-wide layout's peak, with the
 * tree, the counts and the new nodes alive, lies within 1 B of it). Fails if
 * the recursion kept the codes (8 bytes each: 1.4 MB more here). The binned SAH builder's budget is row 123's: the
 * builders' tree, the counts (8), and a finished binary tree's nodes (32 bytes
 * each) and indices (4 a primitive). 1 MiB covers the small arrays. */
static void test_build_peak_budget(void **state) {
    static const int builders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_BINNED_SAH};
    ts_mesh mesh;
    size_t b;
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_GRID, 200000, 5, &mesh));
    for (b = 0; b < sizeof builders / sizeof builders[0]; ++b) {
        aacbvh_bvh *bvh = NULL;
        aacbvh_stats stats;
        unsigned long long budget;
        TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builders[b]), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 3 * sizeof(float),
                                                  mesh.indices, mesh.triangle_count), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
        memset(&stats, 0, sizeof stats);
        stats.struct_size = sizeof stats;
        TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
        if (builders[b] == AACBVH_BUILDER_BINNED_SAH)
            budget = (unsigned long long)stats.primitive_count * (48 + 8 + 4 + 8 + 4) +
                     (unsigned long long)stats.node_count * 32 + (1ull << 20);
        else
            budget = (unsigned long long)stats.primitive_count * (48 + 8 + 4 + 17 + 1 + 8) + (1ull << 20);
        print_message("builder %d: %zu triangles, %llu nodes, peak %llu bytes, budget %llu\n", builders[b],
                      mesh.triangle_count, (unsigned long long)stats.node_count,
                      (unsigned long long)stats.build_peak_bytes, budget);
        if (stats.build_peak_bytes > budget)
            fail_msg("builder %d: build_peak_bytes %llu over the budget %llu", builders[b],
                     (unsigned long long)stats.build_peak_bytes, budget);
        aacbvh_bvh_destroy(bvh);
    }
    ts_mesh_free(&mesh);
}

static void test_sah_cost_follows_params(void **state) {
    ts_mesh mesh;
    float *boxes;
    aacbvh_bvh *bvh = make_bvh(&k_builders[0], 4);
    ts_tree t;
    aacbvh_stats s1, s2;
    char msg[512];
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 2000, 8, &mesh));
    boxes = ts_mesh_boxes(&mesh);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 12, mesh.indices,
                                              mesh.triangle_count), AACBVH_OK);
    build_and_check(bvh, boxes, mesh.triangle_count, 4, "AAC_HQ, 2000 random triangles");
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &t), AACBVH_OK);
    s1 = t.stats;
    assert_true(fabs(s1.sah_cost - ts_tree_sah_cost(&t, 1.2, 1.0)) <= 1e-6 * s1.sah_cost);

    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, 3.0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_INTERSECTION_COST, 0.5), AACBVH_OK);
    memset(&s2, 0, sizeof s2);
    s2.struct_size = sizeof s2;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &s2), AACBVH_OK);
    if (!(fabs(s2.sah_cost - ts_tree_sah_cost(&t, 3.0, 0.5)) <= 1e-6 * s2.sah_cost))
        fail_msg("after changing the costs, sah_cost %.17g, expected %.17g (was %.17g)", s2.sah_cost,
                 ts_tree_sah_cost(&t, 3.0, 0.5), s1.sah_cost);
    assert_true(s2.sah_cost != s1.sah_cost);
    /* built_sah_cost uses the costs in force too: the drift stays 1. */
    if (s2.built_sah_cost != s2.sah_cost)
        fail_msg("after changing the costs, built_sah_cost %.17g but sah_cost %.17g", s2.built_sah_cost, s2.sah_cost);
    /* A refit of unmoved geometry: drift exactly 1, whatever the costs did. */
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, 1.7), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &s2), AACBVH_OK);
    if (s2.sah_cost / s2.built_sah_cost != 1.0)
        fail_msg("unmoved refit: drift %.17g", s2.sah_cost / s2.built_sah_cost);
    /* The largest costs allowed give finite stats; larger ones are refused. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, 1e30), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_INTERSECTION_COST, 1e-300), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &s2), AACBVH_OK);
    assert_true(isfinite(s2.sah_cost) && isfinite(s2.built_sah_cost) && s2.sah_cost == s2.built_sah_cost);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, 1e31), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_INTERSECTION_COST, 1e300),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, 3.0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_INTERSECTION_COST, 0.5), AACBVH_OK);
    /* The checker reads the costs in force as well. */
    if (!ts_check_tree(bvh, boxes, mesh.triangle_count, NULL, 4, msg, sizeof msg)) fail_msg("%s", msg);
    /* The tree itself did not change. */
    {
        ts_tree t2;
        TS_EXPECT_STATUS(ts_tree_fetch(bvh, &t2), AACBVH_OK);
        assert_true(ts_tree_equal(&t, &t2));
        ts_tree_free(&t2);
    }
    ts_tree_free(&t);
    free(boxes);
    ts_mesh_free(&mesh);
    aacbvh_bvh_destroy(bvh);
}

/* Same input, same parameters: the same tree, on the same and on another handle. */
static void test_determinism(void **state) {
    const ts_scene_kind kinds[] = {TS_SCENE_RANDOM, TS_SCENE_GRID, TS_SCENE_IDENTICAL, TS_SCENE_SAME_CENTROID};
    size_t b, k;
    (void)state;
    for (b = 0; b < BUILDER_COUNT; ++b)
        for (k = 0; k < sizeof kinds / sizeof kinds[0]; ++k) {
            ts_mesh mesh;
            ts_tree t1, t2, t3;
            aacbvh_bvh *bvh = make_bvh(&k_builders[b], 4), *other = make_bvh(&k_builders[b], 4);
            size_t n = 1000;
            assert_true(ts_make_scene(kinds[k], n, 99, &mesh));
            TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 12, mesh.indices,
                                                      mesh.triangle_count), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(other, mesh.vertices, mesh.vertex_count, 12, mesh.indices,
                                                      mesh.triangle_count), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
            TS_EXPECT_STATUS(ts_tree_fetch(bvh, &t1), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
            TS_EXPECT_STATUS(ts_tree_fetch(bvh, &t2), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(other), AACBVH_OK);
            TS_EXPECT_STATUS(ts_tree_fetch(other, &t3), AACBVH_OK);
            if (!ts_tree_equal(&t1, &t2) || !ts_tree_equal(&t1, &t3))
                fail_msg("%s on the %s scene: two builds of the same input differ", k_builders[b].name,
                         ts_scene_name(kinds[k]));
            assert_true(t1.stats.sah_cost == t2.stats.sah_cost);
            ts_tree_free(&t1);
            ts_tree_free(&t2);
            ts_tree_free(&t3);
            ts_mesh_free(&mesh);
            aacbvh_bvh_destroy(bvh);
            aacbvh_bvh_destroy(other);
        }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_aac_hq),
        cmocka_unit_test(test_aac_fast),
        cmocka_unit_test(test_aac_custom_small),
        cmocka_unit_test(test_aac_custom_large),
        cmocka_unit_test(test_sweep_sah),
        cmocka_unit_test(test_binned_sah),
        cmocka_unit_test(test_locally_ordered),
        cmocka_unit_test(test_ploc),
        cmocka_unit_test(test_deep_and_wide),
        cmocka_unit_test(test_boxes),
        cmocka_unit_test(test_strided_and_unindexed),
        cmocka_unit_test(test_real_mesh),
        cmocka_unit_test(test_build_peak_budget),
        cmocka_unit_test(test_sah_cost_follows_params),
        cmocka_unit_test(test_determinism),
    };
    return cmocka_run_group_tests(tests, setup_group, teardown_group);
}
