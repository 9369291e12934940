/* Parameters: defaults, round trips, bounds, types and the AAC presets. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "test_support.h"

typedef struct params_snapshot {
    int64_t builder, delta, leaf, ploc, skip;
    double c, alpha, ct, ci;
} params_snapshot;

static void snapshot(const aacbvh_bvh *bvh, params_snapshot *s) {
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_BUILDER, &s->builder), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_AAC_DELTA, &s->delta), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, &s->leaf), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_PLOC_RADIUS, &s->ploc), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_SKIP_INVALID_PRIMITIVES, &s->skip), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_AAC_C, &s->c), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_AAC_ALPHA, &s->alpha), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, &s->ct), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_INTERSECTION_COST, &s->ci), AACBVH_OK);
}

static void assert_same_params(const params_snapshot *a, const params_snapshot *b) {
    assert_int_equal(a->builder, b->builder);
    assert_int_equal(a->delta, b->delta);
    assert_int_equal(a->leaf, b->leaf);
    assert_int_equal(a->ploc, b->ploc);
    assert_int_equal(a->skip, b->skip);
    assert_true(a->c == b->c);
    assert_true(a->alpha == b->alpha);
    assert_true(a->ct == b->ct);
    assert_true(a->ci == b->ci);
}

static void assert_close(double got, double want) {
    if (!(fabs(got - want) <= 1e-12 * fabs(want))) fail_msg("got %.17g, expected %.17g", got, want);
}

static int64_t get_int(const aacbvh_bvh *bvh, aacbvh_param p) {
    int64_t v = -12345;
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, p, &v), AACBVH_OK);
    return v;
}

static double get_float(const aacbvh_bvh *bvh, aacbvh_param p) {
    double v = -12345.0;
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, p, &v), AACBVH_OK);
    return v;
}

static aacbvh_context *g_ctx;

static int setup_bvh(void **state) {
    aacbvh_bvh *bvh = NULL;
    if (aacbvh_context_create(1, &g_ctx) != AACBVH_OK) return -1;
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

static void test_defaults(void **state) {
    const aacbvh_bvh *bvh = (const aacbvh_bvh *)*state;
    assert_int_equal(get_int(bvh, AACBVH_PARAM_BUILDER), AACBVH_BUILDER_AAC_HQ);
    assert_int_equal(get_int(bvh, AACBVH_PARAM_AAC_DELTA), 20);
    assert_close(get_float(bvh, AACBVH_PARAM_AAC_C), pow(20.0, 0.6) / 2.0);
    assert_close(get_float(bvh, AACBVH_PARAM_AAC_ALPHA), 0.4);
    assert_int_equal(get_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE), 4);
    assert_close(get_float(bvh, AACBVH_PARAM_TRAVERSAL_COST), 1.2);
    assert_close(get_float(bvh, AACBVH_PARAM_INTERSECTION_COST), 1.0);
    assert_int_equal(get_int(bvh, AACBVH_PARAM_PLOC_RADIUS), 16);
    assert_int_equal(get_int(bvh, AACBVH_PARAM_SKIP_INVALID_PRIMITIVES), 0);
    assert_int_equal(get_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT), AACBVH_LAYOUT_WIDE8);
    assert_int_equal(get_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE), AACBVH_TRIANGLES_COPIED);
    assert_int_equal(get_int(bvh, AACBVH_PARAM_KEEP_BUILD_MEMORY), 0);
    assert_int_equal(get_int(bvh, AACBVH_PARAM_OPTIMIZE_PASSES), 0);
}

static void set_int_ok(aacbvh_bvh *bvh, aacbvh_param p, int64_t v) {
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, p, v), AACBVH_OK);
    assert_int_equal(get_int(bvh, p), v);
}

static void set_float_ok(aacbvh_bvh *bvh, aacbvh_param p, double v) {
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, p, v), AACBVH_OK);
    assert_true(get_float(bvh, p) == v);
}

static void test_round_trips(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    int b;
    for (b = AACBVH_BUILDER_AAC_HQ; b <= AACBVH_BUILDER_PLOC; ++b) set_int_ok(bvh, AACBVH_PARAM_BUILDER, b);
    set_int_ok(bvh, AACBVH_PARAM_AAC_DELTA, 2);
    set_int_ok(bvh, AACBVH_PARAM_AAC_DELTA, 7);
    set_int_ok(bvh, AACBVH_PARAM_AAC_DELTA, 1 << 20);
    set_int_ok(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 1);
    set_int_ok(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 13);
    set_int_ok(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 1 << 16);
    set_int_ok(bvh, AACBVH_PARAM_PLOC_RADIUS, 1);
    set_int_ok(bvh, AACBVH_PARAM_PLOC_RADIUS, 1024);
    set_int_ok(bvh, AACBVH_PARAM_PLOC_RADIUS, 33);
    set_int_ok(bvh, AACBVH_PARAM_SKIP_INVALID_PRIMITIVES, 1);
    set_int_ok(bvh, AACBVH_PARAM_SKIP_INVALID_PRIMITIVES, 0);
    set_int_ok(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4);
    set_int_ok(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_BINARY);
    set_int_ok(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_COPIED);
    set_int_ok(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, AACBVH_TRIANGLES_REFERENCED);
    set_int_ok(bvh, AACBVH_PARAM_KEEP_BUILD_MEMORY, 1);
    set_int_ok(bvh, AACBVH_PARAM_KEEP_BUILD_MEMORY, 0);
    set_int_ok(bvh, AACBVH_PARAM_OPTIMIZE_PASSES, AACBVH_MAX_OPTIMIZE_PASSES);
    set_int_ok(bvh, AACBVH_PARAM_OPTIMIZE_PASSES, 3);
    set_int_ok(bvh, AACBVH_PARAM_OPTIMIZE_PASSES, 0);
    set_float_ok(bvh, AACBVH_PARAM_AAC_C, 0.5);
    set_float_ok(bvh, AACBVH_PARAM_AAC_C, 1e-3);
    set_float_ok(bvh, AACBVH_PARAM_AAC_C, 3.7);
    set_float_ok(bvh, AACBVH_PARAM_AAC_ALPHA, 1.0);
    set_float_ok(bvh, AACBVH_PARAM_AAC_ALPHA, 0.3);
    set_float_ok(bvh, AACBVH_PARAM_AAC_ALPHA, 1e-6);
    set_float_ok(bvh, AACBVH_PARAM_TRAVERSAL_COST, 0.75);
    set_float_ok(bvh, AACBVH_PARAM_TRAVERSAL_COST, 3.3);
    set_float_ok(bvh, AACBVH_PARAM_INTERSECTION_COST, 2.5);
    set_float_ok(bvh, AACBVH_PARAM_INTERSECTION_COST, 0.1);
}

static void expect_int_rejected(aacbvh_bvh *bvh, aacbvh_param p, int64_t v) {
    params_snapshot before, after;
    snapshot(bvh, &before);
    if (aacbvh_bvh_set_param_int(bvh, p, v) != AACBVH_ERROR_INVALID_ARGUMENT)
        fail_msg("set_param_int(%d, %lld) was not rejected", (int)p, (long long)v);
    assert_true(strlen(aacbvh_bvh_last_error(bvh)) > 0);
    snapshot(bvh, &after);
    assert_same_params(&before, &after);
}

static void expect_float_rejected(aacbvh_bvh *bvh, aacbvh_param p, double v) {
    params_snapshot before, after;
    snapshot(bvh, &before);
    if (aacbvh_bvh_set_param_float(bvh, p, v) != AACBVH_ERROR_INVALID_ARGUMENT)
        fail_msg("set_param_float(%d, %g) was not rejected", (int)p, v);
    assert_true(strlen(aacbvh_bvh_last_error(bvh)) > 0);
    snapshot(bvh, &after);
    assert_same_params(&before, &after);
}

static void check_rejections(aacbvh_bvh *bvh) {
    expect_int_rejected(bvh, AACBVH_PARAM_AAC_DELTA, 1);
    expect_int_rejected(bvh, AACBVH_PARAM_AAC_DELTA, 0);
    expect_int_rejected(bvh, AACBVH_PARAM_AAC_DELTA, -5);
    expect_int_rejected(bvh, AACBVH_PARAM_AAC_DELTA, (1 << 20) + 1);
    expect_int_rejected(bvh, AACBVH_PARAM_AAC_DELTA, INT64_MAX);
    expect_int_rejected(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 0);
    expect_int_rejected(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, -1);
    expect_int_rejected(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, (1 << 16) + 1);
    expect_int_rejected(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, INT64_MIN);
    expect_int_rejected(bvh, AACBVH_PARAM_PLOC_RADIUS, 0);
    expect_int_rejected(bvh, AACBVH_PARAM_PLOC_RADIUS, 1025);
    expect_int_rejected(bvh, AACBVH_PARAM_SKIP_INVALID_PRIMITIVES, 2);
    expect_int_rejected(bvh, AACBVH_PARAM_SKIP_INVALID_PRIMITIVES, -1);
    expect_int_rejected(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, 3);
    expect_int_rejected(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, -1);
    expect_int_rejected(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, 2);
    expect_int_rejected(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, -1);
    expect_int_rejected(bvh, AACBVH_PARAM_KEEP_BUILD_MEMORY, 2);
    expect_int_rejected(bvh, AACBVH_PARAM_KEEP_BUILD_MEMORY, -1);
    expect_int_rejected(bvh, AACBVH_PARAM_OPTIMIZE_PASSES, -1);
    expect_int_rejected(bvh, AACBVH_PARAM_OPTIMIZE_PASSES, AACBVH_MAX_OPTIMIZE_PASSES + 1);
    expect_int_rejected(bvh, AACBVH_PARAM_BUILDER, 7);
    expect_int_rejected(bvh, AACBVH_PARAM_BUILDER, -1);
    expect_int_rejected(bvh, AACBVH_PARAM_BUILDER, 0x7FFFFFFF);
    expect_int_rejected(bvh, AACBVH_PARAM_BUILDER, (int64_t)1 << 32); /* would truncate to 0 */

    expect_float_rejected(bvh, AACBVH_PARAM_AAC_C, 0.0);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_C, -0.0);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_C, -1.0);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_C, NAN);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_C, INFINITY);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_C, -INFINITY);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_ALPHA, 0.0);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_ALPHA, -0.1);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_ALPHA, 1.0000001);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_ALPHA, 2.0);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_ALPHA, NAN);
    expect_float_rejected(bvh, AACBVH_PARAM_AAC_ALPHA, INFINITY);
    expect_float_rejected(bvh, AACBVH_PARAM_TRAVERSAL_COST, 0.0);
    expect_float_rejected(bvh, AACBVH_PARAM_TRAVERSAL_COST, -1.0);
    expect_float_rejected(bvh, AACBVH_PARAM_TRAVERSAL_COST, NAN);
    expect_float_rejected(bvh, AACBVH_PARAM_TRAVERSAL_COST, INFINITY);
    expect_float_rejected(bvh, AACBVH_PARAM_INTERSECTION_COST, 0.0);
    expect_float_rejected(bvh, AACBVH_PARAM_INTERSECTION_COST, -2.0);
    expect_float_rejected(bvh, AACBVH_PARAM_INTERSECTION_COST, NAN);
    expect_float_rejected(bvh, AACBVH_PARAM_INTERSECTION_COST, INFINITY);

    /* Unknown keys, both types, both directions. */
    expect_int_rejected(bvh, (aacbvh_param)13, 1);
    expect_int_rejected(bvh, (aacbvh_param)-1, 1);
    expect_int_rejected(bvh, (aacbvh_param)1000, 1);
    expect_int_rejected(bvh, AACBVH_PARAM_MAX_ENUM, 1);
    expect_float_rejected(bvh, (aacbvh_param)13, 1.0);
    expect_float_rejected(bvh, (aacbvh_param)-1, 1.0);
    expect_float_rejected(bvh, AACBVH_PARAM_MAX_ENUM, 1.0);
    {
        int64_t i = 77;
        double d = 77.0;
        TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, (aacbvh_param)13, &i), AACBVH_ERROR_INVALID_ARGUMENT);
        TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, (aacbvh_param)13, &d), AACBVH_ERROR_INVALID_ARGUMENT);
        TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, (aacbvh_param)-1, &i), AACBVH_ERROR_INVALID_ARGUMENT);
        TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, (aacbvh_param)-1, &d), AACBVH_ERROR_INVALID_ARGUMENT);
    }
}

