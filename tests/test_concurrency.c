/*
 * Concurrency through the public API, as applications use it:
 * - several application threads build their own BVHs at once on one shared
 *   context (its worker pool), and each tree equals the one built alone;
 * - several threads query one built BVH at once (intersect, occluded,
 *   get_stats, get_nodes), and every answer equals the single-threaded one;
 * - threads whose calls fail on one BVH each read their own message.
 * The suite also runs under ThreadSanitizer, which checks the same calls for
 * data races.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <string.h>
#include <math.h>
#include <pthread.h>
#include <cmocka.h>

#include <aacbvh/aacbvh.h>

#include "test_support.h"

enum { kThreads = 4, kRays = 4096 };

typedef struct build_job {
    aacbvh_context *ctx;
    const ts_mesh *mesh;
    int builder;
    ts_tree tree;
    aacbvh_status status;
} build_job;

static aacbvh_status build_tree(aacbvh_context *ctx, const ts_mesh *mesh, int builder, ts_tree *out) {
    aacbvh_bvh *bvh = NULL;
    aacbvh_status s = aacbvh_bvh_create(ctx, &bvh);
    if (s == AACBVH_OK) s = aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder);
    if (s == AACBVH_OK)
        s = aacbvh_bvh_set_triangles(bvh, mesh->vertices, mesh->vertex_count, 3 * sizeof(float), mesh->indices,
                                     mesh->triangle_count);
    if (s == AACBVH_OK) s = aacbvh_bvh_build(bvh);
    if (s == AACBVH_OK) s = ts_tree_fetch(bvh, out);
    aacbvh_bvh_destroy(bvh);
    return s;
}

static void *build_thread(void *arg) {
    build_job *job = (build_job *)arg;
    job->status = build_tree(job->ctx, job->mesh, job->builder, &job->tree);
    return NULL;
}

static void test_concurrent_builds_on_one_context(void **state) {
    (void)state;
    ts_mesh mesh = {0};
    assert_true(ts_make_scene(TS_SCENE_GRID, 60000, 11, &mesh));
    const int builders[kThreads] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_BINNED_SAH,
                                    AACBVH_BUILDER_PLOC};
    aacbvh_context *ctx;
    TS_EXPECT_STATUS(aacbvh_context_create(2, &ctx), AACBVH_OK);

    for (int round = 0; round < 2; ++round) {
        build_job jobs[kThreads];
        pthread_t threads[kThreads];
        for (int i = 0; i < kThreads; ++i) {
            memset(&jobs[i], 0, sizeof jobs[i]);
            jobs[i].ctx = ctx;
            jobs[i].mesh = &mesh;
            jobs[i].builder = builders[i];
            assert_int_equal(pthread_create(&threads[i], NULL, build_thread, &jobs[i]), 0);
        }
        for (int i = 0; i < kThreads; ++i) assert_int_equal(pthread_join(threads[i], NULL), 0);
        for (int i = 0; i < kThreads; ++i) {
            TS_EXPECT_STATUS(jobs[i].status, AACBVH_OK);
            ts_tree alone;
            TS_EXPECT_STATUS(build_tree(ctx, &mesh, builders[i], &alone), AACBVH_OK);
            if (!ts_tree_equal(&alone, &jobs[i].tree))
                fail_msg("builder %d: the tree built beside other builds differs from the one built alone",
                         builders[i]);
            ts_tree_free(&alone);
            ts_tree_free(&jobs[i].tree);
        }
    }
    aacbvh_context_destroy(ctx);
    ts_mesh_free(&mesh);
}

typedef struct query_job {
    const aacbvh_bvh *bvh;
    const aacbvh_ray *rays;
    aacbvh_hit hits[kRays];
    uint8_t occluded[kRays];
    aacbvh_stats stats;
    aacbvh_node root;
    int failed;
} query_job;

static void *query_thread(void *arg) {
    query_job *job = (query_job *)arg;
    job->stats.struct_size = sizeof job->stats;
    for (int repeat = 0; repeat < 3; ++repeat) {
        if (aacbvh_bvh_intersect(job->bvh, job->rays, job->hits, kRays) != AACBVH_OK ||
            aacbvh_bvh_occluded(job->bvh, job->rays, job->occluded, kRays) != AACBVH_OK ||
            aacbvh_bvh_get_stats(job->bvh, &job->stats) != AACBVH_OK ||
            aacbvh_bvh_get_nodes(job->bvh, 0, 1, &job->root) != AACBVH_OK)
            job->failed = 1;
    }
    return NULL;
}

static void check_concurrent_queries(int layout) {
    ts_mesh mesh = {0};
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 20000, 5, &mesh));
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(2, &ctx, &bvh);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 3 * sizeof(float),
                                              mesh.indices, mesh.triangle_count),
                     AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);

    static aacbvh_ray rays[kRays];
    ts_rng rng;
    ts_rng_seed(&rng, 99);
    for (int i = 0; i < kRays; ++i) {
        for (int k = 0; k < 3; ++k) {
            rays[i].org[k] = ts_rng_range(&rng, -1.5f, 1.5f);
            rays[i].dir[k] = ts_rng_range(&rng, -1.0f, 1.0f);
        }
        rays[i].tmin = 0.0f;
        rays[i].tmax = (i % 3 == 0) ? 0.5f : INFINITY;
    }

    static query_job reference, jobs[kThreads];
    memset(&reference, 0, sizeof reference);
    reference.bvh = bvh;
    reference.rays = rays;
    query_thread(&reference);
    assert_false(reference.failed);

    pthread_t threads[kThreads];
    for (int i = 0; i < kThreads; ++i) {
        memset(&jobs[i], 0, sizeof jobs[i]);
        jobs[i].bvh = bvh;
        jobs[i].rays = rays;
        assert_int_equal(pthread_create(&threads[i], NULL, query_thread, &jobs[i]), 0);
    }
    for (int i = 0; i < kThreads; ++i) assert_int_equal(pthread_join(threads[i], NULL), 0);
    for (int i = 0; i < kThreads; ++i) {
        assert_false(jobs[i].failed);
        assert_memory_equal(jobs[i].hits, reference.hits, sizeof reference.hits);
        assert_memory_equal(jobs[i].occluded, reference.occluded, sizeof reference.occluded);
        assert_memory_equal(&jobs[i].root, &reference.root, sizeof reference.root);
        assert_int_equal(jobs[i].stats.node_count, reference.stats.node_count);
        assert_true(jobs[i].stats.sah_cost == reference.stats.sah_cost);
    }
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    ts_mesh_free(&mesh);
}

static void test_concurrent_queries_binary(void **state) {
    (void)state;
    check_concurrent_queries(AACBVH_LAYOUT_BINARY);
}

static void test_concurrent_queries_wide4(void **state) {
    (void)state;
    check_concurrent_queries(AACBVH_LAYOUT_WIDE4);
}

static void test_concurrent_queries_wide8(void **state) {
    (void)state;
    check_concurrent_queries(AACBVH_LAYOUT_WIDE8);
}

/* A build's peak memory is its own, also while another application thread
 * builds on the same context and the two threads run each other's tasks:
 * the sweep builder allocates its sort keys inside forked tasks. */
