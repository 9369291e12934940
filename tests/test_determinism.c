/*
 * Trees are bit-identical (nodes and primitive order) for 1, 2, 3 and 8
 * threads and from run to run, for every builder, through the public API;
 * and so are the answers to a fixed set of rays and the memory the handle
 * holds. Every builder: AAC-HQ, AAC-Fast, AAC with its own delta, c and
 * alpha, sweep and binned SAH, PLOC, and locally-ordered; and the opt-in
 * variants that make more than the binary tree (the WIDE4 traversal layout,
 * COPIED triangle storage, both), whose binary tree must also be the plain
 * build's.
 *
 * The scenes are big enough that every parallel phase really splits: bounds,
 * Morton codes, the AAC recursion, the layout, the wide collapse, the
 * triangle copy and refit on the bunny (69K triangles; a generated 100K grid
 * without it), and the radix sort, whose chunks hold at least 64K keys, in
 * AAC-Fast's build of a generated scene of more than 2 * 64K triangles.
 * Locally-ordered, the slowest builder, runs on a generated 40K grid. AAC
 * also runs on scenes of 3K and 12K triangles, whose recursion forks smaller
 * ranges than big scenes'.
 * Under the sanitizers the bunny's tests run on that 40K grid too: every
 * phase but the radix sort still splits there (their grains are at most
 * 32K triangles), and the radix sort splits on the 140K scene.
 */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <setjmp.h>
#include <string.h>
#include <cmocka.h>

#include <aacbvh/aacbvh.h>

#include "test_support.h"

/* Under ThreadSanitizer (every access checked, 10-15 times slower) the
 * comparison runs at 3 threads only (more threads than the CI's 2 cores):
 * the races it looks for need threads, not every count. Under
 * AddressSanitizer it compares 1 thread with 3 (the memory errors it looks
 * for are in the serial and the parallel paths). The Release stage compares
 * all four counts. */
#if TS_UNDER_TSAN
static const uint32_t kThreadCounts[] = {3};
#elif TS_UNDER_ASAN
static const uint32_t kThreadCounts[] = {1, 3};
#else
static const uint32_t kThreadCounts[] = {1, 2, 3, 8};
#endif
enum { kRayCount = TS_RAYS(4096) };

/* One way to build: a builder and the parameters that change what is made. */
typedef struct build_config {
    const char *name;
    int builder;
    int layout;          /* aacbvh_layout */
    int storage;         /* aacbvh_triangle_storage */
    int custom_aac;      /* 1: AACBVH_BUILDER_AAC with its own delta, c, alpha */
} build_config;

/* What a build gave, read through the public API. */
typedef struct build_result {
    ts_tree tree;
    aacbvh_hit hits[kRayCount];
    size_t ray_count;            /* rays traced, at most kRayCount */
    uint64_t memory_bytes;
} build_result;

static aacbvh_ray *make_rays(const ts_mesh *mesh, uint64_t seed) {
    aacbvh_ray *rays = (aacbvh_ray *)malloc(kRayCount * sizeof *rays);
    float lo[3], hi[3];
    ts_rng rng;
    assert_non_null(rays);
    ts_coords_bounds(mesh->vertices, 3 * mesh->vertex_count, lo, hi);
    ts_rng_seed(&rng, seed);
    for (size_t i = 0; i < kRayCount; ++i) {
        for (int a = 0; a < 3; ++a) {
            const float ext = hi[a] - lo[a] + 1.0f;
            const float target = ts_rng_range(&rng, lo[a], hi[a]);
            rays[i].org[a] = ts_rng_range(&rng, lo[a] - ext, hi[a] + ext);
            rays[i].dir[a] = target - rays[i].org[a];
        }
        rays[i].tmin = 0.0f;
        rays[i].tmax = INFINITY;
    }
    return rays;
}

static void build(uint32_t threads, const build_config *config, const ts_mesh *mesh, const aacbvh_ray *rays,
                  size_t ray_count, int refit, build_result *out) {
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(threads, &ctx, &bvh);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, config->builder), AACBVH_OK);
    if (config->custom_aac) {
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_AAC_DELTA, 8), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_C, 1.5), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_ALPHA, 0.35), AACBVH_OK);
    }
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, config->layout), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, config->storage), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh->vertices, mesh->vertex_count, 3 * sizeof(float),
                                              mesh->indices, mesh->triangle_count),
                     AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    if (refit) TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &out->tree), AACBVH_OK);
    assert_true(ray_count <= kRayCount);
    out->ray_count = ray_count;
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, rays, out->hits, ray_count), AACBVH_OK);
    out->memory_bytes = ts_memory_bytes(bvh);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
}

static size_t hit_count(const build_result *r) {
    size_t n = 0;
    for (size_t i = 0; i < r->ray_count; ++i) n += r->hits[i].prim_id != AACBVH_INVALID_ID;
    return n;
}

/* Builds with 1 thread, then with each thread count twice (the second time
 * refitted too), and compares everything with the 1-thread build. When
 * `plain` is given, the 1-thread binary tree must also equal it. The 1-thread
 * build is handed back in *kept when kept is not NULL (free its tree). */
