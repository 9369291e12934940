/* Refit: after the caller moves vertices, every node's box equals a
 * bottom-up recomputation from the new positions, the topology is unchanged,
 * the stats follow, and refit refuses when it cannot apply. */
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
    return aacbvh_context_create(4, &g_ctx) == AACBVH_OK ? 0 : -1;
}

static int teardown_group(void **state) {
    (void)state;
    aacbvh_context_destroy(g_ctx);
    return 0;
}

/* Expected boxes: leaves from their primitives (prim_boxes), inner nodes the
 * union of their children; children are processed before their parents by
 * walking a pre-order backwards. */
static void expected_boxes(const ts_tree *t, const float *prim_boxes, aacbvh_node *out) {
    size_t *order = malloc((t->node_count + 1) * sizeof *order);
    size_t *stack = malloc((t->node_count + 1) * sizeof *stack);
    size_t top = 0, count = 0, i;
    assert_non_null(order);
    assert_non_null(stack);
    memcpy(out, t->nodes, t->node_count * sizeof *out);
    if (t->node_count) stack[top++] = 0;
    while (top) {
        size_t nd = stack[--top];
        order[count++] = nd;
        if (t->nodes[nd].count == 0) {
            stack[top++] = t->nodes[nd].first;
            stack[top++] = t->nodes[nd].first + 1;
        }
    }
    assert_int_equal(count, t->node_count);
    for (i = count; i-- > 0;) {
        aacbvh_node *n = &out[order[i]];
        int k;
        if (n->count) {
            uint32_t j;
            for (j = n->first; j < n->first + n->count; ++j) {
                const float *b = prim_boxes + 6 * (size_t)t->prims[j];
                for (k = 0; k < 3; ++k) {
                    if (j == n->first || b[k] < n->lower[k]) n->lower[k] = b[k];
                    if (j == n->first || b[3 + k] > n->upper[k]) n->upper[k] = b[3 + k];
                }
            }
        } else {
            const aacbvh_node *l = &out[n->first], *r = &out[n->first + 1];
            for (k = 0; k < 3; ++k) {
                n->lower[k] = l->lower[k] < r->lower[k] ? l->lower[k] : r->lower[k];
                n->upper[k] = l->upper[k] > r->upper[k] ? l->upper[k] : r->upper[k];
            }
        }
    }
    free(order);
    free(stack);
}

/* Refits and checks the result against `before` (the tree before the motion)
 * and the new primitive boxes. */
static void refit_and_check(aacbvh_bvh *bvh, const ts_tree *before, const float *new_boxes, const char *what) {
    ts_tree after;
    aacbvh_node *want;
    size_t i;
    aacbvh_status s = aacbvh_bvh_refit(bvh);
    if (s != AACBVH_OK) fail_msg("%s: refit returned %s (%s)", what, aacbvh_status_string(s), aacbvh_bvh_last_error(bvh));
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &after), AACBVH_OK);
    assert_int_equal(after.node_count, before->node_count);
    assert_int_equal(after.prim_count, before->prim_count);
    if (memcmp(after.prims, before->prims, after.prim_count * sizeof *after.prims) != 0)
        fail_msg("%s: refit changed the primitive indices", what);
    for (i = 0; i < after.node_count; ++i)
        if (after.nodes[i].first != before->nodes[i].first || after.nodes[i].count != before->nodes[i].count)
            fail_msg("%s: refit changed node %zu's topology", what, i);
    want = malloc((after.node_count + 1) * sizeof *want);
    assert_non_null(want);
    expected_boxes(&after, new_boxes, want);
    /* Exact float compare (== also takes -0 for +0: min/max may keep either). */
    for (i = 0; i < after.node_count; ++i)
        if (!(want[i].lower[0] == after.nodes[i].lower[0] && want[i].lower[1] == after.nodes[i].lower[1] &&
              want[i].lower[2] == after.nodes[i].lower[2] && want[i].upper[0] == after.nodes[i].upper[0] &&
              want[i].upper[1] == after.nodes[i].upper[1] && want[i].upper[2] == after.nodes[i].upper[2]))
            fail_msg("%s: node %zu box (%g %g %g)-(%g %g %g), expected (%g %g %g)-(%g %g %g)", what, i,
                     after.nodes[i].lower[0], after.nodes[i].lower[1], after.nodes[i].lower[2],
                     after.nodes[i].upper[0], after.nodes[i].upper[1], after.nodes[i].upper[2], want[i].lower[0],
                     want[i].lower[1], want[i].lower[2], want[i].upper[0], want[i].upper[1], want[i].upper[2]);
    {
        double ct = 0, ci = 0, sah;
        TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, &ct), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_INTERSECTION_COST, &ci), AACBVH_OK);
        sah = ts_tree_sah_cost(&after, ct, ci);
        if (!(fabs(after.stats.sah_cost - sah) <= 1e-6 * sah))
            fail_msg("%s: sah_cost after refit %.17g, recomputed %.17g", what, after.stats.sah_cost, sah);
        if (after.stats.built_sah_cost != before->stats.built_sah_cost)
            fail_msg("%s: built_sah_cost changed by refit: %.17g -> %.17g", what, before->stats.built_sah_cost,
                     after.stats.built_sah_cost);
        assert_int_equal(after.stats.leaf_count, before->stats.leaf_count);
        assert_int_equal(after.stats.max_depth, before->stats.max_depth);
        assert_int_equal(after.stats.primitive_count, before->stats.primitive_count);
    }
    free(want);
    ts_tree_free(&after);
}