static void test_out_of_range_changes_nothing(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    /* From the defaults (builder AAC_HQ: a rejected delta, c or alpha must not
     * switch the builder to AAC) ... */
    check_rejections(bvh);
    /* ... and from a non-default state. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_PLOC), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 7), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, 2.0), AACBVH_OK);
    check_rejections(bvh);
}

static void test_wrong_type(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    const aacbvh_param int_keys[] = {AACBVH_PARAM_BUILDER, AACBVH_PARAM_AAC_DELTA, AACBVH_PARAM_MAX_LEAF_SIZE,
                                     AACBVH_PARAM_PLOC_RADIUS, AACBVH_PARAM_SKIP_INVALID_PRIMITIVES,
                                     AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_PARAM_TRIANGLE_STORAGE,
                                     AACBVH_PARAM_KEEP_BUILD_MEMORY, AACBVH_PARAM_OPTIMIZE_PASSES};
    const aacbvh_param float_keys[] = {AACBVH_PARAM_AAC_C, AACBVH_PARAM_AAC_ALPHA, AACBVH_PARAM_TRAVERSAL_COST,
                                       AACBVH_PARAM_INTERSECTION_COST};
    size_t i;
    for (i = 0; i < sizeof int_keys / sizeof int_keys[0]; ++i) {
        double d = -1.0;
        expect_float_rejected(bvh, int_keys[i], 1.0);
        expect_float_rejected(bvh, int_keys[i], 4.0);
        TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, int_keys[i], &d), AACBVH_ERROR_INVALID_ARGUMENT);
        assert_true(strlen(aacbvh_bvh_last_error(bvh)) > 0);
    }
    for (i = 0; i < sizeof float_keys / sizeof float_keys[0]; ++i) {
        int64_t v = -1;
        expect_int_rejected(bvh, float_keys[i], 1);
        TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, float_keys[i], &v), AACBVH_ERROR_INVALID_ARGUMENT);
        assert_true(strlen(aacbvh_bvh_last_error(bvh)) > 0);
    }
}

static void expect_aac(const aacbvh_bvh *bvh, int64_t builder, int64_t delta, double c, double alpha) {
    assert_int_equal(get_int(bvh, AACBVH_PARAM_BUILDER), builder);
    assert_int_equal(get_int(bvh, AACBVH_PARAM_AAC_DELTA), delta);
    assert_close(get_float(bvh, AACBVH_PARAM_AAC_C), c);
    assert_close(get_float(bvh, AACBVH_PARAM_AAC_ALPHA), alpha);
}

static void test_presets(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    const double c_hq = pow(20.0, 0.6) / 2.0, c_fast = pow(4.0, 0.7) / 2.0;

    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST), AACBVH_OK);
    expect_aac(bvh, AACBVH_BUILDER_AAC_FAST, 4, c_fast, 0.3);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_HQ), AACBVH_OK);
    expect_aac(bvh, AACBVH_BUILDER_AAC_HQ, 20, c_hq, 0.4);

    /* Setting delta, c or alpha switches to AAC and keeps the others. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_AAC_DELTA, 9), AACBVH_OK);
    expect_aac(bvh, AACBVH_BUILDER_AAC, 9, c_hq, 0.4);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_C, 2.5), AACBVH_OK);
    expect_aac(bvh, AACBVH_BUILDER_AAC, 4, 2.5, 0.3);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_HQ), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_ALPHA, 0.25), AACBVH_OK);
    expect_aac(bvh, AACBVH_BUILDER_AAC, 20, c_hq, 0.25);

    /* Also from a non-AAC builder. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_SWEEP_SAH), AACBVH_OK);
    expect_aac(bvh, AACBVH_BUILDER_SWEEP_SAH, 20, c_hq, 0.25);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_AAC_DELTA, 3), AACBVH_OK);
    expect_aac(bvh, AACBVH_BUILDER_AAC, 3, c_hq, 0.25);

    /* Choosing AAC keeps the values in force, also a preset's. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC), AACBVH_OK);
    expect_aac(bvh, AACBVH_BUILDER_AAC, 3, c_hq, 0.25);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC), AACBVH_OK);
    expect_aac(bvh, AACBVH_BUILDER_AAC, 4, c_fast, 0.3);

    /* The presets touch nothing but delta, c and alpha. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 6), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, 1.5), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_HQ), AACBVH_OK);
    expect_aac(bvh, AACBVH_BUILDER_AAC_HQ, 20, c_hq, 0.4);
    assert_int_equal(get_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE), 6);
    assert_true(get_float(bvh, AACBVH_PARAM_TRAVERSAL_COST) == 1.5);
}

/* Parameters belong to their handle. */
static void test_handles_independent(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state, *other = NULL;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &other), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 2), AACBVH_OK);
    assert_int_equal(get_int(other, AACBVH_PARAM_BUILDER), AACBVH_BUILDER_AAC_HQ);
    assert_int_equal(get_int(other, AACBVH_PARAM_MAX_LEAF_SIZE), 4);
    assert_int_equal(get_int(other, AACBVH_PARAM_AAC_DELTA), 20);
    aacbvh_bvh_destroy(other);
}

