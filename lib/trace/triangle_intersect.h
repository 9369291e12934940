// Watertight ray/triangle intersection (Woop, Benthin, Wald, "Watertight
// Ray/Triangle Intersection", JCGT 2(1), 2013), two-sided.
//
// The ray is sheared and scaled so that it runs along +z from the origin; the
// triangle's vertices are transformed the same way, and the 2D edge functions
// U, V, W at the origin decide the hit. Each transformed vertex is computed
// once per triangle by the same expression, so two triangles sharing an edge
// see the same edge function values (up to sign): no ray leaks through a
// shared edge or vertex.
#pragma once

#include <algorithm>
#include <cfloat>
#include <cmath>

namespace aacbvh {

// Whether the compiler has __builtin_shufflevector (GCC 12, Clang); two
// steps, since a preprocessor without __has_builtin cannot parse its call.
#if defined(__has_builtin)
#if __has_builtin(__builtin_shufflevector)
#define AACBVH_HAS_SHUFFLEVECTOR 1
#endif
#endif

/// Four doubles, one per axis and a spare 0 (GCC / Clang vector extension):
/// the hit distance's differences, products and comparisons run on all three
/// axes at once, each lane rounding exactly as the scalar operation would
/// (AVX registers in the AVX2 kernel, SSE2 pairs elsewhere; no FMA anywhere,
/// lib/CMakeLists.txt).
typedef double Double4 __attribute__((vector_size(32)));
typedef long long Long4 __attribute__((vector_size(32)));

/// Per-ray constants of the watertight test (section 3 of the paper).
struct TriangleRay {
    float org[3];
    Double4 org_d, dir_d; ///< org and dir in double (lane 3: 0), for the hit distance (triangle_distance_of())
    int kx, ky, kz;   ///< kz: dominant axis of dir; kx, ky the other two, swapped to keep winding
    float sx, sy;     ///< shear: dir[kx] / dir[kz], dir[ky] / dir[kz] (at most 1 in magnitude)
};

/// Precomputes the shear for a ray with a finite, non-zero direction.
inline TriangleRay make_triangle_ray(const float org[3], const float dir[3]) {
    TriangleRay r;
    r.org[0] = org[0]; r.org[1] = org[1]; r.org[2] = org[2];
    r.org_d = Double4{org[0], org[1], org[2], 0.0};
    r.dir_d = Double4{dir[0], dir[1], dir[2], 0.0};
    const float ax = std::fabs(dir[0]), ay = std::fabs(dir[1]), az = std::fabs(dir[2]);
    int kz = 0;
    if (ay > ax) kz = 1;
    if (az > (kz == 0 ? ax : ay)) kz = 2;
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    // A negative dir[kz] mirrors the sheared frame; swapping kx and ky mirrors
    // it back so the signs of U, V, W keep the triangle's winding.
    if (dir[kz] < 0.0f) { const int s = kx; kx = ky; ky = s; }
    r.kx = kx; r.ky = ky; r.kz = kz;
    r.sx = dir[kx] / dir[kz];
    r.sy = dir[ky] / dir[kz];
    return r;
}

/// Whether the triangle has non-zero area: its edge vectors' cross product in
/// double, where differences and products of floats of like magnitude are
/// exact, so collinear vertices give exactly zero. Called only on hits that
/// look degenerate in single precision.
inline bool has_area(const float *p0, const float *p1, const float *p2) {
    double e1[3], e2[3];
    for (int k = 0; k < 3; ++k) {
        e1[k] = double(p1[k]) - double(p0[k]);
        e2[k] = double(p2[k]) - double(p0[k]);
    }
    return e1[1] * e2[2] != e1[2] * e2[1] || e1[2] * e2[0] != e1[0] * e2[2] || e1[0] * e2[1] != e1[1] * e2[0];
}

/// Where a triangle's vertices are read from: at(i, a) is coordinate a of
/// vertex i. The distance and the edge finish below are written once over
/// it, so a caller can read the vertices where they lie (three pointers
/// here; a packet lane in bvh/wide8_bvh.h) without copying them into arrays
/// whose addresses would keep them in memory.
struct VertexPointers {
    const float *p[3];
    float at(int i, int a) const { return p[i][a]; }
};

/// The vertices of `tri` copied into p[3][3], for the rare paths that take
/// pointers.
template <class Vertices> inline void copy_vertices(const Vertices &tri, float p[3][3]) {
    for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a) p[i][a] = tri.at(i, a);
}

