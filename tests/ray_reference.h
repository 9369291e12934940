/*
 * The tests' one double-precision brute-force reference for ray queries
 * (rr_*), over triangles and boxes, used by every test that checks answers
 * against an oracle (test_intersect.c, test_closest_hit.c, test_degenerate.c,
 * test_ray_directions.c, test_tie_rule.c). Header-only, C99.
 *
 * Each primitive is classified per ray as a certain hit, a certain miss or
 * "either": either when the ray passes within rounding distance of an edge's
 * line (of a box's face), of tmin or tmax, or is nearly parallel to the
 * plane. Rounding distance is relative to L, the largest distance from the
 * ray origin to a vertex (box corner), so scenes of any scale and offset are
 * judged alike.
 *
 * The documented promise of aacbvh_bvh_intersect() (see its header comment)
 * is checked by rr_check():
 *   |t - t_exact| <= RR_T_TOL * (|t_exact| + (L + RR_SLIVER E^2 / h) / |dir|) / |cos theta|,
 * (E the longest edge, h the smallest height: the term matters for slivers),
 * and the primitive is the nearest certain hit unless another candidate lies
 * within that tolerance of it; see rr_check() for the rest.
 *
 * rr_point_in_triangle_2d() is the exact special case for rays along z:
 * which triangles contain a point (x, y), away from their edges.
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

/* One primitive against one ray. */
typedef struct rr_prim {
    int cls;    /* RR_MISS, RR_EITHER or RR_HIT */
    double t;   /* exact distance (NaN when not meaningful) */
    double tol; /* documented tolerance of t (INFINITY when not judged) */
    /* The tolerance the reported t of this primitive is held to: the
     * documented bound of the distance itself, 2^-23 |t| + 2^-46 (L + E^2 / h)
     * / (|dir| |cos theta|), for a ray clear of the triangle's edges; `tol`
     * where the hit itself is a matter of rounding (near an edge, where t may
     * be kept within the triangle's box) and for boxes. */
    double t_tol;
} rr_prim;

/* A scene as given to the library: triangles (vertices stride_floats apart,
 * 3 indices per triangle, or NULL: triangle i is vertices 3i, 3i+1, 3i+2) or
 * boxes (min xyz, max xyz, stride_floats apart). */
typedef struct rr_scene {
    const float *data;
    size_t stride_floats;
    const uint32_t *indices;
    size_t count;
    int boxes;
} rr_scene;

static inline rr_scene rr_triangles(const float *vertices, size_t stride_floats, const uint32_t *indices,
                                    size_t count) {
    const rr_scene s = {vertices, stride_floats, indices, count, 0};
    return s;
}

static inline rr_scene rr_boxes(const float *boxes, size_t stride_floats, size_t count) {
    const rr_scene s = {boxes, stride_floats, NULL, count, 1};
    return s;
}

static inline double rr_dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline void rr_cross(const double a[3], const double b[3], double out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}
static inline double rr_len(const double a[3]) { return sqrt(rr_dot(a, a)); }
static inline double rr_dir_len(const aacbvh_ray *ray) {
    const double d[3] = {ray->dir[0], ray->dir[1], ray->dir[2]};
    return rr_len(d);
}

/* Whether the library takes the ray at all (aacbvh_ray: no NaN field, a
 * finite origin and direction, a non-zero direction). */
static inline int rr_ray_valid(const aacbvh_ray *ray) {
    int k;
    if (isnan(ray->tmin) || isnan(ray->tmax)) return 0;
    for (k = 0; k < 3; ++k)
        if (!isfinite(ray->org[k]) || !isfinite(ray->dir[k])) return 0;
    return ray->dir[0] != 0.0f || ray->dir[1] != 0.0f || ray->dir[2] != 0.0f;
}

static inline rr_prim rr_triangle(const aacbvh_ray *ray, const float *a, const float *b, const float *c) {
    rr_prim res = {RR_MISS, NAN, INFINITY, INFINITY};
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
     * rr_check() still holds such a hit to the triangle's box. */
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
    res.t_tol = unsure ? tol : 0x1p-23 * fabs(t) + 0x1p-46 * (L + emax * emax / h) / (dl * cosine) + 0x1p-149;
    if (t < (double)ray->tmin - tol || t > (double)ray->tmax + tol) return res;
    res.cls = (unsure == 0 && t > (double)ray->tmin + tol && t < (double)ray->tmax - tol) ? RR_HIT : RR_EITHER;
    return res;
}

/* Slab test of box (lo - grow, hi + grow) within [tmin, tmax], in double;
 * grow < 0 shrinks only the axes thicker than 4 |grow| (a flat axis stays
 * flat). *t_entry is the entry distance clamped to tmin. */
