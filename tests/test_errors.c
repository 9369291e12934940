/* Error handling: NULL arguments, misuse, bad strides, bad geometry, failed
 * builds that keep the previous tree, skipping invalid primitives. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "test_support.h"

static aacbvh_context *g_ctx;

static int setup_bvh(void **state) {
    aacbvh_bvh *bvh = NULL;
    if (aacbvh_context_create(2, &g_ctx) != AACBVH_OK) return -1;
    if (aacbvh_bvh_create(g_ctx, &bvh) != AACBVH_OK) return -1;
    *state = bvh;
    return 0;
}

static int teardown_bvh(void **state) {
    aacbvh_bvh_destroy((aacbvh_bvh *)*state);
    aacbvh_context_destroy(g_ctx);
    g_ctx = NULL;
    return 0;
}

/* The status must be `want`, and the handle must explain the failure. */
#define EXPECT_FAIL(bvh, call, want)                                                     \
    do {                                                                                 \
        TS_EXPECT_STATUS(call, want);                                                    \
        assert_non_null(aacbvh_bvh_last_error(bvh));                                     \
        if (strlen(aacbvh_bvh_last_error(bvh)) == 0)                                     \
            fail_msg("%s:%d: empty last_error after %s", __FILE__, __LINE__, #call);     \
    } while (0)

/* One triangle in the plane z = 0 and a ray down the z axis that hits it. */
static const float k_tri[9] = {-1.0f, -1.0f, 0.0f, 1.0f, -1.0f, 0.0f, 0.0f, 1.0f, 0.0f};

static aacbvh_ray ray_down(float x, float y) {
    aacbvh_ray r;
    r.org[0] = x; r.org[1] = y; r.org[2] = 5.0f;
    r.dir[0] = 0.0f; r.dir[1] = 0.0f; r.dir[2] = -1.0f;
    r.tmin = 0.0f;
    r.tmax = INFINITY;
    return r;
}

static void expect_queries(const aacbvh_bvh *bvh, aacbvh_status want) {
    aacbvh_ray ray = ray_down(0.0f, 0.0f);
    aacbvh_hit hit;
    uint8_t occ = 0;
    aacbvh_stats stats;
    aacbvh_node node;
    uint32_t prim = 0;
    memset(&stats, 0, sizeof stats);
    stats.struct_size = sizeof stats;
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), want);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &ray, &occ, 1), want);
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), want);
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(bvh, 0, 1, &node), want);
    TS_EXPECT_STATUS(aacbvh_bvh_get_primitive_indices(bvh, 0, 1, &prim), want);
    if (want != AACBVH_OK) assert_true(strlen(aacbvh_bvh_last_error(bvh)) > 0);
}

static void test_null_handles(void **state) {
    aacbvh_context *ctx = (aacbvh_context *)0x1;
    aacbvh_bvh *bvh = (aacbvh_bvh *)0x1;
    aacbvh_stats stats;
    aacbvh_node node;
    aacbvh_ray ray = ray_down(0.0f, 0.0f);
    aacbvh_hit hit;
    uint8_t occ;
    uint32_t prim;
    int64_t i64;
    double d;
    (void)state;
    memset(&stats, 0, sizeof stats);
    stats.struct_size = sizeof stats;

    TS_EXPECT_STATUS(aacbvh_context_create(1, NULL), AACBVH_ERROR_INVALID_ARGUMENT);
    assert_string_equal(aacbvh_last_error(), "out is NULL");
    TS_EXPECT_STATUS(aacbvh_context_create(1025, &ctx), AACBVH_ERROR_INVALID_ARGUMENT);
    assert_null(ctx);
    assert_non_null(strstr(aacbvh_last_error(), "1024")); /* failures without a handle have a message too */
    assert_int_equal(aacbvh_context_thread_count(NULL), 0);
    aacbvh_context_destroy(NULL);

    TS_EXPECT_STATUS(aacbvh_bvh_create(NULL, &bvh), AACBVH_ERROR_INVALID_ARGUMENT);
    assert_null(bvh);
    assert_string_equal(aacbvh_last_error(), "context is NULL");
    aacbvh_bvh_destroy(NULL);
    assert_non_null(aacbvh_bvh_last_error(NULL));
    assert_string_equal(aacbvh_bvh_last_error(NULL), "invalid handle");

    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(NULL, AACBVH_PARAM_MAX_LEAF_SIZE, 2), AACBVH_ERROR_INVALID_ARGUMENT);
    assert_string_equal(aacbvh_last_error(), "bvh is NULL");
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(NULL, AACBVH_PARAM_AAC_C, 1.0), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(NULL, AACBVH_PARAM_MAX_LEAF_SIZE, &i64), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(NULL, AACBVH_PARAM_AAC_C, &d), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(NULL, k_tri, 3, 12, NULL, 1), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(NULL, k_tri, 1, 24), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(NULL, NULL, NULL), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_build(NULL), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_refit(NULL), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(NULL, &stats), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(NULL, 0, 1, &node), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_primitive_indices(NULL, 0, 1, &prim), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(NULL, &ray, &hit, 1), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(NULL, &ray, &occ, 1), AACBVH_ERROR_INVALID_ARGUMENT);
}

