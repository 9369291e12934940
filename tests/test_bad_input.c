/*
 * Bad input through the public API, and what aacbvh_bvh_last_error() says
 * about it:
 *   - NaN or infinite vertices, out-of-range indices, inverted or NaN boxes:
 *     build (and refit) return AACBVH_ERROR_INVALID_GEOMETRY with a message
 *     naming the first offending primitive ("triangle 17"), also when the bad
 *     primitives lie in different parallel chunks;
 *   - counts that overflow or exceed AACBVH_MAX_PRIMITIVES, vertex_count * stride that
 *     overflows, strides that are too small or not a multiple of 4, NULL
 *     buffers with nonzero counts: AACBVH_ERROR_INVALID_ARGUMENT with a
 *     message, and the call changes nothing.
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

static aacbvh_bvh *new_bvh(void) {
    aacbvh_bvh *bvh;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    return bvh;
}

/* `call` must return `want` and leave a message containing `needle`. */
#define EXPECT_MESSAGE(bvh, call, want, needle)                                                              \
    do {                                                                                                     \
        TS_EXPECT_STATUS(call, want);                                                                        \
        if (!strstr(aacbvh_bvh_last_error(bvh), needle))                                                     \
            fail_msg("%s:%d: %s: message \"%s\" does not contain \"%s\"", __FILE__, __LINE__, #call,         \
                     aacbvh_bvh_last_error(bvh), needle);                                                    \
    } while (0)

/* n separate triangles (non-indexed, 9 floats each) of a small random scene. */
static float *soup(size_t n) {
    ts_mesh m;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, n, 5, &m));
    float *v = malloc(9 * n * sizeof *v);
    assert_non_null(v);
    for (size_t t = 0; t < n; ++t)
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) v[9 * t + 3 * j + k] = m.vertices[3 * m.indices[3 * t + j] + k];
    ts_mesh_free(&m);
    return v;
}

static void test_bad_vertices_named(void **state) {
    (void)state;
    const float bad_values[] = {NAN, INFINITY, -INFINITY};
    enum { N = 40 };
    float *v = soup(N);
    aacbvh_bvh *bvh = new_bvh();
    for (size_t b = 0; b < 3; ++b)
        for (int corner = 0; corner < 3; ++corner)
            for (int axis = 0; axis < 3; ++axis) {
                float *f = &v[9 * 17 + 3 * corner + axis];
                const float keep = *f;
                *f = bad_values[b];
                v[9 * 30 + 4] = NAN; /* a later bad one must not be named */
                TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 3 * N, 12, NULL, N), AACBVH_OK);
                EXPECT_MESSAGE(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "triangle 17 ");
                *f = keep;
            }
    /* Only the later one left. */
    EXPECT_MESSAGE(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "triangle 30 ");
    v[9 * 30 + 4] = 0.5f;
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);

    /* Refit checks first and names the triangle too; the tree stays valid. */
    v[9 * 23 + 8] = INFINITY;
    EXPECT_MESSAGE(bvh, aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "triangle 23 ");
    /* Of two bad ones, the first in the caller's order is named, wherever
     * their leaves lie (refit checks in the caller's order, not the leaves'). */
    v[9 * 11 + 0] = NAN;
    EXPECT_MESSAGE(bvh, aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "triangle 11 ");
    v[9 * 11 + 0] = 0.25f;
    EXPECT_MESSAGE(bvh, aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "triangle 23 ");
    v[9 * 23 + 8] = 0.5f;
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
    {
        aacbvh_stats stats;
        stats.struct_size = sizeof stats;
        TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
    }
    aacbvh_bvh_destroy(bvh);
    free(v);
}

static void test_bad_indices_named(void **state) {
    (void)state;
    enum { N = 40 };
    float *v = soup(N);
    uint32_t idx[3 * N];
    const uint32_t bad[] = {3 * N, 3 * N + 1, 0x7FFFFFFFu, 0xFFFFFFFEu, 0xFFFFFFFFu};
    aacbvh_bvh *bvh = new_bvh();
    for (uint32_t i = 0; i < 3 * N; ++i) idx[i] = i;
    for (size_t b = 0; b < sizeof bad / sizeof bad[0]; ++b)
        for (int corner = 0; corner < 3; ++corner) {
            idx[3 * 17 + corner] = bad[b];
            idx[3 * 35] = 3 * N + 7;
            TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 3 * N, 12, idx, N), AACBVH_OK);
            EXPECT_MESSAGE(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "triangle 17 ");
            idx[3 * 17 + corner] = 3 * 17 + (uint32_t)corner;
        }
    EXPECT_MESSAGE(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "triangle 35 ");
    EXPECT_MESSAGE(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "index");
    aacbvh_bvh_destroy(bvh);
    free(v);
}

