/*
 * Watertightness: rays aimed exactly at shared vertices and at points of
 * shared edges of closed meshes (a subdivided cube, an icosphere) and of a
 * height-field grid of quads, near the origin and translated to 1e5, must
 * hit; none may pass between triangles. At least 100,000 rays per mesh
 * (AACBVH_TEST_QUICK=1 runs 10,000, for valgrind); the leak count must be 0.
 *
 * Closed meshes: a ray from an interior point must leave through the surface,
 * and a ray from outside aimed through a surface point at an interior point
 * must enter it. The height field: a steep ray from above aimed at a point
 * inside the grid must cross it.
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

typedef struct mesh {
    float *v;
    size_t vcount, vcap;
    uint32_t *idx;
    size_t tcount, tcap;
} mesh;

static uint32_t add_vertex(mesh *m, double x, double y, double z) {
    if (m->vcount == m->vcap) {
        m->vcap = m->vcap ? 2 * m->vcap : 256;
        m->v = realloc(m->v, 3 * m->vcap * sizeof(float));
        assert_non_null(m->v);
    }
    m->v[3 * m->vcount] = (float)x;
    m->v[3 * m->vcount + 1] = (float)y;
    m->v[3 * m->vcount + 2] = (float)z;
    return (uint32_t)m->vcount++;
}

static void add_tri(mesh *m, uint32_t a, uint32_t b, uint32_t c) {
    if (m->tcount == m->tcap) {
        m->tcap = m->tcap ? 2 * m->tcap : 256;
        m->idx = realloc(m->idx, 3 * m->tcap * sizeof(uint32_t));
        assert_non_null(m->idx);
    }
    m->idx[3 * m->tcount] = a;
    m->idx[3 * m->tcount + 1] = b;
    m->idx[3 * m->tcount + 2] = c;
    ++m->tcount;
}

static void mesh_free(mesh *m) {
    free(m->v);
    free(m->idx);
    memset(m, 0, sizeof *m);
}

/* The surface of [-1, 1]^3, n x n quads per face, each split in two along
 * alternating diagonals; lattice points on the surface are shared. */
static mesh make_cube(int n, double offset) {
    mesh m = {0};
    const int s = n + 1;
    uint32_t *id = malloc((size_t)s * s * s * sizeof(uint32_t));
    assert_non_null(id);
    for (int i = 0; i < s * s * s; ++i) id[i] = UINT32_MAX;
#define LAT(i, j, k) id[((i) * s + (j)) * s + (k)]
#define VID(i, j, k)                                                                                     \
    (LAT(i, j, k) != UINT32_MAX ? LAT(i, j, k)                                                           \
                                : (LAT(i, j, k) = add_vertex(&m, offset + 2.0 * (i) / n - 1.0,          \
                                                             offset + 2.0 * (j) / n - 1.0,              \
                                                             offset + 2.0 * (k) / n - 1.0)))
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side <= n; side += n)
            for (int a = 0; a < n; ++a)
                for (int b = 0; b < n; ++b) {
                    int c[4][3];
                    const int da[4] = {0, 1, 1, 0}, db[4] = {0, 0, 1, 1};
                    for (int q = 0; q < 4; ++q) {
                        c[q][axis] = side;
                        c[q][(axis + 1) % 3] = a + da[q];
                        c[q][(axis + 2) % 3] = b + db[q];
                    }
                    uint32_t v[4];
                    for (int q = 0; q < 4; ++q) v[q] = VID(c[q][0], c[q][1], c[q][2]);
                    if ((a + b) & 1) {
                        add_tri(&m, v[0], v[1], v[2]);
                        add_tri(&m, v[0], v[2], v[3]);
                    } else {
                        add_tri(&m, v[0], v[1], v[3]);
                        add_tri(&m, v[1], v[2], v[3]);
                    }
                }
#undef VID
#undef LAT
    free(id);
    return m;
}

/* An icosahedron subdivided `levels` times, projected to the unit sphere;
 * edge midpoints are shared through a dense cache. */