/// The rare tail of triangle_distance_of(): the plane point lies outside the
/// triangle's box (or there is no plane point), so t becomes the nearest
/// distance at which the ray is inside the box. Out of line, so the hot path
/// never needs the vertices in memory.
template <class Vertices>
[[gnu::noinline, gnu::cold]] bool clamp_to_triangle_box(const TriangleRay &r, const Vertices &tri, double plane,
                                                         double &t) {
    double enter = -INFINITY, leave = INFINITY;
    for (int k = 0; k < 3; ++k) {
        if (r.dir_d[k] == 0.0) continue;
        const float c0 = tri.at(0, k), c1 = tri.at(1, k), c2 = tri.at(2, k);
        const double lo = double(std::min(std::min(c0, c1), c2)) - r.org_d[k];
        const double hi = double(std::max(std::max(c0, c1), c2)) - r.org_d[k];
        const double a = lo / r.dir_d[k], b = hi / r.dir_d[k];
        enter = std::max(enter, std::min(a, b));
        leave = std::min(leave, std::max(a, b));
    }
    // A plane the ray runs along in double (a nearly collinear triangle the
    // edge functions still found): where the ray enters the box.
    t = std::isfinite(plane) ? std::max(std::min(plane, leave), enter) : enter;
    return std::isfinite(t);
}

/// triangle_distance_of()'s first part, which a caller may make elsewhere by
/// the same operations in the same order (for four triangles at once, say):
/// the plane distance and whether the plane point lies in the triangle's box.
struct PlaneDistance {
    double plane;
    bool inside;
};

/// triangle_distance_of()'s answer from its first part: the plane distance
/// where the plane point lies in the triangle's box, else the clamped one.
template <class Vertices>
inline bool triangle_distance_from(const TriangleRay &r, const Vertices &tri, PlaneDistance d, double &t) {
    t = d.plane;
    if (d.inside) return true;
    return clamp_to_triangle_box(r, tri, d.plane, t);
}