static inline int rr_slab(const aacbvh_ray *ray, const float *box, double grow, double tmin, double tmax,
                          double *t_entry) {
    double t0 = tmin, t1 = tmax;
    for (int k = 0; k < 3; ++k) {
        double lo = box[k], hi = box[3 + k];
        if (grow > 0.0 || hi - lo > -4.0 * grow) {
            lo -= grow;
            hi += grow;
        }
        const double o = ray->org[k], dk = ray->dir[k];
        if (dk == 0.0) {
            if (o < lo || o > hi) return 0;
            continue;
        }
        double ta = (lo - o) / dk, tb = (hi - o) / dk;
        if (ta > tb) {
            const double x = ta;
            ta = tb;
            tb = x;
        }
        t0 = fmax(t0, ta);
        t1 = fmin(t1, tb);
    }
    *t_entry = t0;
    return t0 <= t1;
}

/* The tolerance of a distance t along a ray at scale L (0 for an infinite
 * window end, which needs none). */
static inline double rr_t_tolerance(double t, double L, double dl) {
    return isfinite(t) ? RR_T_TOL * (fabs(t) + L / dl) : 0.0;
}

/* A box primitive: a certain hit if the box shrunk by the rounding distance
 * is hit inside the window narrowed by the distance tolerance, a certain miss
 * if the grown box is missed in the widened window. t is the entry distance
 * clamped to tmin. */
static inline rr_prim rr_box(const aacbvh_ray *ray, const float *box) {
    rr_prim res = {RR_MISS, NAN, INFINITY, INFINITY};
    const double dl = rr_dir_len(ray);
    double L2 = 0.0, t, unused;
    for (int k = 0; k < 3; ++k) {
        const double far = fmax(fabs((double)box[k] - ray->org[k]), fabs((double)box[3 + k] - ray->org[k]));
        L2 += far * far;
    }
    const double L = sqrt(L2), margin = RR_POS_REL * L + 1e-300;
    const double tmin = ray->tmin, tmax = ray->tmax;
    const double tol_min = rr_t_tolerance(tmin, L, dl), tol_max = rr_t_tolerance(tmax, L, dl);
    if (!rr_slab(ray, box, margin, tmin - tol_min, tmax + tol_max, &unused)) return res;
    res.cls = RR_EITHER;
    if (!rr_slab(ray, box, 0.0, -INFINITY, INFINITY, &t)) return res;
    t = fmax(t, tmin);
    if (!isfinite(t)) return res;
    res.t = t;
    res.tol = res.t_tol = rr_t_tolerance(t, L, dl);
    if (rr_slab(ray, box, -margin, tmin + tol_min, tmax - tol_max, &unused)) res.cls = RR_HIT;
    return res;
}

/* Vertex `corner` of triangle `tri`. */
static inline const float *rr_vertex(const rr_scene *s, size_t tri, int corner) {
    const size_t k = s->indices ? s->indices[3 * tri + (size_t)corner] : 3 * tri + (size_t)corner;
    return s->data + k * s->stride_floats;
}

static inline rr_prim rr_primitive(const rr_scene *s, const aacbvh_ray *ray, size_t i) {
    if (s->boxes) return rr_box(ray, s->data + i * s->stride_floats);
    return rr_triangle(ray, rr_vertex(s, i, 0), rr_vertex(s, i, 1), rr_vertex(s, i, 2));
}

/* The reference answer of one ray: the nearest certain hit (best, or
 * (size_t)-1 when none) and whether anything at all may be hit. */
typedef struct rr_answer {
    size_t best;
    double best_t, best_tol;
    int any_possible;
} rr_answer;

static inline rr_answer rr_reference(const rr_scene *s, const aacbvh_ray *ray) {
    rr_answer a = {(size_t)-1, INFINITY, 0.0, 0};
    if (!rr_ray_valid(ray)) return a;
    for (size_t i = 0; i < s->count; ++i) {
        const rr_prim r = rr_primitive(s, ray, i);
        if (r.cls != RR_MISS) a.any_possible = 1;
        if (r.cls == RR_HIT && r.t < a.best_t) {
            a.best_t = r.t;
            a.best_tol = r.tol;
            a.best = i;
        }
    }
    return a;
}

/* A triangle hit's point and barycentrics: the hit point lies on (near) the
 * triangle's box, and (1 - u - v) v0 + u v1 + v v2 is org + t dir (where the
 * distance is judged: r->tol finite). */