typedef struct sweep_job {
    aacbvh_context *ctx;
    const ts_mesh *mesh;
    pthread_mutex_t mutex;
    int stop; /* under mutex */
    int builds;
} sweep_job;

static int sweep_should_stop(sweep_job *job) {
    pthread_mutex_lock(&job->mutex);
    const int stop = job->stop;
    pthread_mutex_unlock(&job->mutex);
    return stop;
}

static void *sweep_thread(void *arg) {
    sweep_job *job = (sweep_job *)arg;
    aacbvh_bvh *bvh = NULL;
    if (aacbvh_bvh_create(job->ctx, &bvh) != AACBVH_OK) return NULL;
    aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_SWEEP_SAH);
    aacbvh_bvh_set_triangles(bvh, job->mesh->vertices, job->mesh->vertex_count, 3 * sizeof(float),
                             job->mesh->indices, job->mesh->triangle_count);
    while (!sweep_should_stop(job) && aacbvh_bvh_build(bvh) == AACBVH_OK) ++job->builds;
    aacbvh_bvh_destroy(bvh);
    return NULL;
}

static uint64_t peak_of_build(aacbvh_bvh *bvh) {
    aacbvh_stats stats;
    stats.struct_size = sizeof stats;
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &stats), AACBVH_OK);
    return stats.build_peak_bytes;
}