static void test_create_out_null(void **state) {
    aacbvh_context *ctx = NULL;
    (void)state;
    TS_EXPECT_STATUS(aacbvh_context_create(1, &ctx), AACBVH_OK);
    assert_true(aacbvh_context_thread_count(ctx) == 1);
    TS_EXPECT_STATUS(aacbvh_bvh_create(ctx, NULL), AACBVH_ERROR_INVALID_ARGUMENT);
    aacbvh_context_destroy(ctx);
    TS_EXPECT_STATUS(aacbvh_context_create(0, &ctx), AACBVH_OK);
    assert_true(aacbvh_context_thread_count(ctx) >= 1);
    aacbvh_context_destroy(ctx);
}

static void test_null_pointers_on_handle(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    aacbvh_ray ray = ray_down(0.0f, 0.0f);
    aacbvh_hit hit;
    uint8_t occ;
    aacbvh_node node;
    uint32_t prim;
    assert_string_equal(aacbvh_bvh_last_error(bvh), "");

    EXPECT_FAIL(bvh, aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, NULL), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_AAC_C, NULL), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_stats(bvh, NULL), AACBVH_ERROR_INVALID_ARGUMENT);

    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, k_tri, 3, 12, NULL, 1), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_nodes(bvh, 0, 1, NULL), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_primitive_indices(bvh, 0, 1, NULL), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_intersect(bvh, NULL, &hit, 1), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_intersect(bvh, &ray, NULL, 1), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_occluded(bvh, NULL, &occ, 1), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_occluded(bvh, &ray, NULL, 1), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_stats(bvh, NULL), AACBVH_ERROR_INVALID_ARGUMENT);

    /* Zero counts with NULL buffers are fine. */
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, NULL, NULL, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, NULL, NULL, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(bvh, 0, 0, NULL), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_primitive_indices(bvh, 0, 0, NULL), AACBVH_OK);

    /* The tree is still fine after all that. */
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(bvh, 0, 1, &node), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_primitive_indices(bvh, 0, 1, &prim), AACBVH_OK);
    assert_int_equal(prim, 0);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
    assert_int_equal(hit.prim_id, 0);
    assert_true(fabsf(hit.t - 5.0f) < 1e-5f);
}

