/* With f(n) = n (c = 1, alpha = 1) AAC is exact agglomerative clustering
 * (Gu et al. 2013): its tree must have the same clusters as a naive greedy
 * reference that repeatedly merges the pair whose union box has the smallest
 * surface area. The exact builders (locally ordered; PLOC with a radius
 * covering every cluster) must agree too, and the AAC presets must stay
 * within a sane factor of the exact tree's SAH cost. */
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

#define MAX_N 200
#define WORDS ((MAX_N + 63) / 64)

typedef struct cluster_set {
    uint64_t bits[WORDS];
} cluster_set;

static int cmp_sets(const void *a, const void *b) {
    return memcmp(a, b, sizeof(cluster_set));
}

/* Surface area of the union of two boxes, in double. */
static double union_area(const float *a, const float *b) {
    double d[3];
    int k;
    for (k = 0; k < 3; ++k) {
        float lo = a[k] < b[k] ? a[k] : b[k];
        float hi = a[3 + k] > b[3 + k] ? a[3 + k] : b[3 + k];
        d[k] = (double)hi - (double)lo;
    }
    return 2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
}

/*
 * Greedy agglomerative clustering, O(n^3) with a distance matrix: out gets
 * the n - 1 merged clusters. Returns 0 when some step's best pair was not
 * clearly the best (a near tie, where float rounding in the library may
 * legitimately choose differently), else 1.
 */
static int reference_clusters(const float *boxes, size_t n, cluster_set *out) {
    float (*box)[6] = malloc(n * sizeof *box);
    double *dist = malloc(n * n * sizeof *dist);
    unsigned char *alive = malloc(n);
    cluster_set *sets = calloc(n, sizeof *sets);
    size_t i, j, step;
    int clear = 1;
    assert_non_null(box);
    assert_non_null(dist);
    assert_non_null(alive);
    assert_non_null(sets);
    for (i = 0; i < n; ++i) {
        memcpy(box[i], boxes + 6 * i, sizeof box[i]);
        alive[i] = 1;
        sets[i].bits[i / 64] |= (uint64_t)1 << (i % 64);
    }
    for (i = 0; i < n; ++i)
        for (j = i + 1; j < n; ++j) dist[i * n + j] = union_area(box[i], box[j]);
    for (step = 0; step + 1 < n; ++step) {
        double best = INFINITY, second = INFINITY;
        size_t bi = 0, bj = 0, w;
        int k;
        for (i = 0; i < n; ++i) {
            if (!alive[i]) continue;
            for (j = i + 1; j < n; ++j) {
                double d;
                if (!alive[j]) continue;
                d = dist[i * n + j];
                if (d < best) {
                    second = best;
                    best = d;
                    bi = i;
                    bj = j;
                } else if (d < second) {
                    second = d;
                }
            }
        }
        if (second - best <= 1e-5 * best) clear = 0;
        /* Merge bj into bi. */
        for (k = 0; k < 3; ++k) {
            if (box[bj][k] < box[bi][k]) box[bi][k] = box[bj][k];
            if (box[bj][3 + k] > box[bi][3 + k]) box[bi][3 + k] = box[bj][3 + k];
        }
        for (w = 0; w < WORDS; ++w) sets[bi].bits[w] |= sets[bj].bits[w];
        alive[bj] = 0;
        out[step] = sets[bi];
        for (i = 0; i < n; ++i) {
            if (!alive[i] || i == bi) continue;
            if (i < bi)
                dist[i * n + bi] = union_area(box[i], box[bi]);
            else
                dist[bi * n + i] = union_area(box[i], box[bi]);
        }
    }
    free(box);
    free(dist);
    free(alive);
    free(sets);
    return clear;
}

/* The clusters (inner nodes) of the built tree, as primitive-id sets. */
static cluster_set tree_clusters_rec(const ts_tree *t, size_t node, cluster_set *out, size_t *count) {
    cluster_set s;
    const aacbvh_node *nd = &t->nodes[node];
    memset(&s, 0, sizeof s);
    if (nd->count) {
        uint32_t j;
        for (j = nd->first; j < nd->first + nd->count; ++j) s.bits[t->prims[j] / 64] |= (uint64_t)1 << (t->prims[j] % 64);
    } else {
        cluster_set a = tree_clusters_rec(t, nd->first, out, count);
        cluster_set b = tree_clusters_rec(t, nd->first + 1, out, count);
        size_t w;
        for (w = 0; w < WORDS; ++w) s.bits[w] = a.bits[w] | b.bits[w];
        out[(*count)++] = s;
    }
    return s;
}

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