static void test_bad_boxes_named(void **state) {
    (void)state;
    enum { N = 30 };
    float *boxes = ts_random_boxes(N, 0.2f, 3);
    aacbvh_bvh *bvh = new_bvh();
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, boxes, N, 24), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    for (int axis = 0; axis < 3; ++axis) {
        /* Inverted on one axis. */
        const float lo = boxes[6 * 17 + axis], hi = boxes[6 * 17 + 3 + axis];
        boxes[6 * 17 + axis] = hi + 1.0f;
        EXPECT_MESSAGE(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "box 17 ");
        boxes[6 * 17 + axis] = lo;
        /* NaN or infinite corners. */
        boxes[6 * 17 + 3 + axis] = NAN;
        EXPECT_MESSAGE(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "box 17 ");
        boxes[6 * 17 + 3 + axis] = INFINITY;
        EXPECT_MESSAGE(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "box 17 ");
        boxes[6 * 17 + 3 + axis] = hi;
    }
    /* A point box (min = max) is valid. */
    for (int k = 0; k < 3; ++k) boxes[6 * 4 + 3 + k] = boxes[6 * 4 + k];
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    boxes[6 * 9 + 1] = NAN;
    EXPECT_MESSAGE(bvh, aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "box 9 ");
    aacbvh_bvh_destroy(bvh);
    free(boxes);
}

/* Many triangles on 2 threads, bad ones far apart (different parallel
 * chunks): the lowest index is named, whichever chunk finishes first. */
static void test_first_bad_across_chunks(void **state) {
    (void)state;
    enum { N = 150000 };
    float *v = soup(N);
    aacbvh_bvh *bvh = new_bvh();
    v[9 * 140001] = NAN;
    v[9 * 99999 + 5] = INFINITY;
    v[9 * 70017 + 1] = NAN;
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 3 * N, 12, NULL, N), AACBVH_OK);
    for (int rep = 0; rep < 3; ++rep)
        EXPECT_MESSAGE(bvh, aacbvh_bvh_build(bvh), AACBVH_ERROR_INVALID_GEOMETRY, "triangle 70017 ");
    aacbvh_bvh_destroy(bvh);
    free(v);
}

static void test_counts_that_overflow(void **state) {
    (void)state;
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint32_t idx[3] = {0, 1, 2};
    aacbvh_bvh *bvh = new_bvh();
    /* Node ids are 32-bit over 2n - 1 nodes: at most 2^31 - 1 primitives. */
    const size_t huge_counts[] = {SIZE_MAX, SIZE_MAX / 3 + 1, SIZE_MAX / 12 + 1, (size_t)UINT32_MAX,
                                  (size_t)UINT32_MAX + 1, (size_t)UINT32_MAX - 1, (size_t)1 << 31,
                                  (size_t)AACBVH_MAX_PRIMITIVES + 1};
    for (size_t i = 0; i < sizeof huge_counts / sizeof huge_counts[0]; ++i) {
        EXPECT_MESSAGE(bvh, aacbvh_bvh_set_triangles(bvh, v, 3, 12, idx, huge_counts[i]),
                       AACBVH_ERROR_INVALID_ARGUMENT, "count");
        EXPECT_MESSAGE(bvh, aacbvh_bvh_set_triangles(bvh, v, 3, 12, NULL, huge_counts[i]),
                       AACBVH_ERROR_INVALID_ARGUMENT, "");
        EXPECT_MESSAGE(bvh, aacbvh_bvh_set_boxes(bvh, v, huge_counts[i], 24), AACBVH_ERROR_INVALID_ARGUMENT,
                       "count");
        /* Vertex counts up to 2^32 are fine (indices reach 2^32 - 1). */
        if (huge_counts[i] > (size_t)1 << 32)
            EXPECT_MESSAGE(bvh, aacbvh_bvh_set_triangles(bvh, v, huge_counts[i], 12, idx, 1),
                           AACBVH_ERROR_INVALID_ARGUMENT, "vertex");
    }
    /* vertex_count * stride overflows size_t (count within 2^32). */
    EXPECT_MESSAGE(bvh, aacbvh_bvh_set_triangles(bvh, v, 3, (SIZE_MAX / 2) & ~(size_t)3, idx, 1),
                   AACBVH_ERROR_INVALID_ARGUMENT, "overflow");
    EXPECT_MESSAGE(bvh, aacbvh_bvh_set_triangles(bvh, v, (size_t)1 << 32, (size_t)1 << 32, idx, 1),
                   AACBVH_ERROR_INVALID_ARGUMENT, "overflow");
    EXPECT_MESSAGE(bvh, aacbvh_bvh_set_boxes(bvh, v, 3, SIZE_MAX & ~(size_t)3), AACBVH_ERROR_INVALID_ARGUMENT,
                   "overflow");
    /* The largest accepted count still sets (nothing is read until build). */
    assert_true(AACBVH_MAX_PRIMITIVES == 0x7FFFFFFFu);
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, v, AACBVH_MAX_PRIMITIVES, 24), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 3, 12, idx, AACBVH_MAX_PRIMITIVES), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 3, 12, NULL, 1), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    aacbvh_bvh_destroy(bvh);
}

