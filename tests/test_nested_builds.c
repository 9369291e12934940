/* Builds started from a progress callback, as game engines do from job
 * callbacks: the callback builds, queries, refits and destroys another BVH,
 * on another context or on the building one, on its first call or on every
 * call (in every phase under ThreadSanitizer, see run_all). The outer build
 * must come out exactly as it does without nesting (same nodes, same
 * primitive order), for every builder, and so must the
 * nested ones. A large single combine (AAC with delta 2^20) polls from inside
 * the combine, where the scratch memory is in use. Calls on the building
 * handle itself from its own callback are refused with
 * AACBVH_ERROR_INVALID_OPERATION and leave the build untouched. The
 * AddressSanitizer stage runs all of it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "test_support.h"

/* NEST_EVERY_PHASE: on every call that reports a new fraction (each phase),
 * not on the polls of a phase that repeat it; see run_all. */
typedef enum nest_when { NEST_FIRST_CALL, NEST_EVERY_CALL, NEST_EVERY_PHASE } nest_when;

/* What the callback does. */
typedef struct nester {
    nest_when when;
    aacbvh_context *ctx;       /* where the nested BVHs are built */
    const ts_mesh *mesh;       /* what they are built over */
    const ts_tree *expected;   /* the nested BVH's tree, built alone */
    aacbvh_builder builder;
    aacbvh_bvh *outer;         /* the building handle, or NULL */
    double nested_at;          /* the fraction of the last call that nested */
    int calls, nested, wrong;
    aacbvh_status self_status; /* a call on `outer` from its own callback */
} nester;

static aacbvh_bvh *new_bvh(aacbvh_context *ctx, aacbvh_builder builder, const ts_mesh *mesh) {
    aacbvh_bvh *bvh = NULL;
    if (aacbvh_bvh_create(ctx, &bvh) != AACBVH_OK) return NULL;
    if (aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder) != AACBVH_OK ||
        aacbvh_bvh_set_triangles(bvh, mesh->vertices, mesh->vertex_count, 3 * sizeof(float), mesh->indices,
                                 mesh->triangle_count) != AACBVH_OK) {
        aacbvh_bvh_destroy(bvh);
        return NULL;
    }
    return bvh;
}

/* Builds, checks, queries, refits and destroys a BVH of n->mesh. */
static void nested_work(nester *n) {
    aacbvh_bvh *bvh = new_bvh(n->ctx, n->builder, n->mesh);
    ts_tree tree;
    aacbvh_ray ray = {{0.0f, 0.0f, 5.0f}, 0.0f, {0.01f, 0.02f, -1.0f}, 1e30f};
    aacbvh_hit hit;
    ++n->nested;
    if (!bvh || aacbvh_bvh_build(bvh) != AACBVH_OK || ts_tree_fetch(bvh, &tree) != AACBVH_OK) {
        ++n->wrong;
        aacbvh_bvh_destroy(bvh);
        return;
    }
    if (!ts_tree_equal(&tree, n->expected)) ++n->wrong;
    ts_tree_free(&tree);
    if (aacbvh_bvh_intersect(bvh, &ray, &hit, 1) != AACBVH_OK || aacbvh_bvh_refit(bvh) != AACBVH_OK) ++n->wrong;
    aacbvh_bvh_destroy(bvh);
}

static bool nests_now(const nester *n, double fraction) {
    switch (n->when) {
    case NEST_FIRST_CALL: return n->calls == 1;
    case NEST_EVERY_CALL: return true;
    default: return n->calls == 1 || fraction != n->nested_at;
    }
}

static bool nesting_callback(void *user, double fraction) {
    nester *n = (nester *)user;
    ++n->calls;
    if (nests_now(n, fraction)) {
        n->nested_at = fraction;
        nested_work(n);
    }
    if (n->outer && n->calls == 2) {
        /* The building handle may not be changed from its own callback. */
        n->self_status = aacbvh_bvh_set_param_int(n->outer, AACBVH_PARAM_MAX_LEAF_SIZE, 2);
        if (n->self_status == AACBVH_OK) ++n->wrong;
        if (aacbvh_bvh_build(n->outer) != AACBVH_ERROR_INVALID_OPERATION) ++n->wrong;
        if (aacbvh_bvh_refit(n->outer) != AACBVH_ERROR_INVALID_OPERATION) ++n->wrong;
    }
    return true;
}