/* Builds `boxes` with the BVH's parameters and compares with the reference. */
static void compare_with_reference(aacbvh_bvh *bvh, const float *boxes, size_t n, const cluster_set *ref,
                                   const char *what) {
    ts_tree t;
    cluster_set *got = calloc(n, sizeof *got);
    size_t count = 0, i;
    char msg[512];
    assert_non_null(got);
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, boxes, n, 24), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    if (!ts_check_tree(bvh, boxes, n, NULL, 1, msg, sizeof msg)) fail_msg("%s: %s", what, msg);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &t), AACBVH_OK);
    assert_int_equal(t.node_count, 2 * n - 1);
    tree_clusters_rec(&t, 0, got, &count);
    assert_int_equal(count, n - 1);
    qsort(got, count, sizeof *got, cmp_sets);
    for (i = 0; i < count; ++i)
        if (memcmp(&got[i], &ref[i], sizeof got[i]) != 0) {
            size_t missing = 0, j;
            for (j = 0; j < count; ++j)
                if (!bsearch(&ref[j], got, count, sizeof *got, cmp_sets)) ++missing;
            fail_msg("%s: %zu of the %zu reference clusters are not in the tree", what, missing, count);
        }
    ts_tree_free(&t);
    free(got);
}

typedef enum exact_kind { EXACT_AAC, EXACT_LOCALLY_ORDERED, EXACT_PLOC } exact_kind;

static void run_exact(exact_kind kind) {
    const size_t sizes[] = {2, 3, 4, 5, 8, 13, 31, 64, 100, 200};
    const int64_t deltas[] = {2, 5, 20};
    const uint64_t seeds[] = {1, 2, 3};
    size_t si, di, ki, compared = 0, skipped = 0;
    char what[256];
    aacbvh_bvh *bvh = NULL;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, 1), AACBVH_OK);
    if (kind == EXACT_AAC) {
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_C, 1.0), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_ALPHA, 1.0), AACBVH_OK);
    } else if (kind == EXACT_LOCALLY_ORDERED) {
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_LOCALLY_ORDERED),
                         AACBVH_OK);
    } else {
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_PLOC), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_PLOC_RADIUS, 1024), AACBVH_OK);
    }
    for (si = 0; si < sizeof sizes / sizeof sizes[0]; ++si)
        for (ki = 0; ki < sizeof seeds / sizeof seeds[0]; ++ki) {
            size_t n = sizes[si];
            float *boxes = ts_random_boxes(n, 0.3f, 1000 * seeds[ki] + n);
            cluster_set *ref = calloc(n, sizeof *ref);
            assert_non_null(boxes);
            assert_non_null(ref);
            if (!reference_clusters(boxes, n, ref)) {
                ++skipped;
            } else {
                qsort(ref, n - 1, sizeof *ref, cmp_sets);
                for (di = 0; di < (kind == EXACT_AAC ? sizeof deltas / sizeof deltas[0] : 1); ++di) {
                    if (kind == EXACT_AAC)
                        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_AAC_DELTA, deltas[di]),
                                         AACBVH_OK);
                    snprintf(what, sizeof what, "%s, n = %zu, seed %llu, delta %lld",
                             kind == EXACT_AAC ? "AAC(c 1, alpha 1)"
                                               : kind == EXACT_LOCALLY_ORDERED ? "LOCALLY_ORDERED" : "PLOC(1024)",
                             n, (unsigned long long)seeds[ki], (long long)deltas[di]);
                    compare_with_reference(bvh, boxes, n, ref, what);
                    ++compared;
                }
            }
            free(ref);
            free(boxes);
        }
    /* Near ties are rare with random boxes; most instances must be compared. */
    assert_true(skipped * 4 <= skipped + compared);
    aacbvh_bvh_destroy(bvh);
}

static void test_aac_exact_matches_greedy(void **state) { (void)state; run_exact(EXACT_AAC); }
static void test_locally_ordered_matches_greedy(void **state) { (void)state; run_exact(EXACT_LOCALLY_ORDERED); }
static void test_ploc_full_radius_matches_greedy(void **state) { (void)state; run_exact(EXACT_PLOC); }

/* The reference itself, on a case worked by hand: two tight pairs far apart. */
static void test_reference_sanity(void **state) {
    const float boxes[4 * 6] = {
        0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f,       /* 0 */
        10.0f, 0.0f, 0.0f, 11.0f, 1.0f, 1.0f,     /* 2's neighbour */
        1.5f, 0.0f, 0.0f, 2.5f, 1.0f, 1.0f,       /* 0's neighbour */
        12.0f, 0.0f, 0.0f, 13.0f, 1.0f, 1.0f,
    };
    cluster_set ref[3];
    (void)state;
    assert_true(reference_clusters(boxes, 4, ref));
    assert_true(ref[0].bits[0] == 0x5u || ref[0].bits[0] == 0xAu);
    assert_true(ref[1].bits[0] == 0x5u || ref[1].bits[0] == 0xAu);
    assert_true(ref[0].bits[0] != ref[1].bits[0]);
    assert_true(ref[2].bits[0] == 0xFu);
}