static void test_bad_strides(void **state) {
    (void)state;
    const float v[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0};
    const size_t vertex_strides[] = {0, 1, 4, 8, 11, 13, 14, 15, 17, 18, 19, 21, 1001, SIZE_MAX};
    const size_t box_strides[] = {0, 4, 12, 20, 22, 23, 25, 26, 27, 29, 30, 31, SIZE_MAX};
    aacbvh_bvh *bvh = new_bvh();
    for (size_t i = 0; i < sizeof vertex_strides / sizeof vertex_strides[0]; ++i) {
        EXPECT_MESSAGE(bvh, aacbvh_bvh_set_triangles(bvh, v, 3, vertex_strides[i], NULL, 1),
                       AACBVH_ERROR_INVALID_ARGUMENT, "stride");
        EXPECT_MESSAGE(bvh, aacbvh_bvh_set_boxes(bvh, v, 1, box_strides[i % 13]), AACBVH_ERROR_INVALID_ARGUMENT,
                       "stride");
    }
    /* Multiples of 4 from the minimum up are fine. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 1, 12, NULL, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 2, 16, NULL, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, v, 1, 28), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, v, 1, 24), AACBVH_OK);
    aacbvh_bvh_destroy(bvh);
}

static void test_null_with_counts(void **state) {
    (void)state;
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint32_t idx[3] = {0, 1, 2};
    aacbvh_bvh *bvh = new_bvh();
    aacbvh_ray ray = {{0.2f, 0.2f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
    aacbvh_hit hit;
    uint8_t occ;
    aacbvh_node node;
    uint32_t prim;
    EXPECT_MESSAGE(bvh, aacbvh_bvh_set_triangles(bvh, NULL, 3, 12, idx, 1), AACBVH_ERROR_INVALID_ARGUMENT, "NULL");
    EXPECT_MESSAGE(bvh, aacbvh_bvh_set_triangles(bvh, NULL, 3, 12, NULL, 1), AACBVH_ERROR_INVALID_ARGUMENT, "NULL");
    EXPECT_MESSAGE(bvh, aacbvh_bvh_set_boxes(bvh, NULL, 2, 24), AACBVH_ERROR_INVALID_ARGUMENT, "NULL");
    /* NULL with zero counts is the empty scene. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, NULL, 0, 24), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, NULL, 0, 12, NULL, 0), AACBVH_OK);

    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, v, 3, 12, idx, 1), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    EXPECT_MESSAGE(bvh, aacbvh_bvh_intersect(bvh, NULL, &hit, 1), AACBVH_ERROR_INVALID_ARGUMENT, "NULL");
    EXPECT_MESSAGE(bvh, aacbvh_bvh_intersect(bvh, &ray, NULL, 1), AACBVH_ERROR_INVALID_ARGUMENT, "NULL");
    EXPECT_MESSAGE(bvh, aacbvh_bvh_occluded(bvh, NULL, &occ, 1), AACBVH_ERROR_INVALID_ARGUMENT, "NULL");
    EXPECT_MESSAGE(bvh, aacbvh_bvh_occluded(bvh, &ray, NULL, 1), AACBVH_ERROR_INVALID_ARGUMENT, "NULL");
    EXPECT_MESSAGE(bvh, aacbvh_bvh_get_nodes(bvh, 0, 1, NULL), AACBVH_ERROR_INVALID_ARGUMENT, "NULL");
    EXPECT_MESSAGE(bvh, aacbvh_bvh_get_primitive_indices(bvh, 0, 1, NULL), AACBVH_ERROR_INVALID_ARGUMENT, "NULL");
    /* Zero counts with NULL are fine, and the tree answers as before. */
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, NULL, NULL, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, NULL, NULL, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(bvh, 0, 1, &node), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_primitive_indices(bvh, 0, 1, &prim), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
    assert_int_equal(hit.prim_id, 0);
    aacbvh_bvh_destroy(bvh);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_vertices_named),
        cmocka_unit_test(test_bad_indices_named),
        cmocka_unit_test(test_bad_boxes_named),
        cmocka_unit_test(test_first_bad_across_chunks),
        cmocka_unit_test(test_counts_that_overflow),
        cmocka_unit_test(test_bad_strides),
        cmocka_unit_test(test_null_with_counts),
    };
    return cmocka_run_group_tests(tests, setup_group, teardown_group);
}