static void test_misuse_before_build(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    /* Nothing set, nothing built. */
    expect_queries(bvh, AACBVH_ERROR_INVALID_OPERATION);
    EXPECT_FAIL(bvh, aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_OPERATION);
    /* Geometry set but not built. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, k_tri, 3, 12, NULL, 1), AACBVH_OK);
    expect_queries(bvh, AACBVH_ERROR_INVALID_OPERATION);
    EXPECT_FAIL(bvh, aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_OPERATION);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    expect_queries(bvh, AACBVH_OK);
    /* Setting geometry again invalidates the tree until the next build. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, k_tri, 3, 12, NULL, 1), AACBVH_OK);
    expect_queries(bvh, AACBVH_ERROR_INVALID_OPERATION);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    expect_queries(bvh, AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, k_tri, 1, 24), AACBVH_OK);
    expect_queries(bvh, AACBVH_ERROR_INVALID_OPERATION);
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, NULL, 0, 24), AACBVH_OK);
    expect_queries(bvh, AACBVH_ERROR_INVALID_OPERATION);
}

static void test_stats_struct_size(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    aacbvh_stats stats;
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, k_tri, 3, 12, NULL, 1), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    memset(&stats, 0, sizeof stats);
    stats.struct_size = 0;
    EXPECT_FAIL(bvh, aacbvh_bvh_get_stats(bvh, &stats), AACBVH_ERROR_INVALID_ARGUMENT);
    stats.struct_size = 3;
    EXPECT_FAIL(bvh, aacbvh_bvh_get_stats(bvh, &stats), AACBVH_ERROR_INVALID_ARGUMENT);
    stats.struct_size = sizeof stats;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
    assert_int_equal(stats.node_count, 1);
    assert_int_equal(stats.leaf_count, 1);
    assert_int_equal(stats.primitive_count, 1);
    assert_int_equal(stats.max_depth, 0);
    assert_true(stats.memory_bytes > 0);
    assert_true(stats.build_seconds >= 0.0);
}

static void test_range_past_end(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    ts_mesh mesh;
    aacbvh_stats stats;
    aacbvh_node *nodes;
    uint32_t *prims;
    size_t n, p;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 50, 1, &mesh));
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 12, mesh.indices,
                                              mesh.triangle_count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    memset(&stats, 0, sizeof stats);
    stats.struct_size = sizeof stats;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
    n = (size_t)stats.node_count;
    p = (size_t)stats.primitive_count;
    assert_int_equal(p, 50);
    nodes = calloc(n + 2, sizeof *nodes);
    prims = calloc(p + 2, sizeof *prims);
    assert_non_null(nodes);
    assert_non_null(prims);
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(bvh, 0, n, nodes), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(bvh, n - 1, 1, nodes), AACBVH_OK);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_nodes(bvh, 0, n + 1, nodes), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_nodes(bvh, n, 1, nodes), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_nodes(bvh, n + 5, 0, nodes), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_nodes(bvh, SIZE_MAX, 2, nodes), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_nodes(bvh, 1, SIZE_MAX, nodes), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_primitive_indices(bvh, 0, p, prims), AACBVH_OK);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_primitive_indices(bvh, 0, p + 1, prims), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_primitive_indices(bvh, p, 1, prims), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_get_primitive_indices(bvh, SIZE_MAX, 2, prims), AACBVH_ERROR_INVALID_ARGUMENT);
    free(nodes);
    free(prims);
    ts_mesh_free(&mesh);
}

static void test_bad_strides_and_pointers(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    const size_t bad_vertex_strides[] = {0, 4, 8, 11, 13, 14, 15, 18};
    const size_t bad_box_strides[] = {0, 12, 20, 23, 25, 26, 30};
    float padded[3 * 4];
    size_t i;
    for (i = 0; i < sizeof bad_vertex_strides / sizeof bad_vertex_strides[0]; ++i)
        EXPECT_FAIL(bvh, aacbvh_bvh_set_triangles(bvh, k_tri, 3, bad_vertex_strides[i], NULL, 1),
                    AACBVH_ERROR_INVALID_ARGUMENT);
    for (i = 0; i < sizeof bad_box_strides / sizeof bad_box_strides[0]; ++i)
        EXPECT_FAIL(bvh, aacbvh_bvh_set_boxes(bvh, k_tri, 1, bad_box_strides[i]), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_set_triangles(bvh, NULL, 3, 12, NULL, 1), AACBVH_ERROR_INVALID_ARGUMENT);
    {
        const uint32_t idx[3] = {0, 1, 2};
        EXPECT_FAIL(bvh, aacbvh_bvh_set_triangles(bvh, NULL, 3, 12, idx, 1), AACBVH_ERROR_INVALID_ARGUMENT);
    }
    EXPECT_FAIL(bvh, aacbvh_bvh_set_boxes(bvh, NULL, 1, 24), AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_set_triangles(bvh, k_tri, 3, 12, NULL, SIZE_MAX / 2),
                AACBVH_ERROR_INVALID_ARGUMENT);
    EXPECT_FAIL(bvh, aacbvh_bvh_set_boxes(bvh, k_tri, SIZE_MAX / 8, 24), AACBVH_ERROR_INVALID_ARGUMENT);

    /* A rejected set leaves nothing usable behind: still no tree. */
    expect_queries(bvh, AACBVH_ERROR_INVALID_OPERATION);

    /* Valid strides above the minimum work. */
    for (i = 0; i < 3; ++i) {
        padded[4 * i + 0] = k_tri[3 * i + 0];
        padded[4 * i + 1] = k_tri[3 * i + 1];
        padded[4 * i + 2] = k_tri[3 * i + 2];
        padded[4 * i + 3] = NAN; /* padding is never read */
    }
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, padded, 3, 16, NULL, 1), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    {
        aacbvh_ray ray = ray_down(0.0f, -0.5f);
        aacbvh_hit hit;
        TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
        assert_int_equal(hit.prim_id, 0);
    }
}

