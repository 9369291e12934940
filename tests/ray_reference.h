/*
 * A double-precision brute-force reference for closest-hit queries on
 * triangles, shared by the robustness tests (test_closest_hit.c,
 * test_degenerate.c, test_ray_directions.c). Header-only, C99.
 *
 * Each triangle is classified per ray as a certain hit, a certain miss or
 * "either": either when the ray passes within rounding distance of an edge's
 * line, of tmin or tmax, or is nearly parallel to the plane. Rounding
 * distance is relative to L, the largest distance from the ray origin to a
 * vertex, so scenes of any scale and offset are judged alike.
 *
 * The documented promise of aacbvh_bvh_intersect() (see its header comment)
 * is checked by rr_check_hit():
 *   |t - t_exact| <= RR_T_TOL * (|t_exact| + (L + RR_SLIVER E^2 / h) / |dir|) / |cos theta|,
 * (E the longest edge, h the smallest height: the term matters for slivers),
 * and the primitive is the nearest certain hit unless another candidate lies
 * within that tolerance of it.
 */
#ifndef AACBVH_TESTS_RAY_REFERENCE_H
#define AACBVH_TESTS_RAY_REFERENCE_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <aacbvh/aacbvh.h>

/* The tolerance documented in aacbvh.h (relative to |t| + L / |dir|). */
#define RR_T_TOL 1e-5
/* Positions the float test may be off by, relative to L. */
#define RR_POS_REL 1e-5
/* Weight of the sliver term E^2 / h (longest edge E, smallest height h). */
#define RR_SLIVER 0.01
/* Below this |cos theta| the distance is not judged. */
#define RR_MIN_COSINE 1e-4

enum { RR_MISS = 0, RR_EITHER = 1, RR_HIT = 2 };

typedef struct rr_tri {
    int cls;    /* RR_MISS, RR_EITHER or RR_HIT */
    double t;   /* exact distance (NaN when not meaningful) */
    double tol; /* documented tolerance of t (INFINITY when not judged) */
} rr_tri;

static double rr_dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void rr_cross(const double a[3], const double b[3], double out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}
static double rr_len(const double a[3]) { return sqrt(rr_dot(a, a)); }

static rr_tri rr_triangle(const aacbvh_ray *ray, const float *a, const float *b, const float *c) {
    rr_tri res = {RR_MISS, NAN, INFINITY};
    const double d[3] = {ray->dir[0], ray->dir[1], ray->dir[2]};
    const double dl = rr_len(d);
    const float *v[3] = {a, b, c};
    double L = 0.0;
    for (int i = 0; i < 3; ++i) {
        double r[3];
        for (int k = 0; k < 3; ++k) r[k] = (double)v[i][k] - ray->org[k];
        L = fmax(L, rr_len(r));
    }
    const double margin = RR_POS_REL * L + 1e-300;
    int pos = 0, neg = 0, unsure = 0;
    for (int i = 0; i < 3; ++i) {
        const float *p = v[i], *q = v[(i + 1) % 3];
        double e[3], r[3], x[3];
        for (int k = 0; k < 3; ++k) {
            e[k] = (double)q[k] - p[k];
            r[k] = (double)p[k] - ray->org[k];
        }
        rr_cross(r, d, x);
        const double el = rr_len(e);
        const double side = el > 0.0 ? rr_dot(e, x) / (el * dl) : 0.0;
        if (side > margin) ++pos;
        else if (side < -margin) ++neg;
        else ++unsure;
    }
    if (pos && neg) return res;
    double e1[3], e2[3], n[3], s[3];
    for (int k = 0; k < 3; ++k) {
        e1[k] = (double)b[k] - a[k];
        e2[k] = (double)c[k] - a[k];
        s[k] = (double)a[k] - ray->org[k];
    }
    rr_cross(e1, e2, n);
    const double dn = rr_dot(d, n), nl = rr_len(n);
    /* Zero area (or nearly): no meaningful distance; the hit point check in
     * rr_check_hit() still holds such a hit to the triangle's box. */
    if (!(nl > 1e-12 * (rr_dot(e1, e1) + rr_dot(e2, e2)))) {
        res.cls = RR_EITHER;
        return res;
    }
    const double cosine = fabs(dn) / (nl * dl);
    if (cosine < RR_MIN_COSINE) {
        if (fabs(rr_dot(s, n)) / nl > margin) return res;
        res.cls = RR_EITHER;
        return res;
    }
    const double t = rr_dot(s, n) / dn;
    /* Slivers: the single-precision barycentrics of a triangle with longest
     * edge E and smallest height h carry errors of relative size E / h. */
    double e3[3], emax = 0.0;
    for (int k = 0; k < 3; ++k) e3[k] = (double)c[k] - b[k];
    emax = fmax(rr_len(e1), fmax(rr_len(e2), rr_len(e3)));
    const double h = nl / emax;
    /* Plus a few float steps at the bottom of the range: t itself is a float. */
    const double tol = RR_T_TOL * (fabs(t) + (L + RR_SLIVER * emax * emax / h) / dl) / cosine + 0x1p-146;
    res.t = t;
    res.tol = tol;
    if (t < (double)ray->tmin - tol || t > (double)ray->tmax + tol) return res;
    res.cls = (unsure == 0 && t > (double)ray->tmin + tol && t < (double)ray->tmax - tol) ? RR_HIT : RR_EITHER;
    return res;
}

/* Vertex k of a triangle list (stride in floats, indices may be NULL). */
static const float *rr_vertex(const float *vertices, size_t stride_floats, const uint32_t *indices, size_t tri,
                              int corner) {
    const size_t k = indices ? indices[3 * tri + (size_t)corner] : 3 * tri + (size_t)corner;
    return vertices + k * stride_floats;
}