/* The paper's presets stay close to the exact tree's SAH cost. */
static void test_presets_sah_close_to_exact(void **state) {
    const size_t sizes[] = {300, 500};
    size_t si, seed;
    (void)state;
    for (si = 0; si < 2; ++si)
        for (seed = 1; seed <= 3; ++seed) {
            size_t n = sizes[si];
            float *boxes = ts_random_boxes(n, 0.2f, 7000 + 10 * seed + n);
            aacbvh_bvh *exact = NULL, *hq = NULL, *fast = NULL;
            aacbvh_stats se, sh, sf;
            char msg[512];
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &exact), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &hq), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &fast), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(exact, AACBVH_PARAM_AAC_C, 1.0), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(exact, AACBVH_PARAM_AAC_ALPHA, 1.0), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(fast, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(exact, boxes, n, 24), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(hq, boxes, n, 24), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(fast, boxes, n, 24), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(exact), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(hq), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_build(fast), AACBVH_OK);
            if (!ts_check_tree(hq, boxes, n, NULL, 4, msg, sizeof msg)) fail_msg("AAC_HQ: %s", msg);
            if (!ts_check_tree(fast, boxes, n, NULL, 4, msg, sizeof msg)) fail_msg("AAC_FAST: %s", msg);
            se.struct_size = sh.struct_size = sf.struct_size = sizeof(aacbvh_stats);
            TS_EXPECT_STATUS(aacbvh_bvh_get_stats(exact, &se), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_get_stats(hq, &sh), AACBVH_OK);
            TS_EXPECT_STATUS(aacbvh_bvh_get_stats(fast, &sf), AACBVH_OK);
            if (!(sh.sah_cost <= 1.5 * se.sah_cost) || !(sf.sah_cost <= 1.5 * se.sah_cost))
                fail_msg("n = %zu, seed %zu: SAH exact %g, AAC_HQ %g, AAC_FAST %g", n, seed, se.sah_cost,
                         sh.sah_cost, sf.sah_cost);
            aacbvh_bvh_destroy(exact);
            aacbvh_bvh_destroy(hq);
            aacbvh_bvh_destroy(fast);
            free(boxes);
        }
}

/* A tree's nodes, from a build of `n` boxes with the builder given, or for
 * AACBVH_BUILDER_AAC the paper's values of the preset `paper_of`; malloc'd,
 * *count set. */
static aacbvh_node *build_nodes(const float *boxes, size_t n, int builder, int paper_of, size_t *count) {
    aacbvh_bvh *bvh = NULL;
    aacbvh_stats st;
    aacbvh_node *nodes;
    const int fast = paper_of == AACBVH_BUILDER_AAC_FAST;
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    if (builder == AACBVH_BUILDER_AAC) {
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_AAC_DELTA, fast ? 4 : 20), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_C,
                                                    fast ? pow(4.0, 0.7) / 2.0 : pow(20.0, 0.6) / 2.0),
                         AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_ALPHA, fast ? 0.3 : 0.4), AACBVH_OK);
    } else {
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    }
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, boxes, n, 24), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    st.struct_size = sizeof st;
    TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &st), AACBVH_OK);
    *count = (size_t)st.node_count;
    nodes = (aacbvh_node *)malloc(*count * sizeof *nodes);
    assert_non_null(nodes);
    TS_EXPECT_STATUS(aacbvh_bvh_get_nodes(bvh, 0, *count, nodes), AACBVH_OK);
    aacbvh_bvh_destroy(bvh);
    return nodes;
}

/* The presets are ours now (issue 17: the root split by SAH, and AAC-Fast
 * with AAC-HQ's cluster counts from 1,024 primitives up); the paper's AAC
 * stays available as AACBVH_BUILDER_AAC with its values, and builds other
 * trees (test_presets_sah_close_to_exact checks the presets' trees). */
static void test_presets_and_paper_values(void **state) {
    const size_t sizes[] = {1000, 6000};
    const int presets[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST};
    size_t si, pi;
    (void)state;
    for (si = 0; si < 2; ++si)
        for (pi = 0; pi < 2; ++pi) {
            const size_t n = sizes[si];
            float *boxes = ts_random_boxes(n, 0.05f, 4242 + n);
            size_t na = 0, nb = 0;
            aacbvh_node *ours = build_nodes(boxes, n, presets[pi], 0, &na);
            aacbvh_node *paper = build_nodes(boxes, n, AACBVH_BUILDER_AAC, presets[pi], &nb);
            if (na == 0 || nb == 0) fail_msg("n = %zu: an empty tree", n);
            if (na == nb && memcmp(ours, paper, na * sizeof *ours) == 0)
                fail_msg("n = %zu, preset %d: the preset builds the paper's tree", n, presets[pi]);
            free(ours);
            free(paper);
            free(boxes);
        }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reference_sanity),
        cmocka_unit_test(test_aac_exact_matches_greedy),
        cmocka_unit_test(test_locally_ordered_matches_greedy),
        cmocka_unit_test(test_ploc_full_radius_matches_greedy),
        cmocka_unit_test(test_presets_sah_close_to_exact),
        cmocka_unit_test(test_presets_and_paper_values),
    };
    return cmocka_run_group_tests(tests, setup_group, teardown_group);
}