static mesh make_icosphere(int levels, double offset) {
    mesh m = {0};
    const double t = (1.0 + sqrt(5.0)) / 2.0;
    const double base[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    const uint32_t faces[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                   {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                   {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                   {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    /* Unit-sphere positions in double; the float mesh is made at the end. */
    size_t vmax = 12, tcount = 20;
    for (int l = 0; l < levels; ++l) vmax += tcount * 3 / 2, tcount *= 4;
    double *p = malloc(3 * vmax * sizeof(double));
    uint32_t *tri = malloc(3 * tcount * sizeof(uint32_t));
    uint32_t *cache = malloc(vmax * vmax * sizeof(uint32_t));
    assert_non_null(p);
    assert_non_null(tri);
    assert_non_null(cache);
    size_t vc = 12, tc = 20;
    for (int i = 0; i < 12; ++i) {
        const double len = sqrt(base[i][0] * base[i][0] + base[i][1] * base[i][1] + base[i][2] * base[i][2]);
        for (int k = 0; k < 3; ++k) p[3 * i + k] = base[i][k] / len;
    }
    memcpy(tri, faces, sizeof faces);
    for (int l = 0; l < levels; ++l) {
        uint32_t *next = malloc(3 * tc * 4 * sizeof(uint32_t));
        assert_non_null(next);
        for (size_t i = 0; i < vmax * vmax; ++i) cache[i] = UINT32_MAX;
        for (size_t f = 0; f < tc; ++f) {
            uint32_t c[3], mid[3];
            for (int j = 0; j < 3; ++j) c[j] = tri[3 * f + j];
            for (int j = 0; j < 3; ++j) {
                const uint32_t a = c[j], b = c[(j + 1) % 3];
                const uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
                uint32_t *slot = &cache[(size_t)lo * vmax + hi];
                if (*slot == UINT32_MAX) {
                    double q[3], len = 0.0;
                    for (int k = 0; k < 3; ++k) q[k] = p[3 * a + k] + p[3 * b + k], len += q[k] * q[k];
                    len = sqrt(len);
                    for (int k = 0; k < 3; ++k) p[3 * vc + k] = q[k] / len;
                    *slot = (uint32_t)vc++;
                }
                mid[j] = *slot;
            }
            const uint32_t quads[4][3] = {{c[0], mid[0], mid[2]}, {c[1], mid[1], mid[0]}, {c[2], mid[2], mid[1]},
                                          {mid[0], mid[1], mid[2]}};
            memcpy(next + 12 * f, quads, sizeof quads);
        }
        free(tri);
        tri = next;
        tc *= 4;
    }
    for (size_t i = 0; i < vc; ++i) add_vertex(&m, offset + p[3 * i], offset + p[3 * i + 1], offset + p[3 * i + 2]);
    for (size_t f = 0; f < tc; ++f) add_tri(&m, tri[3 * f], tri[3 * f + 1], tri[3 * f + 2]);
    free(p);
    free(tri);
    free(cache);
    return m;
}

/* A height field over [0, 1]^2 of n x n non-planar quads, two triangles each. */
static mesh make_quad_grid(int n, double offset) {
    mesh m = {0};
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const double x = (double)i / n, y = (double)j / n;
            add_vertex(&m, offset + x, offset + y, offset + 0.2 * sin(7.0 * x) * cos(5.0 * y) + 0.05 * ((i + j) & 1));
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const uint32_t v00 = (uint32_t)(j * (n + 1) + i), v10 = v00 + 1, v01 = v00 + (uint32_t)n + 1,
                           v11 = v01 + 1;
            add_tri(&m, v00, v10, v11);
            add_tri(&m, v00, v11, v01);
        }
    return m;
}

enum { KIND_CUBE, KIND_SPHERE, KIND_GRID };

static size_t rays_per_mesh(void) {
    const char *quick = getenv("AACBVH_TEST_QUICK");
    return (quick && *quick && strcmp(quick, "0") != 0) ? 10000 : 100000;
}

/* A point exactly on a shared vertex or on a shared edge of triangle `tri`. */
static void surface_target(ts_rng *rng, const mesh *m, size_t tri, float out[3]) {
    const int corner = (int)ts_rng_below(rng, 3);
    const float *a = m->v + 3 * m->idx[3 * tri + corner];
    const float *b = m->v + 3 * m->idx[3 * tri + (corner + 1) % 3];
    const uint32_t kind = ts_rng_below(rng, 4);
    float s;
    switch (kind) {
    case 0: memcpy(out, a, 3 * sizeof(float)); return; /* a shared vertex */
    case 1: s = 0.5f; break;
    case 2: s = (float)ts_rng_below(rng, 17) / 16.0f; break;
    default: s = ts_rng_float(rng); break;
    }
    for (int k = 0; k < 3; ++k) out[k] = a[k] + s * (b[k] - a[k]);
}

/* Fills rays and returns how many. */
static void make_rays(int kind, const mesh *m, double offset, ts_rng *rng, aacbvh_ray *rays, size_t count) {
    for (size_t i = 0; i < count; ++i) {
        aacbvh_ray *r = &rays[i];
        size_t tri;
        if (kind == KIND_GRID) { /* a triangle away from the border */
            const int n = (int)lround(sqrt((double)m->tcount / 2.0));
            const int ci = 1 + (int)ts_rng_below(rng, (uint32_t)n - 2), cj = 1 + (int)ts_rng_below(rng, (uint32_t)n - 2);
            tri = 2 * ((size_t)cj * n + ci) + ts_rng_below(rng, 2);
        } else {
            tri = ts_rng_below(rng, (uint32_t)m->tcount);
        }
        float target[3];
        surface_target(rng, m, tri, target);
        double inner[3];
        if (kind == KIND_GRID) {
            const int above = (int)(i & 1);
            for (int k = 0; k < 2; ++k) r->org[k] = target[k] + ts_rng_range(rng, -0.05f, 0.05f);
            r->org[2] = (float)(offset + (above ? 2.0 : -2.0));
            if (i % 7 == 0) { r->org[0] = target[0]; r->org[1] = target[1]; } /* axis-parallel */
        } else {
            /* An interior point: the centre, or a random point well inside. */
            const double reach = kind == KIND_CUBE ? 0.9 : 0.5;
            for (int k = 0; k < 3; ++k)
                inner[k] = offset + ((i % 4 == 0) ? 0.0 : reach * ts_rng_range(rng, -1.0f, 1.0f));
            if (i & 1) { /* from inside out through the target */
                for (int k = 0; k < 3; ++k) r->org[k] = (float)inner[k];
            } else { /* from outside in, through the target towards the interior point */
                for (int k = 0; k < 3; ++k) r->org[k] = (float)(inner[k] + 3.0 * ((double)target[k] - inner[k]));
                for (int k = 0; k < 3; ++k) target[k] = (float)inner[k];
            }
        }
        const float scale = (i % 3 == 0) ? 1.0f : (i % 3 == 1 ? 0.125f : 7.0f);
        for (int k = 0; k < 3; ++k) r->dir[k] = (target[k] - r->org[k]) * scale;
        r->tmin = 0.0f;
        r->tmax = INFINITY;
    }
}

static size_t count_leaks(int kind, double offset, aacbvh_builder builder) {
    mesh m = kind == KIND_CUBE ? make_cube(24, offset) : kind == KIND_SPHERE ? make_icosphere(4, offset)
                                                                             : make_quad_grid(64, offset);
    aacbvh_context *ctx;
    aacbvh_bvh *bvh;
    ts_create(2, &ctx, &bvh);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_triangles(bvh, m.v, m.vcount, 12, m.idx, m.tcount), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_build(bvh), AACBVH_OK);
    const size_t count = rays_per_mesh();
    aacbvh_ray *rays = malloc(count * sizeof *rays);
    aacbvh_hit *hits = malloc(count * sizeof *hits);
    uint8_t *occ = malloc(count);
    assert_non_null(rays);
    assert_non_null(hits);
    assert_non_null(occ);
    ts_rng rng;
    ts_rng_seed(&rng, 1000 + (uint64_t)kind);
    make_rays(kind, &m, offset, &rng, rays, count);
    TS_EXPECT_STATUS(aacbvh_bvh_intersect(bvh, rays, hits, count), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_occluded(bvh, rays, occ, count), AACBVH_OK);
    size_t leaks = 0;
    for (size_t i = 0; i < count; ++i) {
        if (hits[i].prim_id != AACBVH_INVALID_ID && occ[i]) continue;
        if (leaks < 5)
            printf("  leak: ray %zu org (%.9g %.9g %.9g) dir (%.9g %.9g %.9g)\n", i, (double)rays[i].org[0],
                   (double)rays[i].org[1], (double)rays[i].org[2], (double)rays[i].dir[0], (double)rays[i].dir[1],
                   (double)rays[i].dir[2]);
        ++leaks;
    }
    static const char *names[] = {"subdivided cube", "icosphere", "grid of quads"};
    printf("%-16s offset %-6g %zu triangles, %zu rays: %zu leaks\n", names[kind], offset, m.tcount, count, leaks);
    free(rays);
    free(hits);
    free(occ);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    mesh_free(&m);
    return leaks;
}

static void test_cube(void **state) {
    (void)state;
    assert_int_equal(count_leaks(KIND_CUBE, 0.0, AACBVH_BUILDER_AAC_HQ), 0);
    assert_int_equal(count_leaks(KIND_CUBE, 1e5, AACBVH_BUILDER_BINNED_SAH), 0);
}

static void test_icosphere(void **state) {
    (void)state;
    assert_int_equal(count_leaks(KIND_SPHERE, 0.0, AACBVH_BUILDER_SWEEP_SAH), 0);
    assert_int_equal(count_leaks(KIND_SPHERE, 1e5, AACBVH_BUILDER_AAC_FAST), 0);
}

static void test_quad_grid(void **state) {
    (void)state;
    assert_int_equal(count_leaks(KIND_GRID, 0.0, AACBVH_BUILDER_PLOC), 0);
    assert_int_equal(count_leaks(KIND_GRID, 1e5, AACBVH_BUILDER_AAC_HQ), 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cube),
        cmocka_unit_test(test_icosphere),
        cmocka_unit_test(test_quad_grid),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