static void check_config(const build_config *config, const ts_mesh *mesh, const aacbvh_ray *rays,
                         size_t ray_count, const build_result *plain, build_result *kept) {
    build_result *reference = (build_result *)calloc(1, sizeof *reference);
    build_result *other = (build_result *)calloc(1, sizeof *other);
    assert_non_null(reference);
    assert_non_null(other);
    build(1, config, mesh, rays, ray_count, 0, reference);
    /* The rays must test something: they aim at points inside the scene's bounds. */
    if (hit_count(reference) < ray_count / 4)
        fail_msg("%s: only %zu of %zu rays hit", config->name, hit_count(reference), ray_count);
    if (plain && !ts_tree_equal(&plain->tree, &reference->tree))
        fail_msg("%s: the binary tree differs from the plain build's", config->name);
    for (size_t t = 0; t < sizeof kThreadCounts / sizeof kThreadCounts[0]; ++t) {
        for (int run = 0; run < 2; ++run) {
            char msg[512];
            build(kThreadCounts[t], config, mesh, rays, ray_count, run == 1, other);
            if (!ts_tree_diff(&reference->tree, &other->tree, msg, sizeof msg))
                fail_msg("%s: tree with %u threads (run %d) differs from the 1-thread tree: %s", config->name,
                         kThreadCounts[t], run, msg);
            if (memcmp(reference->hits, other->hits, ray_count * sizeof reference->hits[0]) != 0)
                fail_msg("%s: hits with %u threads (run %d) differ from the 1-thread hits", config->name,
                         kThreadCounts[t], run);
            if (other->memory_bytes != reference->memory_bytes)
                fail_msg("%s: %llu bytes held with %u threads (run %d), %llu with 1", config->name,
                         (unsigned long long)other->memory_bytes, kThreadCounts[t], run,
                         (unsigned long long)reference->memory_bytes);
            ts_tree_free(&other->tree);
        }
    }
    if (kept)
        *kept = *reference;
    else
        ts_tree_free(&reference->tree);
    free(reference);
    free(other);
}

static void check_builder(const char *name, int builder, const ts_mesh *mesh, const aacbvh_ray *rays,
                          size_t ray_count) {
    const build_config config = {name, builder, AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED, 0};
    check_config(&config, mesh, rays, ray_count, NULL, NULL);
}

static void load_scene(ts_mesh *mesh) {
    if (TS_UNDER_SANITIZER) {
        assert_true(ts_make_scene(TS_SCENE_GRID, 40000, 7, mesh));
        return;
    }
    if (!ts_load_scene("bunny.obj", mesh)) {
        print_message("note: bunny.obj not found, using a generated grid scene\n");
        assert_true(ts_make_scene(TS_SCENE_GRID, 100000, 7, mesh));
    }
}

/* More than 2 * 64K triangles: the radix sort works in two chunks or more. */
static void make_large_scene(ts_mesh *mesh) {
    assert_true(ts_make_scene(TS_SCENE_GRID, 140000, 7, mesh));
    assert_true(mesh->triangle_count >= 2 * 65536);
}

static void test_aac_deterministic(void **state) {
    (void)state;
    ts_mesh mesh = {0};
    load_scene(&mesh);
    aacbvh_ray *rays = make_rays(&mesh, 11);
    check_builder("AAC-HQ", AACBVH_BUILDER_AAC_HQ, &mesh, rays, kRayCount);
    {
        const build_config custom = {"AAC (delta 8, c 1.5, alpha 0.35)", AACBVH_BUILDER_AAC,
                                     AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED, 1};
        check_config(&custom, &mesh, rays, kRayCount, NULL, NULL);
    }
    free(rays);
    ts_mesh_free(&mesh);

    /* The radix sort splits only here. */
    make_large_scene(&mesh);
    rays = make_rays(&mesh, 16);
    check_builder("AAC-Fast", AACBVH_BUILDER_AAC_FAST, &mesh, rays, kRayCount);
    free(rays);
    ts_mesh_free(&mesh);
}

static void test_reference_builders_deterministic(void **state) {
    (void)state;
    ts_mesh mesh = {0};
    load_scene(&mesh);
    aacbvh_ray *rays = make_rays(&mesh, 12);
    check_builder("binned SAH", AACBVH_BUILDER_BINNED_SAH, &mesh, rays, kRayCount);
    check_builder("sweep SAH", AACBVH_BUILDER_SWEEP_SAH, &mesh, rays, kRayCount);
    check_builder("PLOC", AACBVH_BUILDER_PLOC, &mesh, rays, kRayCount);
    free(rays);
    ts_mesh_free(&mesh);
}

