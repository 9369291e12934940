/* The progress callback: the fractions it sees, and cancelling at several
 * points of a build with every builder, which must return
 * AACBVH_ERROR_CANCELLED, keep the previous tree answering rays exactly as
 * before, and leave the handle ready for a later build that succeeds. (Leaks
 * of cancelled builds are caught by the AddressSanitizer stage.) */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>

#include "test_support.h"

#define MAX_CALLS 100000
#define RAY_COUNT 4096

static const aacbvh_builder k_builders[] = {
    AACBVH_BUILDER_AAC_HQ,     AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_SWEEP_SAH,
    AACBVH_BUILDER_BINNED_SAH, AACBVH_BUILDER_PLOC,     AACBVH_BUILDER_LOCALLY_ORDERED,
};
#define BUILDER_COUNT (sizeof k_builders / sizeof k_builders[0])

static const char *builder_name(aacbvh_builder b) {
    switch (b) {
    case AACBVH_BUILDER_AAC_HQ: return "aac-hq";
    case AACBVH_BUILDER_AAC_FAST: return "aac-fast";
    case AACBVH_BUILDER_AAC: return "aac";
    case AACBVH_BUILDER_SWEEP_SAH: return "sweep-sah";
    case AACBVH_BUILDER_BINNED_SAH: return "binned-sah";
    case AACBVH_BUILDER_LOCALLY_ORDERED: return "locally-ordered";
    case AACBVH_BUILDER_PLOC: return "ploc";
    default: return "?";
    }
}

static double now_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* When the recorder's callback answers false. */
typedef enum cancel_rule {
    CANCEL_NEVER = 0,
    CANCEL_FIRST_CALL = 1, /* the very first call (fraction 0) */
    CANCEL_IN_BUILDER = 2, /* the first call after the one reporting 0.1 (input ready) */
    CANCEL_AT_FRACTION = 3 /* the first call with fraction >= at */
} cancel_rule;

/* Everything the callback saw. */
typedef struct recorder {
    cancel_rule rule;
    double at;
    size_t calls;
    double fractions[MAX_CALLS];
    double times[MAX_CALLS];
    size_t cancel_call; /* index of the call that answered false, or MAX_CALLS */
    size_t calls_after_cancel;
    bool input_ready;
} recorder;

static recorder g_rec; /* large: static, not on the stack */
static double g_build_returned; /* when the last expect_cancelled() build returned */

static void recorder_reset(recorder *r, cancel_rule rule, double at) {
    r->rule = rule;
    r->at = at;
    r->calls = 0;
    r->cancel_call = MAX_CALLS;
    r->calls_after_cancel = 0;
    r->input_ready = false;
}

static bool record(void *user, double fraction) {
    recorder *r = (recorder *)user;
    bool go_on = true;
    if (r->cancel_call != MAX_CALLS) {
        ++r->calls_after_cancel;
        return false;
    }
    if (r->calls < MAX_CALLS) {
        r->fractions[r->calls] = fraction;
        r->times[r->calls] = now_seconds();
    }
    switch (r->rule) {
    case CANCEL_NEVER: break;
    case CANCEL_FIRST_CALL: go_on = false; break;
    case CANCEL_IN_BUILDER: go_on = !r->input_ready; break;
    case CANCEL_AT_FRACTION: go_on = !(fraction >= r->at); break;
    }
    if (fraction >= 0.1) r->input_ready = true;
    if (!go_on) r->cancel_call = r->calls;
    ++r->calls;
    return go_on;
}

/* Fractions lie in [0, 1] and never decrease. */
static void check_fractions(const recorder *r, const char *what) {
    size_t n = r->calls < MAX_CALLS ? r->calls : MAX_CALLS;
    for (size_t i = 0; i < n; ++i) {
        double f = r->fractions[i];
        if (!(f >= 0.0 && f <= 1.0)) fail_msg("%s: call %zu reported fraction %g", what, i, f);
        if (i > 0 && f < r->fractions[i - 1])
            fail_msg("%s: fraction went down from %g to %g at call %zu", what, r->fractions[i - 1], f, i);
    }
}

static aacbvh_ray *make_rays(const ts_mesh *mesh, size_t count, uint64_t seed) {
    aacbvh_ray *rays = (aacbvh_ray *)malloc(count * sizeof *rays);
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    ts_rng rng;
    assert_non_null(rays);
    for (size_t v = 0; v < mesh->vertex_count; ++v)
        for (int a = 0; a < 3; ++a) {
            lo[a] = fminf(lo[a], mesh->vertices[3 * v + a]);
            hi[a] = fmaxf(hi[a], mesh->vertices[3 * v + a]);
        }
    ts_rng_seed(&rng, seed);
    for (size_t i = 0; i < count; ++i) {
        for (int a = 0; a < 3; ++a) {
            float ext = hi[a] - lo[a] + 1.0f;
            float target = ts_rng_range(&rng, lo[a], hi[a]);
            rays[i].org[a] = ts_rng_range(&rng, lo[a] - ext, hi[a] + ext);
            rays[i].dir[a] = target - rays[i].org[a];
        }
        rays[i].tmin = 0.0f;
        rays[i].tmax = INFINITY;
    }
    return rays;
}

