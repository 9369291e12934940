/*
 * AACBVH_LAYOUT_WIDE4 against AACBVH_LAYOUT_BINARY, through the public API.
 *
 * The same geometry is built twice, once per layout, and both answer the
 * same rays bit for bit (ts_compare_answers: t, u, v, prim_id and occluded
 * identical; of hits at the same t the smaller prim_id wins in both). Rays
 * from ts_make_rays: axis-parallel directions with +0 and -0 components,
 * origins on the scene's planes, bounded and negative [tmin, tmax] intervals
 * and invalid (NaN, infinite, zero) rays. The comparison is repeated after the
 * vertices move and both refit, over several builders, leaf sizes and
 * degenerate and coplanar scenes.
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

/* The wide layouts compared with the binary one (which reads the caller's
 * triangles), each with both triangle storages. */
typedef struct {
    aacbvh_layout layout;
    aacbvh_triangle_storage storage;
} wide_variant;
static const wide_variant kWide[] = {
    {AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_REFERENCED},
    {AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_COPIED},
    {AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_REFERENCED},
    {AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_COPIED},
};
enum { kWideCount = sizeof kWide / sizeof kWide[0] };
/* Which of kWide the mesh checks run: all of them, except on the scenes whose
 * rays meet every triangle (identical, stacked), where the 1.1 layout and the
 * default are enough and the other two would only multiply the run time. */
enum { kAllWide = 0xF, kMainWide = 0x9 };
static unsigned g_wide_variants = kAllWide;

static void set_builder(aacbvh_bvh *bvh, aacbvh_builder builder, uint32_t leaf, aacbvh_layout layout,
                        aacbvh_triangle_storage storage) {
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, leaf), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, storage), AACBVH_OK);
}

static const aacbvh_builder kBuilders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST,
                                           AACBVH_BUILDER_BINNED_SAH};
static const uint32_t kLeafSizes[] = {1, 4};
enum { kRays = TS_RAYS(3000) };
/* Rays per check_mesh comparison: kRays, except on the deep tree under
 * ThreadSanitizer, where every ray meets all 3000 triangles. */
static size_t g_rays = kRays;

/* The binary tree that get_nodes reports, the node count and the SAH are
 * the same whatever the layout: the default layout keeps the tree's shape
 * only and makes the nodes again from its packets (the same boxes, compared
 * by value: a zero may come back with the other sign). */
static void check_same_tree(aacbvh_bvh *binary, aacbvh_bvh *wide, const char *what) {
    aacbvh_stats a, b;
    aacbvh_node *na, *nb;
    size_t i;
    int k;
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    a.struct_size = b.struct_size = sizeof a;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(binary, &a), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(wide, &b), AACBVH_OK);
    if (a.node_count != b.node_count || a.leaf_count != b.leaf_count || a.max_depth != b.max_depth)
        fail_msg("%s: %zu nodes, %zu leaves, depth %u against the binary layout's %zu, %zu, %u", what,
                 (size_t)b.node_count, (size_t)b.leaf_count, (unsigned)b.max_depth, (size_t)a.node_count,
                 (size_t)a.leaf_count, (unsigned)a.max_depth);
    if (fabs(a.sah_cost - b.sah_cost) > 1e-12 * fabs(a.sah_cost) ||
        fabs(a.built_sah_cost - b.built_sah_cost) > 1e-12 * fabs(a.built_sah_cost))
        fail_msg("%s: SAH %.17g (built %.17g) against the binary layout's %.17g (%.17g)", what, b.sah_cost,
                 b.built_sah_cost, a.sah_cost, a.built_sah_cost);
    if (a.node_count == 0) return;
    na = malloc(a.node_count * sizeof *na);
    nb = malloc(a.node_count * sizeof *nb);
    assert_non_null(na);
    assert_non_null(nb);
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(binary, 0, a.node_count, na), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(wide, 0, a.node_count, nb), AACBVH_OK);
    for (i = 0; i < a.node_count; ++i) {
        int same = na[i].first == nb[i].first && na[i].count == nb[i].count;
        for (k = 0; k < 3; ++k)
            same = same && na[i].lower[k] == nb[i].lower[k] && na[i].upper[k] == nb[i].upper[k];
        if (!same) fail_msg("%s: node %zu differs from the binary layout's", what, i);
    }
    free(na);
    free(nb);
}

/* Under ThreadSanitizer, whether check_mesh runs builder bi for its
 * `pair`-th (variant, leaf size) pair: one builder per pair, in turn, so
 * every variant, builder and leaf size still runs, not every combination.
 * The builds and refits of these scenes (a few thousand triangles, below
 * most of the library's task grains) are mostly serial; the queries, which
 * run in tasks, run for every pair. The Release and AddressSanitizer stages
 * run every combination. */