static void test_peak_is_the_builds_own(void **state) {
    (void)state;
    ts_mesh mine = {0}, other = {0};
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    sweep_job job;
    pthread_t thread;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 40000, 41, &mine));
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 150000, 42, &other));
    ts_create(2, &ctx, &bvh);
    /* Binned SAH allocates on the building thread only: its peak is fixed. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_BINNED_SAH), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mine.vertices, mine.vertex_count, 3 * sizeof(float), mine.indices,
                                              mine.triangle_count),
                     AACBVH_OK);
    const uint64_t alone = peak_of_build(bvh);
    job.ctx = ctx;
    job.mesh = &other;
    job.stop = 0;
    job.builds = 0;
    assert_int_equal(pthread_mutex_init(&job.mutex, NULL), 0);
    assert_int_equal(pthread_create(&thread, NULL, sweep_thread, &job), 0);
    /* Under ThreadSanitizer, 10 builds (each one 10-15 times slower). */
    for (int i = 0; i < (TS_UNDER_TSAN ? 10 : 30); ++i) {
        const uint64_t p = peak_of_build(bvh);
        if (p != alone)
            fail_msg("build %d beside a sweep build: peak %llu bytes, alone %llu", i, (unsigned long long)p,
                     (unsigned long long)alone);
    }
    pthread_mutex_lock(&job.mutex);
    job.stop = 1;
    pthread_mutex_unlock(&job.mutex);
    assert_int_equal(pthread_join(thread, NULL), 0);
    pthread_mutex_destroy(&job.mutex);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    ts_mesh_free(&mine);
    ts_mesh_free(&other);
}

/* Each thread reads the message of its own last failure on a shared handle. */
typedef struct error_job {
    aacbvh_bvh *bvh;
    int kind; /* 0: intersect with NULL rays, 1: a node range past the end */
    int wrong;
} error_job;

static void *error_thread(void *arg) {
    error_job *job = (error_job *)arg;
    aacbvh_hit hit;
    aacbvh_node node;
    const char *want = job->kind == 0 ? "rays or hits is NULL" : "node range";
    for (int i = 0; i < 3000; ++i) {
        const aacbvh_status s = job->kind == 0 ? aacbvh_bvh_intersect(job->bvh, NULL, &hit, 1)
                                               : aacbvh_bvh_get_nodes(job->bvh, (size_t)1 << 40, 1, &node);
        if (s != AACBVH_ERROR_INVALID_ARGUMENT || !strstr(aacbvh_bvh_last_error(job->bvh), want)) ++job->wrong;
    }
    return NULL;
}

static void test_errors_are_per_thread(void **state) {
    (void)state;
    ts_mesh mesh = {0};
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 500, 3, &mesh));
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(2, &ctx, &bvh);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 3 * sizeof(float),
                                              mesh.indices, mesh.triangle_count),
                     AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    assert_string_equal(aacbvh_bvh_last_error(bvh), ""); /* nothing failed on this thread */
    error_job jobs[kThreads];
    pthread_t threads[kThreads];
    for (int i = 0; i < kThreads; ++i) {
        jobs[i].bvh = bvh;
        jobs[i].kind = i % 2;
        jobs[i].wrong = 0;
        assert_int_equal(pthread_create(&threads[i], NULL, error_thread, &jobs[i]), 0);
    }
    for (int i = 0; i < kThreads; ++i) assert_int_equal(pthread_join(threads[i], NULL), 0);
    for (int i = 0; i < kThreads; ++i)
        if (jobs[i].wrong) fail_msg("thread %d read another thread's message %d times", i, jobs[i].wrong);
    assert_string_equal(aacbvh_bvh_last_error(bvh), ""); /* still nothing failed on this thread */
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    ts_mesh_free(&mesh);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_concurrent_builds_on_one_context),
        cmocka_unit_test(test_concurrent_queries_binary),
        cmocka_unit_test(test_concurrent_queries_wide4),
        cmocka_unit_test(test_concurrent_queries_wide8),
        cmocka_unit_test(test_errors_are_per_thread),
        cmocka_unit_test(test_peak_is_the_builds_own),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