/* A BVH built over `mesh` with AAC-Fast, the hits of `rays` in it, and its tree. */
typedef struct fixture {
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_mesh mesh;
    aacbvh_ray *rays;
    aacbvh_hit *hits;
    ts_tree tree;
} fixture;

static void fixture_init(fixture *f, ts_scene_kind kind, size_t triangles, uint64_t seed) {
    memset(f, 0, sizeof *f);
    ts_create(2, &f->ctx, &f->bvh);
    assert_true(ts_make_scene(kind, triangles, seed, &f->mesh));
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(f->bvh, f->mesh.vertices, f->mesh.vertex_count, 12,
                                              f->mesh.indices, f->mesh.triangle_count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(f->bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(f->bvh), AACBVH_OK);
    f->rays = make_rays(&f->mesh, RAY_COUNT, seed + 1);
    f->hits = (aacbvh_hit *)malloc(RAY_COUNT * sizeof *f->hits);
    assert_non_null(f->hits);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(f->bvh, f->rays, f->hits, RAY_COUNT), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(f->bvh, &f->tree), AACBVH_OK);
}

static void fixture_free(fixture *f) {
    ts_tree_free(&f->tree);
    free(f->hits);
    free(f->rays);
    ts_mesh_free(&f->mesh);
    aacbvh_bvh_destroy(f->bvh);
    aacbvh_context_destroy(f->ctx);
}

/* The tree is the one built by fixture_init: same nodes, same stats, and
 * every ray's hit bit for bit the same. */
static void expect_old_tree(const fixture *f, const char *what) {
    ts_tree now;
    aacbvh_hit *hits = (aacbvh_hit *)malloc(RAY_COUNT * sizeof *hits);
    assert_non_null(hits);
    TS_EXPECT_STATUS(ts_tree_fetch(f->bvh, &now), AACBVH_OK);
    if (!ts_tree_equal(&f->tree, &now)) fail_msg("%s: the tree changed", what);
    if (now.stats.memory_bytes != f->tree.stats.memory_bytes || now.stats.sah_cost != f->tree.stats.sah_cost ||
        now.stats.built_sah_cost != f->tree.stats.built_sah_cost)
        fail_msg("%s: the stats changed", what);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(f->bvh, f->rays, hits, RAY_COUNT), AACBVH_OK);
    if (memcmp(hits, f->hits, RAY_COUNT * sizeof *hits) != 0) fail_msg("%s: the old tree answers rays differently", what);
    ts_tree_free(&now);
    free(hits);
}

/* A cancelled build: CANCELLED, a message, no call after the cancelling one,
 * fractions in order, the old tree intact. */
static void expect_cancelled(fixture *f, const char *what) {
    aacbvh_status status;
    TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(f->bvh, record, &g_rec), AACBVH_OK);
    status = aacbvh_bvh_build(f->bvh);
    g_build_returned = now_seconds();
    if (status != AACBVH_ERROR_CANCELLED)
        fail_msg("%s: build returned %s, expected AACBVH_ERROR_CANCELLED", what, aacbvh_status_string(status));
    if (g_rec.cancel_call == MAX_CALLS) fail_msg("%s: the callback never cancelled", what);
    if (g_rec.calls_after_cancel != 0)
        fail_msg("%s: %zu calls after the callback returned false", what, g_rec.calls_after_cancel);
    if (strlen(aacbvh_bvh_last_error(f->bvh)) == 0) fail_msg("%s: empty last_error", what);
    check_fractions(&g_rec, what);
    expect_old_tree(f, what);
}