static int run_builder(size_t pair, size_t bi) {
    return !TS_UNDER_TSAN || pair % (sizeof kBuilders / sizeof kBuilders[0]) == bi;
}

/* Builds a mesh with both layouts for every builder and leaf size, compares,
 * moves the vertices, refits and compares again. */
/* must_hit: the rays must hit something (not for scenes of zero-area triangles). */
static void check_mesh(ts_mesh *mesh, const char *name, uint64_t seed, int must_hit) {
    size_t bi, li, wi, pairs = 0;
    const size_t coords = 3 * mesh->vertex_count;
    float *original = malloc((coords ? coords : 1) * sizeof *original);
    assert_non_null(original);
    memcpy(original, mesh->vertices, coords * sizeof *original);
    for (wi = 0; wi < kWideCount; ++wi) {
        if (!(g_wide_variants >> wi & 1u)) continue;
        for (bi = 0; bi < sizeof kBuilders / sizeof kBuilders[0]; ++bi)
        for (li = 0; li < sizeof kLeafSizes / sizeof kLeafSizes[0]; ++li) {
            aacbvh_bvh *binary, *wide;
            aacbvh_ray *rays;
            char what[160];
            size_t hits;
            if (!run_builder(pairs + li, bi)) continue;
            memcpy(mesh->vertices, original, coords * sizeof *original);
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &wide), AACBVH_OK);
            set_builder(binary, kBuilders[bi], kLeafSizes[li], AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED);
            set_builder(wide, kBuilders[bi], kLeafSizes[li], kWide[wi].layout, kWide[wi].storage);
            ts_set_mesh(binary, mesh);
            ts_set_mesh(wide, mesh);
            TS_EXPECT_STATUS(aacbvh_bvh_build(binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(wide), AACBVH_OK);
            /* Every layout adds to the binary handle's memory, except the
             * default (8-wide, copied), which keeps the binary tree's shape
             * only (test_compact_topology). */
            if (mesh->triangle_count > 0 &&
                !(kWide[wi].layout == AACBVH_LAYOUT_WIDE8 && kWide[wi].storage == AACBVH_TRIANGLES_COPIED))
                assert_true(ts_memory_bytes(wide) > ts_memory_bytes(binary));

            rays = ts_make_rays(mesh->vertices, coords, g_rays, seed + 17 * bi + li);
            assert_non_null(rays);
            snprintf(what, sizeof what, "%s layout %d storage %d builder %d leaf %u", name, (int)kWide[wi].layout,
                     (int)kWide[wi].storage, (int)kBuilders[bi], kLeafSizes[li]);
            hits = ts_compare_answers(binary, wide, rays, g_rays, what);
            check_same_tree(binary, wide, what);
            if (must_hit && hits == 0) fail_msg("%s: no ray hits anything", what);
            free(rays);

            /* Move the vertices; both refit; compare on new rays. */
            ts_jitter_mesh(mesh, seed + 99);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(wide), AACBVH_OK);
            rays = ts_make_rays(mesh->vertices, coords, g_rays, seed + 1000 + 17 * bi + li);
            assert_non_null(rays);
            snprintf(what, sizeof what, "%s (refitted) layout %d storage %d builder %d leaf %u", name,
                     (int)kWide[wi].layout, (int)kWide[wi].storage, (int)kBuilders[bi], kLeafSizes[li]);
            ts_compare_answers(binary, wide, rays, g_rays, what);
            check_same_tree(binary, wide, what);
            free(rays);

            aacbvh_bvh_destroy(binary);
            aacbvh_bvh_destroy(wide);
        }
        pairs += sizeof kLeafSizes / sizeof kLeafSizes[0];
    }
    memcpy(mesh->vertices, original, coords * sizeof *original);
    free(original);
}

static void check_generated(ts_scene_kind kind, size_t triangles, uint64_t seed) {
    ts_mesh mesh;
    assert_true(ts_make_scene(kind, triangles, seed, &mesh));
    check_mesh(&mesh, ts_scene_name(kind), seed, kind != TS_SCENE_ZERO_AREA);
    ts_mesh_free(&mesh);
}

/* ------------------------------------------------------------------ */
/* Tests                                                               */
/* ------------------------------------------------------------------ */

static void test_random_soup(void **state) {
    (void)state;
    check_generated(TS_SCENE_RANDOM, 3000, 11);
}

static void test_grid(void **state) {
    (void)state;
    check_generated(TS_SCENE_GRID, 3000, 12);
}