static inline int rr_check_hit_point(const rr_scene *s, const aacbvh_ray *ray, const aacbvh_hit *hit,
                                     const rr_prim *r, char *msg, size_t msg_size) {
    const size_t p = hit->prim_id;
    double L = 0.0, e[3][3], emax = 0.0, n[3], err = 0.0;
    const float *q[3];
    for (int j = 0; j < 3; ++j) {
        q[j] = rr_vertex(s, p, j);
        for (int k = 0; k < 3; ++k) L = fmax(L, fabs((double)q[j][k] - ray->org[k]));
    }
    for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) e[j][k] = (double)q[(j + 1) % 3][k] - q[j][k];
        emax = fmax(emax, rr_len(e[j]));
    }
    rr_cross(e[0], e[1], n);
    const double box_scale = rr_len(n) > 0.0 ? L + RR_SLIVER * emax * emax * emax / rr_len(n) : L;
    for (int k = 0; k < 3; ++k) {
        const double x = (double)ray->org[k] + (double)hit->t * ray->dir[k];
        const double lo = fmin(q[0][k], fmin(q[1][k], q[2][k])), hi = fmax(q[0][k], fmax(q[1][k], q[2][k]));
        const double slack = 1e-4 * box_scale + 1e-4 * fabs((double)hit->t * ray->dir[k]) +
                             0x1p-146 * fabs((double)ray->dir[k]) + 1e-300;
        if (x < lo - slack || x > hi + slack) {
            snprintf(msg, msg_size, "hit point of triangle %zu off its box on axis %d (%.9g not in [%.9g, %.9g])", p,
                     k, x, lo, hi);
            return 0;
        }
        const double on_tri = (1.0 - hit->u - hit->v) * q[0][k] + (double)hit->u * q[1][k] + (double)hit->v * q[2][k];
        err = fmax(err, fabs(on_tri - x));
    }
    /* The barycentrics are as good as t: its tolerance as a distance, plus
     * ten times the rounding distance. */
    if (isfinite(r->tol) && err > 10.0 * RR_POS_REL * L + r->tol * rr_dir_len(ray)) {
        snprintf(msg, msg_size, "triangle %zu: u, v = %.9g, %.9g put the hit point %.3g away from org + t dir", p,
                 (double)hit->u, (double)hit->v, err);
        return 0;
    }
    return 1;
}

/*
 * Checks one answer against the reference `ref` (from rr_reference) over the
 * scene. Returns 1 if it keeps the documented promise, else 0 with a message
 * in msg:
 *  - an invalid ray misses; a miss is (t, u, v) = (inf, 0, 0) and is wrong
 *    when a certain hit exists;
 *  - a hit names a primitive in range that is not a certain miss, at a finite
 *    t in [tmin, tmax], within the tolerance of its exact distance, no
 *    farther than the nearest certain hit (plus its tolerance), and is that
 *    nearest primitive unless another candidate ties with it;
 *  - a triangle hit's point lies on the triangle's box and matches u, v
 *    (rr_check_hit_point); a box hit has u = v = 0;
 *  - occluded (unless < 0: not given) is 0 or 1 and agrees with the closest
 *    hit.
 * *max_rel_err_out (may be NULL) is raised to the largest |t - t_exact| / tol seen.
 */