/* The outer build of `outer_mesh` with nesting equals the one without. */
static void check_nesting(aacbvh_context *outer_ctx, aacbvh_context *nested_ctx, aacbvh_builder builder,
                          int64_t aac_delta, const ts_mesh *outer_mesh, const ts_mesh *inner_mesh, nest_when when) {
    const char *name = aacbvh_builder_name(builder);
    aacbvh_bvh *plain = new_bvh(outer_ctx, builder, outer_mesh);
    aacbvh_bvh *inner = new_bvh(nested_ctx, builder, inner_mesh);
    aacbvh_bvh *outer = new_bvh(outer_ctx, builder, outer_mesh);
    ts_tree want, want_inner, got;
    nester n;
    assert_non_null(plain);
    assert_non_null(inner);
    assert_non_null(outer);
    if (aac_delta) {
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(plain, AACBVH_PARAM_AAC_DELTA, aac_delta), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(outer, AACBVH_PARAM_AAC_DELTA, aac_delta), AACBVH_OK);
    }
    TS_EXPECT_STATUS(aacbvh_bvh_build(plain), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(plain, &want), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(inner), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(inner, &want_inner), AACBVH_OK);

    memset(&n, 0, sizeof n);
    n.when = when;
    n.ctx = nested_ctx;
    n.mesh = inner_mesh;
    n.expected = &want_inner;
    n.builder = builder;
    n.outer = outer;
    TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(outer, nesting_callback, &n), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(outer), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(outer, &got), AACBVH_OK);
    if (n.nested == 0) fail_msg("%s: the callback never nested", name);
    if (n.wrong) fail_msg("%s: %d nested builds or calls on the building handle went wrong", name, n.wrong);
    if (n.self_status != AACBVH_ERROR_INVALID_OPERATION)
        fail_msg("%s: setting a parameter from the handle's own callback returned %s", name,
                 aacbvh_status_string(n.self_status));
    if (!ts_tree_equal(&got, &want))
        fail_msg("%s (delta %lld), nesting %s: the outer tree differs from a build without nesting", name,
                 (long long)aac_delta,
                 when == NEST_FIRST_CALL   ? "on the first call"
                 : when == NEST_EVERY_CALL ? "on every call"
                                           : "in every phase");
    ts_tree_free(&want);
    ts_tree_free(&want_inner);
    ts_tree_free(&got);
    aacbvh_bvh_destroy(plain);
    aacbvh_bvh_destroy(inner);
    aacbvh_bvh_destroy(outer);
}

static void run_all(int same_context) {
    ts_mesh outer_mesh = {0}, inner_mesh = {0};
    aacbvh_context *ctx = NULL, *other = NULL;
    int b;
    /* Under ThreadSanitizer (10-15 times slower) smaller scenes: an outer one
     * on which every builder still reports progress more than twice, and an
     * inner one that AAC still splits into tasks (4,096 triangles make one). */
    assert_true(ts_make_scene(TS_SCENE_RANDOM, TS_UNDER_TSAN ? 8000 : 30000, 21, &outer_mesh));
    assert_true(ts_make_scene(TS_SCENE_GRID, TS_UNDER_TSAN ? 4500 : 6000, 22, &inner_mesh));
    TS_EXPECT_STATUS(aacbvh_context_create(2, &ctx), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_context_create(2, &other), AACBVH_OK);
    /* Under ThreadSanitizer a nested build takes longer than the 5 ms a build
     * leaves between two progress calls, so every poll of a long phase calls
     * back, repeating the phase's fraction: nesting on every call nested 22
     * times per AAC build there (5 in the Release stage) and 43 per PLOC
     * build. There the second build nests in every phase (on each new
     * fraction) instead; nesting from the polls of a long phase is
     * test_nested_inside_a_large_combine's, in every stage. */
    for (b = 0; aacbvh_builder_name((aacbvh_builder)b); ++b) {
        check_nesting(ctx, same_context ? ctx : other, (aacbvh_builder)b, 0, &outer_mesh, &inner_mesh,
                      NEST_FIRST_CALL);
        check_nesting(ctx, same_context ? ctx : other, (aacbvh_builder)b, 0, &outer_mesh, &inner_mesh,
                      TS_UNDER_TSAN ? NEST_EVERY_PHASE : NEST_EVERY_CALL);
    }
    aacbvh_context_destroy(ctx);
    aacbvh_context_destroy(other);
    ts_mesh_free(&outer_mesh);
    ts_mesh_free(&inner_mesh);
}

static void test_nested_on_another_context(void **state) {
    (void)state;
    run_all(0);
}

static void test_nested_on_the_same_context(void **state) {
    (void)state;
    run_all(1);
}

/* One combine of 4,000 clusters (delta 2^20): the callback runs while the
 * combine's scratch is in use, and the nested build makes combines of its own
 * on the same thread. */
static void test_nested_inside_a_large_combine(void **state) {
    ts_mesh outer_mesh = {0}, inner_mesh = {0};
    aacbvh_context *ctx = NULL;
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 4000, 31, &outer_mesh));
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 3000, 32, &inner_mesh));
    TS_EXPECT_STATUS(aacbvh_context_create(1, &ctx), AACBVH_OK);
    check_nesting(ctx, ctx, AACBVH_BUILDER_AAC, (int64_t)1 << 20, &outer_mesh, &inner_mesh, NEST_EVERY_CALL);
    aacbvh_context_destroy(ctx);
    ts_mesh_free(&outer_mesh);
    ts_mesh_free(&inner_mesh);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nested_on_another_context),
        cmocka_unit_test(test_nested_on_the_same_context),
        cmocka_unit_test(test_nested_inside_a_large_combine),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