static void check_empty_tree(aacbvh_bvh *bvh) {
    aacbvh_stats stats;
    aacbvh_ray rays[3];
    aacbvh_hit hits[3];
    uint8_t occ[3] = {7, 7, 7};
    size_t i;
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    memset(&stats, 0xAB, sizeof stats);
    stats.struct_size = sizeof stats;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
    assert_int_equal(stats.node_count, 0);
    assert_int_equal(stats.leaf_count, 0);
    assert_int_equal(stats.primitive_count, 0);
    assert_int_equal(stats.max_depth, 0);
    assert_true(stats.sah_cost == 0.0);
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(bvh, 0, 0, NULL), AACBVH_OK);
    for (i = 0; i < 3; ++i) rays[i] = ray_down((float)i * 0.1f, 0.0f);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, rays, hits, 3), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, rays, occ, 3), AACBVH_OK);
    for (i = 0; i < 3; ++i) {
        assert_int_equal(hits[i].prim_id, AACBVH_INVALID_ID);
        assert_true(isinf(hits[i].t) && hits[i].t > 0);
        assert_true(hits[i].u == 0.0f && hits[i].v == 0.0f);
        assert_int_equal(occ[i], 0);
    }
    /* Refit of an empty tree over an empty scene is harmless. */
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
}

static void test_empty_scene(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, NULL, 0, 12, NULL, 0), AACBVH_OK);
    check_empty_tree(bvh);
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, NULL, 0, 24), AACBVH_OK);
    check_empty_tree(bvh);
    /* Vertices but no triangles. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, k_tri, 3, 12, NULL, 0), AACBVH_OK);
    check_empty_tree(bvh);
    /* Every builder copes with it. */
    {
        int b;
        for (b = AACBVH_BUILDER_AAC_HQ; b <= AACBVH_BUILDER_PLOC; ++b) {
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, b), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, NULL, 0, 12, NULL, 0), AACBVH_OK);
            check_empty_tree(bvh);
        }
    }
}

static void test_invalid_geometry(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    float v[9];
    float boxes[12] = {0, 0, 0, 1, 1, 1, 2, 0, 0, 1, 1, 1}; /* second box has min x > max x */
    const uint32_t bad_idx[6] = {0, 1, 2, 0, 1, 3};
    const uint32_t huge_idx[3] = {0, 1, 0xFFFFFFFFu};

    /* Out-of-range index. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, k_tri, 3, 12, bad_idx, 2), AACBVH_OK);
    EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
    expect_queries(bvh, AACBVH_ERROR_INVALID_OPERATION);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, k_tri, 3, 12, huge_idx, 1), AACBVH_OK);
    EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
    /* Non-indexed triangles beyond the vertex count: the header allows the
     * count check at set time (a count problem) or at build time (geometry). */
    {
        aacbvh_status s = aacbvh_bvh_set_triangles(bvh, k_tri, 3, 12, NULL, 2);
        if (s == AACBVH_OK)
            EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
        else
            EXPECT_FAIL(bvh, s, AACBVH_ERROR_INVALID_ARGUMENT);
    }

    /* NaN and infinite coordinates. */
    memcpy(v, k_tri, sizeof v);
    v[4] = NAN;
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 3, 12, NULL, 1), AACBVH_OK);
    EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
    v[4] = INFINITY;
    EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
    v[4] = -INFINITY;
    EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY);

    /* Boxes: inverted and NaN. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, boxes, 2, 24), AACBVH_OK);
    EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
    boxes[6] = 0.5f;
    boxes[10] = NAN;
    EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
    boxes[10] = 1.0f;
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
}

static void test_failed_build_keeps_tree(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    ts_mesh mesh;
    ts_tree before, after;
    aacbvh_ray ray;
    aacbvh_hit hit_before, hit_after;
    float saved;
    assert_true(ts_make_scene(TS_SCENE_GRID, 200, 3, &mesh));
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 12, mesh.indices,
                                              mesh.triangle_count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &before), AACBVH_OK);
    ray = ray_down(0.51f, 0.49f);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit_before, 1), AACBVH_OK);
    assert_int_not_equal(hit_before.prim_id, AACBVH_INVALID_ID);

    /* Vertex 0 sits at the grid's corner, far from the ray. */
    saved = mesh.vertices[0];
    mesh.vertices[0] = NAN;
    EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &after), AACBVH_OK);
    assert_true(ts_tree_equal(&before, &after));
    assert_true(before.stats.sah_cost == after.stats.sah_cost);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit_after, 1), AACBVH_OK);
    assert_int_equal(hit_after.prim_id, hit_before.prim_id);
    assert_true(hit_after.t == hit_before.t);
    ts_tree_free(&after);

    /* A failed refit keeps the tree as well. */
    EXPECT_FAIL(bvh, aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &after), AACBVH_OK);
    assert_true(ts_tree_equal(&before, &after));
    ts_tree_free(&after);

    mesh.vertices[0] = saved;
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    ts_tree_free(&before);
    ts_mesh_free(&mesh);
}

