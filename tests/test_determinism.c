/*
 * Trees are bit-identical (nodes and primitive order) for 1, 2, 3 and 8
 * threads and from run to run, for every builder, through the public API.
 * The scenes are big enough (> 64K primitives) that every parallel phase
 * really splits: bounds, Morton codes, the radix sort, the AAC recursion,
 * the layout and refit.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <string.h>
#include <cmocka.h>

#include <aacbvh/aacbvh.h>

#include "test_support.h"

static const uint32_t kThreadCounts[] = {1, 2, 3, 8};

static void fetch_tree(uint32_t threads, int builder, const ts_mesh *mesh, ts_tree *out, int refit) {
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(threads, &ctx, &bvh);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh->vertices, mesh->vertex_count, 3 * sizeof(float),
                                              mesh->indices, mesh->triangle_count),
                     AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    if (refit) TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, out), AACBVH_OK);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
}

static void check_builder(int builder, const ts_mesh *mesh) {
    ts_tree reference;
    fetch_tree(1, builder, mesh, &reference, 0);
    for (size_t t = 0; t < sizeof kThreadCounts / sizeof kThreadCounts[0]; ++t) {
        for (int run = 0; run < 2; ++run) {
            ts_tree tree;
            char msg[512];
            fetch_tree(kThreadCounts[t], builder, mesh, &tree, run == 1);
            if (!ts_tree_diff(&reference, &tree, msg, sizeof msg))
                fail_msg("builder %d: tree with %u threads (run %d) differs from the 1-thread tree: %s", builder,
                         kThreadCounts[t], run, msg);
            ts_tree_free(&tree);
        }
    }
    ts_tree_free(&reference);
}

static void load_scene(ts_mesh *mesh) {
    if (!ts_load_scene("bunny.obj", mesh)) {
        print_message("note: bunny.obj not found, using a generated grid scene\n");
        assert_true(ts_make_scene(TS_SCENE_GRID, 100000, 7, mesh));
    }
}

static void test_aac_deterministic(void **state) {
    (void)state;
    ts_mesh mesh = {0};
    load_scene(&mesh);
    check_builder(AACBVH_BUILDER_AAC_HQ, &mesh);
    check_builder(AACBVH_BUILDER_AAC_FAST, &mesh);
    ts_mesh_free(&mesh);
}

static void test_reference_builders_deterministic(void **state) {
    (void)state;
    ts_mesh mesh = {0};
    load_scene(&mesh);
    check_builder(AACBVH_BUILDER_BINNED_SAH, &mesh);
    check_builder(AACBVH_BUILDER_SWEEP_SAH, &mesh);
    check_builder(AACBVH_BUILDER_PLOC, &mesh);
    ts_mesh_free(&mesh);
}

static void test_degenerate_scene_deterministic(void **state) {
    (void)state;
    /* Equal Morton codes everywhere: the middle splits must not depend on timing. */
    ts_mesh mesh = {0};
    assert_true(ts_make_scene(TS_SCENE_SAME_CENTROID, 70000, 3, &mesh));
    check_builder(AACBVH_BUILDER_AAC_FAST, &mesh);
    ts_mesh_free(&mesh);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_aac_deterministic),
        cmocka_unit_test(test_reference_builders_deterministic),
        cmocka_unit_test(test_degenerate_scene_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