/// The distance along the ray to the triangle, for a ray the edge functions
/// have found inside it: the plane distance (p0 - org) . n / (dir . n), n =
/// (p1 - p0) x (p2 - p0), in double, kept within the stretch of the ray that
/// lies inside the triangle's bounding box.
///
/// Why double: the paper's single-precision distance, the sum of U, V, W
/// times the vertices' z over det, adds terms as large as the distance to the
/// vertices, which cancel when the hit is near and the triangle large (t was
/// 1e-3 off, relative). In double the differences of floats are exact, each
/// product rounds once, and the one cancellation (in the numerator) costs
/// bits that double has to spare: t comes out within an ulp of the exact
/// plane distance (the bound is in the header, at aacbvh_bvh_intersect).
///
/// Why the box: the edge functions decide a hit in single precision, so a ray
/// that passes within rounding distance of an edge may be accepted although
/// its exact path misses the triangle; for a ray grazing the plane, the
/// plane distance of such a hit can then lie outside the triangle's box, and
/// the BVH would cull the triangle or not depending on the order of the
/// visits. Clamped to the box, t is where the node tests expect it. For every
/// other hit the plane point lies in the box and nothing changes.
/// Returns false when no finite distance comes out.
template <class Vertices> inline bool triangle_distance_of(const TriangleRay &r, const Vertices &tri, double &t) {
    const Double4 p0{tri.at(0, 0), tri.at(0, 1), tri.at(0, 2), 0.0};
    const Double4 p1{tri.at(1, 0), tri.at(1, 1), tri.at(1, 2), 0.0};
    const Double4 p2{tri.at(2, 0), tri.at(2, 1), tri.at(2, 2), 0.0};
    const Double4 e1 = p1 - p0, e2 = p2 - p0, w = p0 - r.org_d;
    // n = e1 x e2: lane k is e1[k+1] e2[k+2] - e1[k+2] e2[k+1], from the
    // lanes rotated to (y, z, x) and (z, x, y): one permute each where the
    // compiler has __builtin_shufflevector (GCC 12, Clang), else built lane by
    // lane (the same values, a few more instructions).
#if defined(AACBVH_HAS_SHUFFLEVECTOR)
    const Double4 e1_yzx = __builtin_shufflevector(e1, e1, 1, 2, 0, 3), e1_zxy = __builtin_shufflevector(e1, e1, 2, 0, 1, 3);
    const Double4 e2_yzx = __builtin_shufflevector(e2, e2, 1, 2, 0, 3), e2_zxy = __builtin_shufflevector(e2, e2, 2, 0, 1, 3);
#else
    const Double4 e1_yzx{e1[1], e1[2], e1[0], 0.0}, e1_zxy{e1[2], e1[0], e1[1], 0.0};
    const Double4 e2_yzx{e2[1], e2[2], e2[0], 0.0}, e2_zxy{e2[2], e2[0], e2[1], 0.0};
#endif
    const Double4 n = e1_yzx * e2_zxy - e1_zxy * e2_yzx;
    const Double4 dn = r.dir_d * n, wn = w * n;
    const double den = (dn[0] + dn[1]) + dn[2];
    t = ((wn[0] + wn[1]) + wn[2]) / den;
    // The plane point, relative to p0, inside the box of the three vertices
    // (the common case): t stands. Comparisons are false for NaN; lane 3
    // (0 * t - 0) is left out of the answer. An axis on which the triangle is
    // flat (its vertices share the coordinate: floors and walls) needs no
    // test: the plane is that coordinate, so the exact plane point lies on it,
    // and x there is rounding around 0 that failed the test half the time,
    // sending those hits to the clamp for nothing (docs/PERFORMANCE.md, row
    // 299).
    const Double4 zero{0.0, 0.0, 0.0, 0.0};
    const Double4 x = Double4{t, t, t, t} * r.dir_d - w;
    const Double4 lo = e1 < e2 ? e1 : e2, hi = e1 > e2 ? e1 : e2;
    const Long4 flat = (e1 == zero) & (e2 == zero);
    const Long4 inside = ((x >= (lo < zero ? lo : zero)) & (x <= (hi > zero ? hi : zero))) | flat;
    return triangle_distance_from(r, tri, PlaneDistance{t, (inside[0] & inside[1] & inside[2]) != 0}, t);
}

/// A distance th found in double (`found`: triangle_distance_of()'s answer)
/// rounded to the float that is reported, and whether that float lies in
/// [tmin, tmax]. The window is applied to the reported t, not to the double
/// before rounding: a traversal's window ends at the best t reported so far,
/// and a second triangle at exactly that t (a tie, decided by prim_id) must
/// be accepted whichever was found first.
inline bool report_distance(bool found, double th, float tmin, float tmax, float &t) {
    if (!found || !(std::fabs(th) <= FLT_MAX)) return false;
    t = float(th);
    return t >= tmin && t <= tmax;
}

/// triangle_distance_of() reported: report_distance().
template <class Vertices>
inline bool reported_distance_of(const TriangleRay &r, const Vertices &tri, float tmin, float tmax, float &t) {
    double th;
    const bool found = triangle_distance_of(r, tri, th);
    return report_distance(found, th, tmin, tmax, t);
}