static void test_bunny(void **state) {
    ts_mesh mesh;
    (void)state;
    if (ts_load_scene("bunny_npm_lowres.obj", &mesh)) {
        check_mesh(&mesh, "bunny_npm_lowres", 13, 1);
        ts_mesh_free(&mesh);
    } else {
        print_message("bunny_npm_lowres.obj not available: using a generated grid instead\n");
        check_generated(TS_SCENE_GRID, 4000, 13);
    }
}

static void test_degenerate_scenes(void **state) {
    (void)state;
    /* Rays meet every triangle of the first five scenes: under a
     * sanitizer, 300 rays (still more than a task's grain of 256). */
    g_rays = TS_UNDER_SANITIZER ? 300 : kRays;
    g_wide_variants = kMainWide;
    check_generated(TS_SCENE_IDENTICAL, 500, 21);
    check_generated(TS_SCENE_SAME_CENTROID, 500, 23);
    check_generated(TS_SCENE_ZERO_AREA, 500, 24);
    check_generated(TS_SCENE_COPLANAR, 1200, 28);
    check_generated(TS_SCENE_COPLANAR_STACK, 1200, 29);
    g_wide_variants = kAllWide;
    check_generated(TS_SCENE_FLAT, 1500, 22);
    check_generated(TS_SCENE_SLIVERS, 1000, 25);
    check_generated(TS_SCENE_WIDE_RANGE, 1000, 26);
    g_rays = kRays;
}

/* Many identical triangles in leaves of 1: a deep tree, whose traversal
 * stacks spill past their fixed part. */
static void test_deep_tree(void **state) {
    (void)state;
    g_wide_variants = kMainWide;
    g_rays = TS_UNDER_SANITIZER ? 300 : kRays; /* still more than a task's grain of 256 */
    check_generated(TS_SCENE_IDENTICAL, 3000, 27);
    g_rays = kRays;
    g_wide_variants = kAllWide;
}

static void test_single_triangle(void **state) {
    (void)state;
    check_generated(TS_SCENE_RANDOM, 1, 31);
    check_generated(TS_SCENE_RANDOM, 2, 32);
    check_generated(TS_SCENE_RANDOM, 5, 33);
}

static void test_boxes(void **state) {
    size_t bi, li, i, wi;
    const size_t count = 1500;
    (void)state;
    for (wi = 0; wi < kWideCount; wi += 2) /* storage does not apply to boxes */
    for (bi = 0; bi < sizeof kBuilders / sizeof kBuilders[0]; ++bi)
        for (li = 0; li < sizeof kLeafSizes / sizeof kLeafSizes[0]; ++li) {
            float *boxes = ts_random_boxes(count, 0.2f, 41 + bi);
            aacbvh_bvh *binary, *wide;
            aacbvh_ray *rays;
            char what[120];
            assert_non_null(boxes);
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &wide), AACBVH_OK);
            set_builder(binary, kBuilders[bi], kLeafSizes[li], AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED);
            set_builder(wide, kBuilders[bi], kLeafSizes[li], kWide[wi].layout, kWide[wi].storage);
            TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(binary, boxes, count, 24), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(wide, boxes, count, 24), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(wide), AACBVH_OK);
            assert_true(ts_memory_bytes(wide) > ts_memory_bytes(binary));
            /* Coordinates of box corners: rays start on and aim at faces. */
            rays = ts_make_rays(boxes, 6 * count, kRays, 51 + bi * 2 + li);
            assert_non_null(rays);
            snprintf(what, sizeof what, "boxes layout %d builder %d leaf %u", (int)kWide[wi].layout, (int)kBuilders[bi],
                     kLeafSizes[li]);
            assert_true(ts_compare_answers(binary, wide, rays, kRays, what) > kRays / 10);
            free(rays);

            /* Shift every box; both refit. */
            for (i = 0; i < count; ++i) {
                const float dx = 0.01f * (float)(i % 7), dy = -0.02f * (float)(i % 3);
                boxes[6 * i] += dx;
                boxes[6 * i + 3] += dx;
                boxes[6 * i + 1] += dy;
                boxes[6 * i + 4] += dy;
            }
            TS_EXPECT_STATUS(aacbvh_bvh_refit(binary), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_refit(wide), AACBVH_OK);
            rays = ts_make_rays(boxes, 6 * count, kRays, 61 + bi * 2 + li);
            assert_non_null(rays);
            snprintf(what, sizeof what, "boxes (refitted) builder %d leaf %u", (int)kBuilders[bi], kLeafSizes[li]);
            ts_compare_answers(binary, wide, rays, kRays, what);
            free(rays);
            aacbvh_bvh_destroy(binary);
            aacbvh_bvh_destroy(wide);
            free(boxes);
        }
}