static inline int rr_check(const rr_scene *s, const rr_answer *ref, const aacbvh_ray *ray, const aacbvh_hit *hit,
                           int occluded, char *msg, size_t msg_size, double *max_rel_err_out) {
    const int hit_something = hit->prim_id != AACBVH_INVALID_ID;
    if (occluded >= 0 && occluded != hit_something) {
        snprintf(msg, msg_size, "occluded %d, but the closest hit is prim %u", occluded, hit->prim_id);
        return 0;
    }
    if (!hit_something) {
        if (!(hit->t == INFINITY && hit->u == 0.0f && hit->v == 0.0f)) {
            snprintf(msg, msg_size, "a miss with t, u, v = %.9g, %.9g, %.9g", (double)hit->t, (double)hit->u,
                     (double)hit->v);
            return 0;
        }
        if (ref->best != (size_t)-1) {
            snprintf(msg, msg_size, "missed; reference hits primitive %zu at t = %.9g", ref->best, ref->best_t);
            return 0;
        }
        return 1;
    }
    if (!rr_ray_valid(ray)) {
        snprintf(msg, msg_size, "an invalid ray hit primitive %u", hit->prim_id);
        return 0;
    }
    if (hit->prim_id >= s->count) {
        snprintf(msg, msg_size, "hit id %u out of range", hit->prim_id);
        return 0;
    }
    const size_t p = hit->prim_id;
    const rr_prim r = rr_primitive(s, ray, p);
    if (r.cls == RR_MISS) {
        snprintf(msg, msg_size, "hit primitive %zu at t = %.9g, which the reference misses", p, (double)hit->t);
        return 0;
    }
    if (!(hit->t >= ray->tmin && hit->t <= ray->tmax) || !isfinite(hit->t)) {
        snprintf(msg, msg_size, "t = %.9g outside [%.9g, %.9g]", (double)hit->t, (double)ray->tmin,
                 (double)ray->tmax);
        return 0;
    }
    if (s->boxes) {
        if (hit->u != 0.0f || hit->v != 0.0f) {
            snprintf(msg, msg_size, "box %zu hit with u, v = %.9g, %.9g", p, (double)hit->u, (double)hit->v);
            return 0;
        }
    } else if (!rr_check_hit_point(s, ray, hit, &r, msg, msg_size)) {
        return 0;
    }
    if (isfinite(r.t_tol)) {
        const double err = fabs((double)hit->t - r.t);
        if (max_rel_err_out && err / r.t_tol > *max_rel_err_out) *max_rel_err_out = err / r.t_tol;
        if (err > r.t_tol) {
            snprintf(msg, msg_size,
                     "primitive %zu: t = %.9g, exact %.12g (tolerance %.3g); ray org %.9g %.9g %.9g dir %.9g %.9g "
                     "%.9g",
                     p, (double)hit->t, r.t, r.t_tol, (double)ray->org[0], (double)ray->org[1], (double)ray->org[2],
                     (double)ray->dir[0], (double)ray->dir[1], (double)ray->dir[2]);
            return 0;
        }
    }
    if (ref->best != (size_t)-1 && (double)hit->t > ref->best_t + ref->best_tol) {
        snprintf(msg, msg_size, "hit primitive %zu at t = %.9g behind primitive %zu at %.9g", p, (double)hit->t,
                 ref->best, ref->best_t);
        return 0;
    }
    /* The nearest primitive, unless another candidate ties with it. */
    if (ref->best != (size_t)-1 && p != ref->best && isfinite(r.tol) && r.t > ref->best_t + ref->best_tol + r.tol) {
        snprintf(msg, msg_size, "hit primitive %zu at %.9g, but primitive %zu is nearer at %.9g", p, r.t, ref->best,
                 ref->best_t);
        return 0;
    }
    return 1;
}

/* rr_check() against a reference computed for this one answer. */
static inline int rr_check_hit(const rr_scene *s, const aacbvh_ray *ray, const aacbvh_hit *hit, int occluded,
                               char *msg, size_t msg_size, double *max_rel_err_out) {
    const rr_answer ref = rr_reference(s, ray);
    return rr_check(s, &ref, ray, hit, occluded, msg, msg_size, max_rel_err_out);
}

/* Distance from (px, py) to the segment p q (x and y only). */
static inline double rr_segment_distance_2d(double px, double py, const float *p, const float *q) {
    const double ex = (double)q[0] - p[0], ey = (double)q[1] - p[1];
    const double rx = px - p[0], ry = py - p[1];
    const double ee = ex * ex + ey * ey;
    double s = ee > 0.0 ? (rx * ex + ry * ey) / ee : 0.0;
    s = s < 0.0 ? 0.0 : s > 1.0 ? 1.0 : s;
    return hypot(rx - s * ex, ry - s * ey);
}

/*
 * Whether triangle (a, b, c), seen along z, contains the point (px, py):
 * RR_EITHER within `margin` of one of its edges, else RR_HIT inside (either
 * winding) or RR_MISS outside; a triangle of zero area contains nothing. In
 * double: with float inputs each edge function rounds once, so its sign is
 * exact away from the edge.
 */
static inline int rr_point_in_triangle_2d(double px, double py, const float *a, const float *b, const float *c,
                                          double margin) {
    const float *v[3] = {a, b, c};
    int pos = 0, neg = 0;
    for (int i = 0; i < 3; ++i)
        if (rr_segment_distance_2d(px, py, v[i], v[(i + 1) % 3]) <= margin) return RR_EITHER;
    for (int i = 0; i < 3; ++i) {
        const float *p = v[i], *q = v[(i + 1) % 3];
        const double side = ((double)q[0] - p[0]) * (py - p[1]) - ((double)q[1] - p[1]) * (px - p[0]);
        pos += side > 0.0;
        neg += side < 0.0;
    }
    return (pos == 3 || neg == 3) ? RR_HIT : RR_MISS;
}

#endif /* AACBVH_TESTS_RAY_REFERENCE_H */