/* Rays straight at the centroids of some triangles must be occluded. */
static void check_rays_hit(const aacbvh_bvh *bvh, const ts_mesh *mesh, const char *what) {
    size_t i, n = mesh->triangle_count < 64 ? mesh->triangle_count : 64;
    for (i = 0; i < n; ++i) {
        size_t t = i * (mesh->triangle_count / n);
        const float *a = mesh->vertices + 3 * mesh->indices[3 * t];
        const float *b = mesh->vertices + 3 * mesh->indices[3 * t + 1];
        const float *c = mesh->vertices + 3 * mesh->indices[3 * t + 2];
        aacbvh_ray ray;
        aacbvh_hit hit;
        uint8_t occ = 0;
        float e1[3], e2[3], nrm[3], len;
        int k;
        for (k = 0; k < 3; ++k) {
            e1[k] = b[k] - a[k];
            e2[k] = c[k] - a[k];
        }
        nrm[0] = e1[1] * e2[2] - e1[2] * e2[1];
        nrm[1] = e1[2] * e2[0] - e1[0] * e2[2];
        nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
        len = sqrtf(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
        if (!(len > 0.0f)) continue;
        /* Along the normal, from outside, at the centroid. */
        for (k = 0; k < 3; ++k) {
            float centroid = (a[k] + b[k] + c[k]) / 3.0f;
            ray.dir[k] = -nrm[k] / len;
            ray.org[k] = centroid + 10.0f * nrm[k] / len;
        }
        ray.tmin = 0.0f;
        ray.tmax = INFINITY;
        TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, &ray, &occ, 1), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, &ray, &hit, 1), AACBVH_OK);
        if (!occ || hit.prim_id == AACBVH_INVALID_ID)
            fail_msg("%s: a ray at triangle %zu's centroid misses after refit", what, t);
    }
}

static void move_vertices(ts_mesh *mesh, ts_rng *rng, int large) {
    size_t i;
    int k;
    for (i = 0; i < mesh->vertex_count; ++i)
        for (k = 0; k < 3; ++k) {
            float *p = &mesh->vertices[3 * i + k];
            if (large)
                *p = *p * 7.0f + (k == 0 ? 50.0f : -20.0f) + ts_rng_range(rng, -3.0f, 3.0f);
            else
                *p += ts_rng_range(rng, -0.05f, 0.05f);
        }
}

typedef struct refit_case {
    const char *name;
    aacbvh_builder builder;
    uint32_t leaf;
    ts_scene_kind scene;
    size_t n;
} refit_case;