static void test_skip_invalid(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    ts_mesh mesh;
    const size_t n = 300;
    unsigned char *present = malloc(n);
    float *boxes;
    size_t i, bad = 0;
    char msg[256];
    uint32_t extra_vertex;
    aacbvh_stats stats;

    assert_true(ts_make_scene(TS_SCENE_RANDOM, n, 5, &mesh));
    /* Boxes of the intact triangles; the checker reads only the valid ones. */
    boxes = ts_mesh_boxes(&mesh);
    assert_non_null(boxes);
    /* Make a NaN and an infinite vertex of their own, then point some
     * triangles at them and others past the end of the vertex array. */
    extra_vertex = (uint32_t)mesh.vertex_count;
    mesh.vertices = realloc(mesh.vertices, (mesh.vertex_count + 2) * 3 * sizeof(float));
    assert_non_null(mesh.vertices);
    for (i = 0; i < 3; ++i) {
        mesh.vertices[3 * extra_vertex + i] = NAN;
        mesh.vertices[3 * extra_vertex + 3 + i] = 0.5f;
    }
    mesh.vertices[3 * extra_vertex + 3 + 1] = -INFINITY;
    memset(present, 1, n);
    for (i = 0; i < n; i += 7) {
        switch ((i / 7) % 3) {
        case 0: mesh.indices[3 * i + 1] = extra_vertex; break;
        case 1: mesh.indices[3 * i + 2] = extra_vertex + 1; break;
        default: mesh.indices[3 * i] = extra_vertex + 2; break; /* out of range */
        }
        present[i] = 0;
        ++bad;
    }
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count + 2, 12, mesh.indices, n),
                     AACBVH_OK);
    EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_SKIP_INVALID_PRIMITIVES, 1), AACBVH_OK);
    {
        int b;
        for (b = AACBVH_BUILDER_AAC_HQ; b <= AACBVH_BUILDER_PLOC; ++b) {
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, b), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
            if (!ts_check_tree(bvh, boxes, n, present, 4, msg, sizeof msg))
                fail_msg("builder %d: %s", b, msg);
            memset(&stats, 0, sizeof stats);
            stats.struct_size = sizeof stats;
            TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
            assert_int_equal(stats.invalid_primitive_count, bad);
            assert_int_equal(stats.primitive_count, n - bad);
            /* Refit checks the tree's primitives only: the ones left out stay bad. */
            TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
        }
        /* One of the tree's own (triangle 1) made bad: refused, and named. */
        {
            const uint32_t k = mesh.indices[3 * 1 + 2];
            const float keep = mesh.vertices[3 * k];
            mesh.vertices[3 * k] = INFINITY;
            EXPECT_FAIL(bvh, aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_GEOMETRY);
            assert_non_null(strstr(aacbvh_bvh_last_error(bvh), "triangle 1 "));
            mesh.vertices[3 * k] = keep;
            TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
        }
    }

    /* Only invalid primitives: an empty tree. */
    for (i = 0; i < n; ++i) mesh.indices[3 * i] = extra_vertex;
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count + 2, 12, mesh.indices, n),
                     AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    memset(&stats, 0, sizeof stats);
    stats.struct_size = sizeof stats;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
    assert_int_equal(stats.node_count, 0);
    assert_int_equal(stats.primitive_count, 0);
    assert_int_equal(stats.invalid_primitive_count, n);

    free(boxes);
    free(present);
    ts_mesh_free(&mesh);
}

/* prim_id (and the primitive index array) name primitives by their index in
 * the caller's arrays, also when invalid ones before them were left out. */