static void test_locally_ordered_deterministic(void **state) {
    (void)state;
    /* Exact clustering is the slowest builder: a smaller scene, on which the
     * bounds and the layout still split; the radix sort it shares with AAC
     * splits in test_aac_deterministic. */
    ts_mesh mesh = {0};
    assert_true(ts_make_scene(TS_SCENE_GRID, 40000, 5, &mesh));
    aacbvh_ray *rays = make_rays(&mesh, 13);
    check_builder("locally-ordered", AACBVH_BUILDER_LOCALLY_ORDERED, &mesh, rays, kRayCount);
    free(rays);
    ts_mesh_free(&mesh);
}

static void test_layout_and_storage_variants_deterministic(void **state) {
    (void)state;
    const build_config plain_config = {"AAC-Fast", AACBVH_BUILDER_AAC_FAST, AACBVH_LAYOUT_BINARY,
                                       AACBVH_TRIANGLES_REFERENCED, 0};
    const build_config variants[] = {
        {"AAC-Fast, WIDE4", AACBVH_BUILDER_AAC_FAST, AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_REFERENCED, 0},
        {"AAC-Fast, COPIED", AACBVH_BUILDER_AAC_FAST, AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_COPIED, 0},
        {"AAC-Fast, WIDE4 and COPIED", AACBVH_BUILDER_AAC_FAST, AACBVH_LAYOUT_WIDE4, AACBVH_TRIANGLES_COPIED, 0},
        {"AAC-Fast, WIDE8", AACBVH_BUILDER_AAC_FAST, AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_REFERENCED, 0},
        {"AAC-Fast, WIDE8 and COPIED", AACBVH_BUILDER_AAC_FAST, AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_COPIED, 0},
    };
    ts_mesh mesh = {0};
    build_result *plain = (build_result *)calloc(1, sizeof *plain);
    assert_non_null(plain);
    load_scene(&mesh);
    aacbvh_ray *rays = make_rays(&mesh, 14);
    build(1, &plain_config, &mesh, rays, kRayCount, 0, plain);
    for (size_t v = 0; v < sizeof variants / sizeof variants[0]; ++v) {
        build_result *r = (build_result *)calloc(1, sizeof *r);
        assert_non_null(r);
        check_config(&variants[v], &mesh, rays, kRayCount, plain, r);
        /* Same answers as the binary layout over the caller's triangles. */
        for (size_t i = 0; i < kRayCount; ++i)
            if (r->hits[i].t != plain->hits[i].t || r->hits[i].u != plain->hits[i].u ||
                r->hits[i].v != plain->hits[i].v)
                fail_msg("%s: ray %zu hits at t = %g, the plain build at t = %g", variants[v].name, i,
                         (double)r->hits[i].t, (double)plain->hits[i].t);
        /* The variants make more than the binary tree, and say so. */
        if (r->memory_bytes <= plain->memory_bytes)
            fail_msg("%s holds %llu bytes, no more than the plain build's %llu", variants[v].name,
                     (unsigned long long)r->memory_bytes, (unsigned long long)plain->memory_bytes);
        ts_tree_free(&r->tree);
        free(r);
    }
    ts_tree_free(&plain->tree);
    free(plain);
    free(rays);
    ts_mesh_free(&mesh);
}

static void test_small_scenes_deterministic(void **state) {
    (void)state;
    /* Under 16K triangles the AAC recursion forks ranges of a quarter of the
     * scene (down to 1,024) instead of 4,096 and more: scenes of 3,000 and
     * 12,000 triangles fork at two levels or more. */
    static const size_t kSizes[] = {3000, 12000};
    for (size_t i = 0; i < sizeof kSizes / sizeof kSizes[0]; ++i) {
        ts_mesh mesh = {0};
        assert_true(ts_make_scene(TS_SCENE_GRID, kSizes[i], 9 + (unsigned)i, &mesh));
        assert_true(mesh.triangle_count < 16384);
        aacbvh_ray *rays = make_rays(&mesh, 17 + (unsigned)i);
        check_builder("AAC-HQ, small scene", AACBVH_BUILDER_AAC_HQ, &mesh, rays, kRayCount);
        check_builder("AAC-Fast, small scene", AACBVH_BUILDER_AAC_FAST, &mesh, rays, kRayCount);
        free(rays);
        ts_mesh_free(&mesh);
    }
}

static void test_degenerate_scene_deterministic(void **state) {
    (void)state;
    /* Equal Morton codes everywhere: the middle splits must not depend on timing. */
    ts_mesh mesh = {0};
    assert_true(ts_make_scene(TS_SCENE_SAME_CENTROID, 70000, 3, &mesh));
    aacbvh_ray *rays = make_rays(&mesh, 15);
    /* Every ray meets most of the 70K overlapping triangles: a few rays suffice. */
    check_builder("AAC-Fast, same centroids", AACBVH_BUILDER_AAC_FAST, &mesh, rays, 64);
    free(rays);
    ts_mesh_free(&mesh);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_aac_deterministic),
        cmocka_unit_test(test_reference_builders_deterministic),
        cmocka_unit_test(test_locally_ordered_deterministic),
        cmocka_unit_test(test_layout_and_storage_variants_deterministic),
        cmocka_unit_test(test_small_scenes_deterministic),
        cmocka_unit_test(test_degenerate_scene_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
