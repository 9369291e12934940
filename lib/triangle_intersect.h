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

#include <cmath>

namespace aacbvh {

/// Per-ray constants of the watertight test (section 3 of the paper).
struct TriangleRay {
    float org[3];
    int kx, ky, kz;   ///< kz: dominant axis of dir; kx, ky the other two, swapped to keep winding
    float sx, sy, sz; ///< shear: dir[kx] / dir[kz], dir[ky] / dir[kz], 1 / dir[kz]
};

/// Precomputes the shear for a ray with a finite, non-zero direction.
inline TriangleRay make_triangle_ray(const float org[3], const float dir[3]) {
    TriangleRay r;
    r.org[0] = org[0]; r.org[1] = org[1]; r.org[2] = org[2];
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
    r.sz = 1.0f / dir[kz];
    return r;
}

/// Two-sided watertight test of triangle (p0, p1, p2) against the ray.
/// On a hit with tmin <= t <= tmax (t finite) sets t and the barycentrics
/// u, v of the hit point (1 - u - v) * p0 + u * p1 + v * p2 and returns true.
/// A triangle seen edge-on (det == 0) is missed.
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
    float eu = cx * by - cy * bx;
    float ev = ax * cy - ay * cx;
    float ew = bx * ay - by * ax;
    // On an edge in single precision: decide the sign exactly. Products of
    // floats are exact in double, so only the difference rounds, and its sign
    // is right (paper, section 4.1).
    if (eu == 0.0f || ev == 0.0f || ew == 0.0f) {
        eu = float(double(cx) * double(by) - double(cy) * double(bx));
        ev = float(double(ax) * double(cy) - double(ay) * double(cx));
        ew = float(double(bx) * double(ay) - double(by) * double(ax));
    }
    // Two-sided: all three on one side (zeros are on both).
    if ((eu < 0.0f || ev < 0.0f || ew < 0.0f) && (eu > 0.0f || ev > 0.0f || ew > 0.0f))
        return false;
    const float det = eu + ev + ew;
    if (det == 0.0f) return false;

    const float tscaled = eu * (r.sz * az) + ev * (r.sz * bz) + ew * (r.sz * cz);
    // A true division for t (one rounding: a hit exactly at tmin or tmax
    // stays in range); the barycentrics share one reciprocal.
    const float th = tscaled / det;
    if (!(th >= tmin && th <= tmax) || std::isinf(th)) return false;
    const float inv_det = 1.0f / det;
    t = th;
    u = ev * inv_det;
    v = ew * inv_det;
    return true;
}

} // namespace aacbvh