static void test_skip_invalid_keeps_caller_ids(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    /* Four triangles side by side, centred at x = 0, 3, 6, 9 (z = 0);
     * triangle 0 has a NaN vertex and triangle 2 an index past the end. */
    float vertices[12 * 3];
    uint32_t indices[12];
    /* Four boxes at the same places; box 1 has min > max on y. */
    float boxes[4 * 6];
    int b, kind;
    size_t t;
    for (t = 0; t < 4; ++t) {
        const float x = 3.0f * (float)t;
        const float corner[3][3] = {{x - 1.0f, -1.0f, 0.0f}, {x + 1.0f, -1.0f, 0.0f}, {x, 1.0f, 0.0f}};
        size_t c, a;
        for (c = 0; c < 3; ++c) {
            for (a = 0; a < 3; ++a) vertices[3 * (3 * t + c) + a] = corner[c][a];
            indices[3 * t + c] = (uint32_t)(3 * t + c);
        }
        boxes[6 * t + 0] = x - 1.0f; boxes[6 * t + 1] = -1.0f; boxes[6 * t + 2] = -0.5f;
        boxes[6 * t + 3] = x + 1.0f; boxes[6 * t + 4] = 1.0f;  boxes[6 * t + 5] = 0.5f;
    }
    vertices[3 * 1 + 2] = NAN;   /* triangle 0 */
    indices[3 * 2 + 1] = 1000;   /* triangle 2 */
    boxes[6 * 1 + 4] = -2.0f;    /* box 1: max y < min y */

    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_SKIP_INVALID_PRIMITIVES, 1), AACBVH_OK);
    for (kind = 0; kind < 2; ++kind) {
        /* The valid ones: triangles 1 and 3, boxes 0, 2 and 3. */
        const int valid_triangle[4] = {0, 1, 0, 1}, valid_box[4] = {1, 0, 1, 1};
        const int *valid = kind == 0 ? valid_triangle : valid_box;
        if (kind == 0)
            TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, vertices, 12, 12, indices, 4), AACBVH_OK);
        else
            TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, boxes, 4, 24), AACBVH_OK);
        for (b = AACBVH_BUILDER_AAC_HQ; b <= AACBVH_BUILDER_PLOC; ++b) {
            uint32_t prims[4];
            size_t count = 0, i;
            aacbvh_stats stats;
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, b), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
            memset(&stats, 0, sizeof stats);
            stats.struct_size = sizeof stats;
            TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
            for (t = 0; t < 4; ++t) count += (size_t)valid[t];
            assert_int_equal(stats.primitive_count, count);
            TS_EXPECT_STATUS(aacbvh_bvh_get_primitive_indices(bvh, 0, count, prims), AACBVH_OK);
            for (i = 0; i < count; ++i) {
                if (prims[i] >= 4 || !valid[prims[i]])
                    fail_msg("%s, builder %d: primitive index %u", kind ? "boxes" : "triangles", b, prims[i]);
            }
            for (t = 0; t < 4; ++t) {
                aacbvh_ray ray = ray_down(3.0f * (float)t, -0.5f);
                aacbvh_hit hit;
                TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
                if (valid[t] && hit.prim_id != t)
                    fail_msg("%s, builder %d: the ray at primitive %zu hit %u", kind ? "boxes" : "triangles",
                             b, t, hit.prim_id);
                if (!valid[t] && hit.prim_id != AACBVH_INVALID_ID)
                    fail_msg("%s, builder %d: the ray at skipped primitive %zu hit %u",
                             kind ? "boxes" : "triangles", b, t, hit.prim_id);
            }
        }
    }
}

static bool cancel_after(void *user, double fraction) {
    int *calls = (int *)user;
    if (!(fraction >= 0.0 && fraction <= 1.0)) *calls = -1000000;
    ++*calls;
    return false;
}

static void test_cancel_keeps_tree(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    ts_mesh mesh;
    ts_tree before, after;
    int calls = 0;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 5000, 9, &mesh));
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 12, mesh.indices,
                                              mesh.triangle_count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &before), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(bvh, cancel_after, &calls), AACBVH_OK);
    EXPECT_FAIL(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_CANCELLED);
    assert_true(calls >= 1);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &after), AACBVH_OK);
    assert_true(ts_tree_equal(&before, &after));
    ts_tree_free(&after);
    TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(bvh, NULL, NULL), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    ts_tree_free(&before);
    ts_mesh_free(&mesh);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_null_handles),
        cmocka_unit_test(test_create_out_null),
        cmocka_unit_test_setup_teardown(test_null_pointers_on_handle, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_misuse_before_build, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_stats_struct_size, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_range_past_end, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_bad_strides_and_pointers, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_empty_scene, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_invalid_geometry, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_failed_build_keeps_tree, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_skip_invalid, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_skip_invalid_keeps_caller_ids, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_cancel_keeps_tree, setup_bvh, teardown_bvh),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