static void test_refit_triangles(void **state) {
    const refit_case cases[] = {
        {"AAC_HQ", AACBVH_BUILDER_AAC_HQ, 4, TS_SCENE_RANDOM, 2000},
        {"AAC_HQ", AACBVH_BUILDER_AAC_HQ, 1, TS_SCENE_GRID, 1000},
        {"AAC_FAST", AACBVH_BUILDER_AAC_FAST, 8, TS_SCENE_SLIVERS, 1500},
        {"SWEEP_SAH", AACBVH_BUILDER_SWEEP_SAH, 2, TS_SCENE_RANDOM, 1000},
        {"BINNED_SAH", AACBVH_BUILDER_BINNED_SAH, 4, TS_SCENE_GRID, 3000},
        {"PLOC", AACBVH_BUILDER_PLOC, 4, TS_SCENE_RANDOM, 2000},
        {"AAC_HQ", AACBVH_BUILDER_AAC_HQ, 4, TS_SCENE_IDENTICAL, 300},
        {"AAC_HQ", AACBVH_BUILDER_AAC_HQ, 4, TS_SCENE_RANDOM, 1},
    };
    size_t ci;
    char what[256];
    (void)state;
    for (ci = 0; ci < sizeof cases / sizeof cases[0]; ++ci) {
        const refit_case *rc = &cases[ci];
        aacbvh_bvh *bvh = NULL;
        ts_mesh mesh;
        ts_tree before;
        ts_rng rng;
        float *boxes;
        int frame;
        ts_rng_seed(&rng, 500 + ci);
        assert_true(ts_make_scene(rc->scene, rc->n, 40 + ci, &mesh));
        TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, rc->builder), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, rc->leaf), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 12, mesh.indices,
                                                  mesh.triangle_count), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
        TS_EXPECT_STATUS(ts_tree_fetch(bvh, &before), AACBVH_OK);
        assert_true(before.stats.built_sah_cost == before.stats.sah_cost ||
                    fabs(before.stats.built_sah_cost - before.stats.sah_cost) <= 1e-9 * before.stats.sah_cost);

        /* Unchanged vertices: refit reproduces a tight tree over the same boxes. */
        boxes = ts_mesh_boxes(&mesh);
        snprintf(what, sizeof what, "%s leaf %u %s n %zu, no motion", rc->name, rc->leaf, ts_scene_name(rc->scene), rc->n);
        refit_and_check(bvh, &before, boxes, what);
        free(boxes);

        for (frame = 0; frame < 3; ++frame) {
            int large = frame == 1;
            move_vertices(&mesh, &rng, large);
            boxes = ts_mesh_boxes(&mesh);
            snprintf(what, sizeof what, "%s leaf %u %s n %zu, frame %d (%s motion)", rc->name, rc->leaf,
                     ts_scene_name(rc->scene), rc->n, frame, large ? "large" : "small");
            refit_and_check(bvh, &before, boxes, what);
            check_rays_hit(bvh, &mesh, what);
            free(boxes);
        }
        ts_tree_free(&before);
        aacbvh_bvh_destroy(bvh);
        ts_mesh_free(&mesh);
    }
}

static void test_refit_boxes(void **state) {
    const size_t n = 1500;
    float *boxes = ts_random_boxes(n, 0.1f, 12);
    aacbvh_bvh *bvh = NULL;
    ts_tree before;
    ts_rng rng;
    size_t i;
    int k;
    (void)state;
    ts_rng_seed(&rng, 3);
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, boxes, n, 24), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &before), AACBVH_OK);
    for (i = 0; i < n; ++i)
        for (k = 0; k < 3; ++k) {
            float d = ts_rng_range(&rng, -0.5f, 0.5f);
            boxes[6 * i + k] += d;
            boxes[6 * i + 3 + k] += d + ts_rng_range(&rng, 0.0f, 0.2f);
        }
    refit_and_check(bvh, &before, boxes, "boxes");
    ts_tree_free(&before);
    aacbvh_bvh_destroy(bvh);
    free(boxes);
}

static void test_refit_misuse(void **state) {
    aacbvh_bvh *bvh = NULL;
    ts_mesh mesh, other;
    ts_tree before;
    float *boxes;
    (void)state;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 400, 1, &mesh));
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 400, 2, &other));
    TS_EXPECT_STATUS(aacbvh_bvh_create(g_ctx, &bvh), AACBVH_OK);

    /* Never built: nothing to refit, with or without geometry. */
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_OPERATION);
    assert_true(strlen(aacbvh_bvh_last_error(bvh)) > 0);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 12, mesh.indices, 400), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_OPERATION);
    assert_true(strlen(aacbvh_bvh_last_error(bvh)) > 0);

    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    TS_EXPECT_STATUS(ts_tree_fetch(bvh, &before), AACBVH_OK);

    /* A different primitive count in between: refit refuses, the tree stays invalid. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 12, mesh.indices, 399), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_OPERATION);
    assert_true(strlen(aacbvh_bvh_last_error(bvh)) > 0);
    {
        aacbvh_stats s;
        s.struct_size = sizeof s;
        TS_EXPECT_STATUS(aacbvh_bvh_get_stats(bvh, &s), AACBVH_ERROR_INVALID_OPERATION);
    }
    TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(bvh, mesh.vertices, 7, 24), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_refit(bvh), AACBVH_ERROR_INVALID_OPERATION);

    /* The same count over other buffers: refit applies the old topology to them. */
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, other.vertices, other.vertex_count, 12, other.indices, 400),
                     AACBVH_OK);
    boxes = ts_mesh_boxes(&other);
    refit_and_check(bvh, &before, boxes, "same count, other geometry");
    free(boxes);

    ts_tree_free(&before);
    aacbvh_bvh_destroy(bvh);
    ts_mesh_free(&mesh);
    ts_mesh_free(&other);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_refit_triangles),
        cmocka_unit_test(test_refit_boxes),
        cmocka_unit_test(test_refit_misuse),
    };
    return cmocka_run_group_tests(tests, setup_group, teardown_group);
}