inline bool reported_distance(const TriangleRay &r, const float *p0, const float *p1, const float *p2, float tmin,
                              float tmax, float &t) {
    return reported_distance_of(r, VertexPointers{{p0, p1, p2}}, tmin, tmax, t);
}

/// The tail of intersect_triangle() in double precision, from the same sheared
/// vertices: products of floats are exact in double, so each edge function
/// rounds once (in the difference) and its sign is exact (paper, section
/// 4.1), and nothing overflows or underflows for float inputs. Used when the
/// single-precision edge functions are zero, denormal, infinite or NaN (a ray
/// on an edge; coordinates so small or large that the products leave float
/// range), or the distance does not fit a float.
inline bool intersect_triangle_double(const TriangleRay &r, const float *p0, const float *p1, const float *p2,
                                      float ax, float ay, float bx, float by, float cx, float cy, float tmin,
                                      float tmax, float &t, float &u, float &v) {
    const double eu = double(cx) * double(by) - double(cy) * double(bx);
    const double ev = double(ax) * double(cy) - double(ay) * double(cx);
    const double ew = double(bx) * double(ay) - double(by) * double(ax);
    if ((eu < 0.0 || ev < 0.0 || ew < 0.0) && (eu > 0.0 || ev > 0.0 || ew > 0.0)) return false;
    const double det = eu + ev + ew;
    if (det == 0.0) return false;
    if (!reported_distance(r, p0, p1, p2, tmin, tmax, t)) return false;
    u = float(ev / det);
    v = float(ew / det);
    return true;
}

/// Two-sided watertight test of triangle (p0, p1, p2) against the ray.
/// On a hit with tmin <= t <= tmax (t finite) sets t and the barycentrics
/// u, v of the hit point (1 - u - v) * p0 + u * p1 + v * p2 and returns true.
/// A triangle seen edge-on (det == 0) is missed, and so is a triangle of zero
/// area (collinear vertices).
inline bool intersect_triangle(const TriangleRay &r, const float *p0, const float *p1,
                               const float *p2, float tmin, float tmax, float &t, float &u,
                               float &v) {
    const int kx = r.kx, ky = r.ky, kz = r.kz;
    // Vertices relative to the origin, then sheared (the z scaling waits).
    const float az = p0[kz] - r.org[kz];
    const float bz = p1[kz] - r.org[kz];
    const float cz = p2[kz] - r.org[kz];
    const float ax = (p0[kx] - r.org[kx]) - r.sx * az;
    const float ay = (p0[ky] - r.org[ky]) - r.sy * az;
    const float bx = (p1[kx] - r.org[kx]) - r.sx * bz;
    const float by = (p1[ky] - r.org[ky]) - r.sy * bz;
    const float cx = (p2[kx] - r.org[kx]) - r.sx * cz;
    const float cy = (p2[ky] - r.org[ky]) - r.sy * cz;

    // Edge functions: U weighs vertex 0 (edge p1-p2), V vertex 1, W vertex 2.
    // Rounding is monotonic, so a non-zero single-precision value has the
    // exact sign; zero, denormal or non-finite values go to the double path.
    const float eu = cx * by - cy * bx;
    const float ev = ax * cy - ay * cx;
    const float ew = bx * ay - by * ax;
    const float mu = std::fabs(eu), mv = std::fabs(ev), mw = std::fabs(ew);
    const bool in_range = mu >= FLT_MIN && mv >= FLT_MIN && mw >= FLT_MIN &&
                          mu <= FLT_MAX && mv <= FLT_MAX && mw <= FLT_MAX;
    if (!in_range) {
        // Cheap rejection first: a sign pair that is certain (both non-zero
        // and finite) already proves a miss.
        if ((eu < 0.0f || ev < 0.0f || ew < 0.0f) && (eu > 0.0f || ev > 0.0f || ew > 0.0f) &&
            !std::isnan(eu) && !std::isnan(ev) && !std::isnan(ew))
            return false;
        if (!has_area(p0, p1, p2)) return false;
        return intersect_triangle_double(r, p0, p1, p2, ax, ay, bx, by, cx, cy, tmin, tmax, t, u, v);
    }
    // Two-sided: all three on one side.
    if ((eu < 0.0f || ev < 0.0f || ew < 0.0f) && (eu > 0.0f || ev > 0.0f || ew > 0.0f))
        return false;
    const float det = eu + ev + ew;
    // A hit this close to cancellation may be a zero-area triangle whose
    // sheared vertices came out of rounding slightly apart: its distance
    // would be noise. All three have one sign, so det has no cancellation;
    // the test is against the products' size.
    const float mag = std::fabs(cx * by) + std::fabs(ax * cy) + std::fabs(bx * ay);
    if (mu + mv + mw <= 0x1p-18f * mag && !has_area(p0, p1, p2)) return false;

    if (!std::isfinite(det))
        return intersect_triangle_double(r, p0, p1, p2, ax, ay, bx, by, cx, cy, tmin, tmax, t, u, v);
    if (!reported_distance(r, p0, p1, p2, tmin, tmax, t)) return false;
    const float inv_det = 1.0f / det;
    u = ev * inv_det;
    v = ew * inv_det;
    return true;
}