/*
 * Checks one closest hit against the reference over all `count` triangles.
 * Returns 1 if it keeps the documented promise, else 0 with a message in msg.
 * *max_rel_err_out (may be NULL) is raised to the largest
 * |t - t_exact| / tol seen.
 */
static int rr_check_hit(const aacbvh_ray *ray, const aacbvh_hit *hit, const float *vertices, size_t stride_floats,
                        const uint32_t *indices, size_t count, char *msg, size_t msg_size, double *max_rel_err_out) {
    double best_t = INFINITY, best_tol = 0.0;
    size_t best = (size_t)-1;
    for (size_t i = 0; i < count; ++i) {
        const rr_tri r = rr_triangle(ray, rr_vertex(vertices, stride_floats, indices, i, 0),
                                     rr_vertex(vertices, stride_floats, indices, i, 1),
                                     rr_vertex(vertices, stride_floats, indices, i, 2));
        if (r.cls == RR_HIT && r.t < best_t) {
            best_t = r.t;
            best_tol = r.tol;
            best = i;
        }
    }
    if (hit->prim_id == AACBVH_INVALID_ID) {
        if (best != (size_t)-1) {
            snprintf(msg, msg_size, "missed; reference hits triangle %zu at t = %.9g", best, best_t);
            return 0;
        }
        return 1;
    }
    if (hit->prim_id >= count) {
        snprintf(msg, msg_size, "hit id %u out of range", hit->prim_id);
        return 0;
    }
    const size_t p = hit->prim_id;
    const rr_tri r = rr_triangle(ray, rr_vertex(vertices, stride_floats, indices, p, 0),
                                 rr_vertex(vertices, stride_floats, indices, p, 1),
                                 rr_vertex(vertices, stride_floats, indices, p, 2));
    if (r.cls == RR_MISS) {
        snprintf(msg, msg_size, "hit triangle %zu at t = %.9g, which the reference misses", p, (double)hit->t);
        return 0;
    }
    if (!(hit->t >= ray->tmin && hit->t <= ray->tmax) || !isfinite(hit->t)) {
        snprintf(msg, msg_size, "t = %.9g outside [%.9g, %.9g]", (double)hit->t, (double)ray->tmin,
                 (double)ray->tmax);
        return 0;
    }
    {
        /* The hit point lies on (near) the triangle's box. */
        double L = 0.0, e[3][3], emax = 0.0, n[3];
        const float *q[3];
        for (int j = 0; j < 3; ++j) {
            q[j] = rr_vertex(vertices, stride_floats, indices, p, j);
            for (int k = 0; k < 3; ++k) L = fmax(L, fabs((double)q[j][k] - ray->org[k]));
        }
        for (int j = 0; j < 3; ++j) {
            for (int k = 0; k < 3; ++k) e[j][k] = (double)q[(j + 1) % 3][k] - q[j][k];
            emax = fmax(emax, rr_len(e[j]));
        }
        rr_cross(e[0], e[1], n);
        /* The sliver term of the tolerance, as a distance (none at zero area). */
        if (rr_len(n) > 0.0) L += RR_SLIVER * emax * emax * emax / rr_len(n);
        for (int k = 0; k < 3; ++k) {
            const double x = (double)ray->org[k] + (double)hit->t * ray->dir[k];
            double lo = INFINITY, hi = -INFINITY;
            for (int j = 0; j < 3; ++j) {
                const double q = rr_vertex(vertices, stride_floats, indices, p, j)[k];
                lo = fmin(lo, q);
                hi = fmax(hi, q);
            }
            const double slack =
                1e-4 * L + 1e-4 * fabs((double)hit->t * ray->dir[k]) + 0x1p-146 * fabs((double)ray->dir[k]) + 1e-300;
            if (x < lo - slack || x > hi + slack) {
                snprintf(msg, msg_size, "hit point of triangle %zu off its box on axis %d (%.9g not in [%.9g, %.9g])",
                         p, k, x, lo, hi);
                return 0;
            }
        }
    }
    if (isfinite(r.tol)) {
        const double err = fabs((double)hit->t - r.t);
        if (max_rel_err_out && err / r.tol > *max_rel_err_out) *max_rel_err_out = err / r.tol;
        if (err > r.tol) {
            snprintf(msg, msg_size,
                     "triangle %zu: t = %.9g, exact %.12g (tolerance %.3g); ray org %.9g %.9g %.9g dir %.9g %.9g %.9g",
                     p, (double)hit->t, r.t, r.tol, (double)ray->org[0], (double)ray->org[1], (double)ray->org[2],
                     (double)ray->dir[0], (double)ray->dir[1], (double)ray->dir[2]);
            return 0;
        }
    }
    if (best != (size_t)-1 && (double)hit->t > best_t + best_tol) {
        snprintf(msg, msg_size, "hit triangle %zu at t = %.9g behind triangle %zu at %.9g", p, (double)hit->t, best,
                 best_t);
        return 0;
    }
    /* The nearest primitive, unless another candidate ties with it. */
    if (best != (size_t)-1 && p != best && isfinite(r.tol) && r.t > best_t + best_tol + r.tol) {
        snprintf(msg, msg_size, "hit triangle %zu at %.9g, but triangle %zu is nearer at %.9g", p, r.t, best,
                 best_t);
        return 0;
    }
    return 1;
}

#endif /* AACBVH_TESTS_RAY_REFERENCE_H */