static void test_layout_param(void **state) {
    aacbvh_bvh *bvh;
    int64_t value = -1;
    double f;
    (void)state;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_LAYOUT_WIDE8); /* the default since 1.2 */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_LAYOUT_WIDE4);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, 3),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, -1),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, 1.0),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, &f),
                     AACBVH_ERROR_INVALID_ARGUMENT);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_LAYOUT_WIDE4);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_BINARY), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, &value), AACBVH_OK);
    assert_int_equal(value, AACBVH_LAYOUT_BINARY);
    aacbvh_bvh_destroy(bvh);
}

/* The layout takes effect at the next build or refit; memory follows it. */
static void test_layout_switch(void **state) {
    ts_mesh mesh;
    aacbvh_bvh *binary, *bvh;
    aacbvh_ray *rays;
    uint64_t mem_binary, mem_wide;
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 2000, 71, &mesh));
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &binary), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(binary, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_BINARY), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_BINARY), AACBVH_OK);
    ts_set_mesh(binary, &mesh);
    ts_set_mesh(bvh, &mesh);
    TS_EXPECT_STATUS(aacbvh_bvh_build(binary), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    mem_binary = ts_memory_bytes(bvh);
    assert_int_equal(mem_binary, ts_memory_bytes(binary));

    rays = ts_make_rays(mesh.vertices, 3 * mesh.vertex_count, kRays, 72);
    assert_non_null(rays);

    /* Switched to WIDE4 and refitted: the wide tree appears. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4), AACBVH_OK);
    assert_int_equal(ts_memory_bytes(bvh), mem_binary);
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
    mem_wide = ts_memory_bytes(bvh);
    assert_true(mem_wide > mem_binary);
    ts_compare_answers(binary, bvh, rays, kRays, "switched to wide4 by refit");

    /* Rebuilt with WIDE4: same memory as after the refit. */
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    assert_int_equal(ts_memory_bytes(bvh), mem_wide);
    ts_compare_answers(binary, bvh, rays, kRays, "rebuilt with wide4");

    /* Back to BINARY: the wide tree is freed at the next build. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_BINARY), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    assert_int_equal(ts_memory_bytes(bvh), mem_binary);
    ts_compare_answers(binary, bvh, rays, kRays, "back to binary");

    free(rays);
    aacbvh_bvh_destroy(binary);
    aacbvh_bvh_destroy(bvh);
    ts_mesh_free(&mesh);
}

static void test_empty_scene(void **state) {
    aacbvh_bvh *bvh;
    aacbvh_ray ray = {{0.0f, 0.0f, 0.0f}, 0.0f, {1.0f, 0.5f, 0.25f}, INFINITY};
    aacbvh_hit hit;
    uint8_t occ = 7;
    aacbvh_stats st;
    (void)state;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, NULL, 0, 12, NULL, 0), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
    assert_int_equal(hit.prim_id, AACBVH_INVALID_ID);
    assert_true(isinf(hit.t) && hit.t > 0.0f);
    assert_true(hit.u == 0.0f && hit.v == 0.0f);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &ray, &occ, 1), AACBVH_OK);
    assert_int_equal(occ, 0);
    memset(&st, 0, sizeof st);
    st.struct_size = sizeof st;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &st), AACBVH_OK);
    assert_int_equal(st.node_count, 0);
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
    assert_int_equal(hit.prim_id, AACBVH_INVALID_ID);
    aacbvh_bvh_destroy(bvh);
}

/* A query before any build fails the same way in both layouts. */
static void test_query_before_build(void **state) {
    aacbvh_bvh *bvh;
    aacbvh_ray ray = {{0.0f, 0.0f, 0.0f}, 0.0f, {1.0f, 0.0f, 0.0f}, INFINITY};
    aacbvh_hit hit;
    (void)state;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_ERROR_INVALID_OPERATION);
    aacbvh_bvh_destroy(bvh);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layout_param),
        cmocka_unit_test(test_empty_scene),
        cmocka_unit_test(test_query_before_build),
        cmocka_unit_test(test_single_triangle),
        cmocka_unit_test(test_random_soup),
        cmocka_unit_test(test_grid),
        cmocka_unit_test(test_bunny),
        cmocka_unit_test(test_boxes),
        cmocka_unit_test(test_degenerate_scenes),
        cmocka_unit_test(test_deep_tree),
        cmocka_unit_test(test_layout_switch),
    };
    return cmocka_run_group_tests(tests, setup_group, teardown_group);
}