/* Builder names: every value 0.. has one until the first NULL, names and
 * values round-trip, every named builder is accepted by the parameter, and
 * the first value past the table is rejected by both. */
static void test_builder_names(void **state) {
    aacbvh_bvh *bvh = (aacbvh_bvh *)*state;
    const char *expected[] = {"aac-hq", "aac-fast", "aac", "sweep-sah", "binned-sah", "locally-ordered", "ploc"};
    int count = 0;
    aacbvh_builder got;
    while (aacbvh_builder_name((aacbvh_builder)count)) {
        const char *name = aacbvh_builder_name((aacbvh_builder)count);
        assert_true(count < (int)(sizeof expected / sizeof expected[0]));
        assert_string_equal(name, expected[count]);
        TS_EXPECT_STATUS(aacbvh_builder_from_name(name, &got), AACBVH_OK);
        assert_int_equal(got, count);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, count), AACBVH_OK);
        ++count;
    }
    assert_int_equal(count, (int)(sizeof expected / sizeof expected[0]));
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, count), AACBVH_ERROR_INVALID_ARGUMENT);
    assert_null(aacbvh_builder_name((aacbvh_builder)-1));
    assert_null(aacbvh_builder_name(AACBVH_BUILDER_MAX_ENUM));
    TS_EXPECT_STATUS(aacbvh_builder_from_name("aac-hq ", &got), AACBVH_ERROR_INVALID_ARGUMENT);
    assert_non_null(strstr(aacbvh_last_error(), "sweep-sah")); /* the message lists the names */
    TS_EXPECT_STATUS(aacbvh_builder_from_name(NULL, &got), AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_builder_from_name("ploc", NULL), AACBVH_ERROR_INVALID_ARGUMENT);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_defaults, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_round_trips, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_out_of_range_changes_nothing, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_wrong_type, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_presets, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_handles_independent, setup_bvh, teardown_bvh),
        cmocka_unit_test_setup_teardown(test_builder_names, setup_bvh, teardown_bvh),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