/// intersect_triangle() on a copy of `tri`'s vertices: the edge finish's
/// rare cases, out of line.
template <class Vertices>
[[gnu::noinline, gnu::cold]] bool intersect_triangle_of(const TriangleRay &r, const Vertices &tri, float tmin,
                                                         float tmax, float &t, float &u, float &v) {
    float p[3][3];
    copy_vertices(tri, p);
    return intersect_triangle(r, p[0], p[1], p[2], tmin, tmax, t, u, v);
}

/// has_area() on a copy of `tri`'s vertices, out of line (rare).
template <class Vertices> [[gnu::noinline, gnu::cold]] bool has_area_of(const Vertices &tri) {
    float p[3][3];
    copy_vertices(tri, p);
    return has_area(p[0], p[1], p[2]);
}

/// intersect_triangle() for a caller that has already computed the
/// single-precision edge functions eu, ev, ew and mag (the sum of the
/// products' magnitudes, |cx by| + |ax cy| + |bx ay|) by the same operations
/// in the same order, e.g. for four triangles at once with SIMD: the same
/// result, without computing them again. The rare cases (values out of
/// float range, det overflowing) go to intersect_triangle() itself. With
/// Known, the caller has made the plane distance too (`known`,
/// PlaneDistance); otherwise `known` is not read.
///
/// The caller has already dropped the values with certain, mixed signs (a
/// packet filter's rejection): values in range (finite, normal, so no NaN)
/// then share one sign, and the two-sided test needs no second look.
template <bool Known, class Vertices>
inline bool finish_triangle_edges(const TriangleRay &r, const Vertices &tri, float eu, float ev, float ew, float mag,
                                  PlaneDistance known, float tmin, float tmax, float &t, float &u, float &v) {
    const float mu = std::fabs(eu), mv = std::fabs(ev), mw = std::fabs(ew);
    const bool in_range = mu >= FLT_MIN && mv >= FLT_MIN && mw >= FLT_MIN &&
                          mu <= FLT_MAX && mv <= FLT_MAX && mw <= FLT_MAX;
    if (!in_range) return intersect_triangle_of(r, tri, tmin, tmax, t, u, v);
    const float det = eu + ev + ew;
    if (mu + mv + mw <= 0x1p-18f * mag && !has_area_of(tri)) return false;
    if (!std::isfinite(det)) return intersect_triangle_of(r, tri, tmin, tmax, t, u, v);
    double th;
    const bool found = Known ? triangle_distance_from(r, tri, known, th) : triangle_distance_of(r, tri, th);
    if (!report_distance(found, th, tmin, tmax, t)) return false;
    const float inv_det = 1.0f / det;
    u = ev * inv_det;
    v = ew * inv_det;
    return true;
}

} // namespace aacbvh