static void test_fractions_on_success(void **state) {
    fixture f;
    char what[128];
    (void)state;
    fixture_init(&f, TS_SCENE_RANDOM, 20000, 11);
    for (size_t b = 0; b < BUILDER_COUNT; ++b) {
        snprintf(what, sizeof what, "%s, 20K triangles", builder_name(k_builders[b]));
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(f.bvh, AACBVH_PARAM_BUILDER, k_builders[b]), AACBVH_OK);
        recorder_reset(&g_rec, CANCEL_NEVER, 0.0);
        TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(f.bvh, record, &g_rec), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(f.bvh), AACBVH_OK);
        if (g_rec.calls < 2) fail_msg("%s: %zu progress calls", what, g_rec.calls);
        check_fractions(&g_rec, what);
        if (g_rec.fractions[0] != 0.0) fail_msg("%s: first fraction %g, not 0", what, g_rec.fractions[0]);
        if (g_rec.calls <= MAX_CALLS && g_rec.fractions[g_rec.calls - 1] != 1.0)
            fail_msg("%s: last fraction %g, not 1", what, g_rec.fractions[g_rec.calls - 1]);
    }
    /* An empty scene reports 0 and 1 too. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(f.bvh, NULL, 0, 12, NULL, 0), AACBVH_OK);
    recorder_reset(&g_rec, CANCEL_NEVER, 0.0);
    TS_EXPECT_STATUS(aacbvh_bvh_build(f.bvh), AACBVH_OK);
    assert_true(g_rec.calls >= 2);
    assert_true(g_rec.fractions[0] == 0.0 && g_rec.fractions[g_rec.calls - 1] == 1.0);
    /* Removing the callback: builds no longer call it. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(f.bvh, NULL, NULL), AACBVH_OK);
    recorder_reset(&g_rec, CANCEL_NEVER, 0.0);
    TS_EXPECT_STATUS(aacbvh_bvh_build(f.bvh), AACBVH_OK);
    assert_int_equal(g_rec.calls, 0);
    fixture_free(&f);
}

/* Every builder cancelled at the first call, in the builder, at 0.8 (tree
 * made, not yet flattened) and at 1.0 (the build's last call): each time the
 * old tree stays. Then a build without cancelling succeeds. */
static void test_cancel_points(void **state) {
    static const struct { cancel_rule rule; double at; const char *name; } points[] = {
        {CANCEL_FIRST_CALL, 0.0, "first call"},
        {CANCEL_IN_BUILDER, 0.0, "in the builder"},
        {CANCEL_AT_FRACTION, 0.8, "at 0.8"},
        {CANCEL_AT_FRACTION, 1.0, "at 1.0"},
    };
    fixture f;
    char what[128];
    (void)state;
    fixture_init(&f, TS_SCENE_RANDOM, 20000, 21);
    for (size_t b = 0; b < BUILDER_COUNT; ++b) {
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(f.bvh, AACBVH_PARAM_BUILDER, k_builders[b]), AACBVH_OK);
        for (size_t p = 0; p < sizeof points / sizeof points[0]; ++p) {
            snprintf(what, sizeof what, "%s, cancelled %s", builder_name(k_builders[b]), points[p].name);
            recorder_reset(&g_rec, points[p].rule, points[p].at);
            expect_cancelled(&f, what);
            if (points[p].rule == CANCEL_FIRST_CALL && g_rec.calls != 1)
                fail_msg("%s: %zu calls", what, g_rec.calls);
        }
    }
    /* A later build succeeds and replaces the tree. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(f.bvh, NULL, NULL), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(f.bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_SWEEP_SAH), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(f.bvh), AACBVH_OK);
    {
        ts_tree now;
        TS_EXPECT_STATUS(ts_tree_fetch(f.bvh, &now), AACBVH_OK);
        assert_false(ts_tree_equal(&f.tree, &now));
        assert_int_equal(now.stats.primitive_count, f.mesh.triangle_count);
        ts_tree_free(&now);
    }
    fixture_free(&f);
}

/* A large scene (about 200 K triangles; 100 K under ThreadSanitizer, where
 * its builds and checks took 9 s and every phase still splits into tasks):
 * each builder cancelled at its first progress call after the input is
 * ready. Prints how far the build had come and how long the callback went
 * without being called, which bounds how quickly a long build can be
 * cancelled. */
static void test_cancel_large_scene(void **state) {
    fixture f;
    char what[128];
    (void)state;
    fixture_init(&f, TS_SCENE_GRID, TS_UNDER_TSAN ? 100000 : 200000, 31);
    print_message("scene: %zu triangles\n", f.mesh.triangle_count);
    for (size_t b = 0; b < BUILDER_COUNT; ++b) {
        double start, cancelled_at;
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(f.bvh, AACBVH_PARAM_BUILDER, k_builders[b]), AACBVH_OK);
        snprintf(what, sizeof what, "%s, %zuK triangles, cancelled in the builder", builder_name(k_builders[b]),
                 f.mesh.triangle_count / 1000);
        recorder_reset(&g_rec, CANCEL_IN_BUILDER, 0.0);
        start = now_seconds();
        expect_cancelled(&f, what);
        cancelled_at = g_rec.times[g_rec.cancel_call];
        print_message("%-16s cancelled at call %zu (fraction %.2f), %.1f ms into the build; "
                      "build returned %.1f ms later (old tree checked after)\n",
                      builder_name(k_builders[b]), g_rec.cancel_call + 1, g_rec.fractions[g_rec.cancel_call],
                      1e3 * (cancelled_at - start), 1e3 * (g_build_returned - cancelled_at));
    }
    TS_EXPECT_STATUS(aacbvh_bvh_set_progress_callback(f.bvh, NULL, NULL), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(f.bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_HQ), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(f.bvh), AACBVH_OK);
    fixture_free(&f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fractions_on_success),
        cmocka_unit_test(test_cancel_points),
        cmocka_unit_test(test_cancel_large_scene),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
