// What both traversals (binary and wide) share: which rays are valid, the
// miss record, and the leaf-primitive tests for triangles and boxes. The
// traversals hand the adapters a leaf slot (an index into Bvh::prim_ids);
// each adapter finds that slot's primitive its own way.
#pragma once

#include <cfloat>
#include <cmath>
#include <cstdint>

#include "aacbvh/aacbvh.h"
#include "core/geometry.h"
#include "trace/ray_box.h"
#include "trace/triangle_intersect.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace aacbvh {

/// A ray with a NaN field, an infinite origin or direction component, or a
/// zero direction misses everything (an infinite tmax is normal use).
inline bool ray_is_valid(const aacbvh_ray &ray) {
    for (int k = 0; k < 3; ++k)
        if (!std::isfinite(ray.org[k]) || !std::isfinite(ray.dir[k])) return false;
    if (std::isnan(ray.tmin) || std::isnan(ray.tmax)) return false;
    return ray.dir[0] != 0.0f || ray.dir[1] != 0.0f || ray.dir[2] != 0.0f;
}

/// Whether ScaledRay (below) would take the ray as it is: valid
/// (ray_is_valid()) and its largest direction component in [2^-32, 2^32].
/// The common case, decided with two vector compares instead of a branch
/// per field: the origin below FLT_MAX and the direction below 2^32 in
/// magnitude (so finite), tmin and tmax not NaN (an ordered compare is false
/// for NaN), and some direction component at least 2^-32 (so non-zero).
inline bool ray_is_plain(const aacbvh_ray &ray) {
#if defined(__SSE2__)
    static_assert(sizeof(aacbvh_ray) == 32, "org, tmin, dir, tmax: two rows of four floats");
    const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7FFFFFFF));
    const __m128 o = _mm_and_ps(_mm_loadu_ps(ray.org), abs_mask); // |org|, |tmin|
    const __m128 d = _mm_and_ps(_mm_loadu_ps(ray.dir), abs_mask); // |dir|, |tmax|
    const int ok = _mm_movemask_ps(_mm_cmple_ps(o, _mm_setr_ps(FLT_MAX, FLT_MAX, FLT_MAX, INFINITY))) &
                   _mm_movemask_ps(_mm_cmple_ps(d, _mm_setr_ps(0x1p32f, 0x1p32f, 0x1p32f, INFINITY)));
    const int big = _mm_movemask_ps(_mm_cmpge_ps(d, _mm_set1_ps(0x1p-32f))) & 7;
    return ok == 15 && big != 0;
#else
    if (!ray_is_valid(ray)) return false;
    const float m = std::fmax(std::fabs(ray.dir[0]), std::fmax(std::fabs(ray.dir[1]), std::fabs(ray.dir[2])));
    return m >= 0x1p-32f && m <= 0x1p32f;
#endif
}

/// A ray whose direction is far from unit length, traversed as its twin
/// with the direction scaled by a power of two (exactly) and t scaled to
/// match: org + t dir = org + (t 2^shift) (dir 2^-shift). Without it, a
/// direction like (1e-40, 0, 0) overflows 1 / dir and misses a triangle it
/// reaches at t = 1e37. Directions whose largest component lies in
/// [2^-32, 2^32] are left as they are (shift 0), so ordinary rays take the
/// usual path bit for bit. The window is cut to [-FLT_MAX, FLT_MAX] first (a
/// hit's t is always finite) and scaled rounding inwards.
struct ScaledRay {
    aacbvh_ray ray;
    int shift = 0;

    ScaledRay() = default; ///< no ray yet (shift 0: unscale() changes nothing)
    explicit ScaledRay(const aacbvh_ray &r) : ray(r) {
        // Comparisons, not std::fmax (a libm call per ray): the direction is
        // finite here (ray_is_valid()).
        const float ax = std::fabs(r.dir[0]), ay = std::fabs(r.dir[1]), az = std::fabs(r.dir[2]);
        const float m = ax > ay ? (ax > az ? ax : az) : (ay > az ? ay : az);
        if (m >= 0x1p-32f && m <= 0x1p32f) return;
        int e;
        std::frexp(m, &e); // m = f 2^e, f in [0.5, 1)
        shift = e;
        for (int k = 0; k < 3; ++k) ray.dir[k] = std::ldexp(r.dir[k], -e);
        ray.tmin = scale_bound(std::fmax(r.tmin, -FLT_MAX), e, +1);
        ray.tmax = scale_bound(std::fmin(r.tmax, FLT_MAX), e, -1);
    }
    /// t 2^e as a float rounded inwards (up for tmin, `towards` +1; down for
    /// tmax, -1): the scaled window never reaches past the caller's, also
    /// where the scaled bound falls into the denormals, so every hit found
    /// lies in [tmin, tmax] once scaled back (and an empty window stays empty).
    static float scale_bound(float t, int e, int towards) {
        const double exact = std::ldexp(double(t), e);
        float f = float(exact);
        if (towards > 0 && double(f) < exact) f = std::nextafter(f, INFINITY);
        if (towards < 0 && double(f) > exact) f = std::nextafter(f, -INFINITY);
        return f;
    }
    /// The hit of the scaled ray as a hit of the caller's ray.
    /// Exact: the scaled window lies within [-FLT_MAX, FLT_MAX] 2^shift.
    void unscale(aacbvh_hit &hit) const {
        if (shift != 0 && hit.prim_id != AACBVH_INVALID_ID) hit.t = std::ldexp(hit.t, -shift);
    }
};

/// The ray a traversal runs for `ray`, or null for an invalid ray (it
/// misses everything): the caller's own ray when it is plain
/// (ray_is_plain(), no copy), else its scaled twin, made in `scaled`; the
/// traversal's hit goes through scaled.unscale() afterwards either way.
inline const aacbvh_ray *traced_ray(const aacbvh_ray &ray, ScaledRay &scaled) {
    if (ray_is_plain(ray)) return &ray;
    if (!ray_is_valid(ray)) return nullptr;
    scaled = ScaledRay(ray);
    return &scaled.ray;
}

/// Whether the ray's origin lies in the box `bounds` (lo x, y, z, then hi x,
/// y, z, at 16-byte aligned offsets 0 and 4; closed). False for a NaN
/// coordinate.
inline bool origin_in_bounds(const float *bounds, const aacbvh_ray &ray) {
#if defined(__SSE2__)
    const __m128 org = _mm_loadu_ps(ray.org); // x, y, z, tmin (lane 3 unused)
    const __m128 in = _mm_and_ps(_mm_cmple_ps(_mm_load_ps(bounds), org), _mm_cmple_ps(org, _mm_load_ps(bounds + 4)));
    return (_mm_movemask_ps(in) & 7) == 7;
#else
    for (int k = 0; k < 3; ++k)
        if (!(bounds[k] <= ray.org[k] && ray.org[k] <= bounds[4 + k])) return false;
    return true;
#endif
}

inline void set_miss(aacbvh_hit &hit) {
    hit.t = INFINITY;
    hit.u = 0.0f;
    hit.v = 0.0f;
    hit.prim_id = AACBVH_INVALID_ID;
}

/// Leaf tests of triangle geometry: the watertight test on the caller's vertices.
struct TrianglePrimitives {
    const Geometry &geometry;
    const uint32_t *prim_ids;
    TriangleRay ray;

    bool intersect(uint32_t slot, float tmin, float tmax, float &t, float &u, float &v) const {
        const float *p[3];
        geometry.triangle(prim_ids[slot], p);
        return intersect_triangle(ray, p[0], p[1], p[2], tmin, tmax, t, u, v);
    }
};

/// Leaf tests of triangle geometry from the BVH's own copy
/// (AACBVH_TRIANGLES_COPIED): slot i's three vertices are the nine floats at
/// triangles[9 i], so a leaf's triangles are contiguous. Same test, same
/// vertices as TrianglePrimitives, hence the same results.
struct CopiedTrianglePrimitives {
    const float *triangles;
    TriangleRay ray;

    bool intersect(uint32_t slot, float tmin, float tmax, float &t, float &u, float &v) const {
        const float *p = triangles + 9 * size_t(slot);
        return intersect_triangle(ray, p, p + 3, p + 6, tmin, tmax, t, u, v);
    }
};

/// Leaf tests of box geometry: t is where the ray enters the box (clamped to tmin).
struct BoxPrimitives {
    const Geometry &geometry;
    const uint32_t *prim_ids;
    const BoxRay &ray;

    bool intersect(uint32_t slot, float tmin, float tmax, float &t, float &u, float &v) const {
        const float *b = geometry.box_ptr(prim_ids[slot]);
        u = 0.0f;
        v = 0.0f;
        return ray_box_primitive(ray, b, b + 3, tmin, tmax, t);
    }
};

/// Any leaf-test adapter above, counting its tests into *tests (for the tests
/// of the visiting order; a traversal instantiated with it answers alike).
template <class Primitives> struct CountedPrimitives {
    const Primitives &prims;
    uint64_t *tests;
    bool intersect(uint32_t slot, float tmin, float tmax, float &t, float &u, float &v) const {
        ++*tests;
        return prims.intersect(slot, tmin, tmax, t, u, v);
    }
};

template <class Primitives> CountedPrimitives<Primitives> count_tests(const Primitives &prims, uint64_t *tests) {
    return CountedPrimitives<Primitives>{prims, tests};
}

/// Calls visit(prims) with the leaf-test adapter that fits the geometry:
/// boxes, the BVH's own triangle copy (when `triangles` is non-null), or the
/// caller's triangles. Both traversals dispatch here.
template <class Visit>
bool with_primitives(const Geometry &geometry, const uint32_t *prim_ids, const float *triangles,
                     const aacbvh_ray &ray, const BoxRay &box_ray, Visit &&visit) {
    if (geometry.kind == GeometryKind::Boxes) return visit(BoxPrimitives{geometry, prim_ids, box_ray});
    if (triangles) return visit(CopiedTrianglePrimitives{triangles, make_triangle_ray(ray.org, ray.dir)});
    return visit(TrianglePrimitives{geometry, prim_ids, make_triangle_ray(ray.org, ray.dir)});
}

/// The closest-hit record at the end of a traversal.
inline void write_closest(bool found, float t, float u, float v, uint32_t prim, aacbvh_hit &hit) {
    if (!found) {
        set_miss(hit);
        return;
    }
    hit.t = t;
    hit.u = u;
    hit.v = v;
    hit.prim_id = prim;
}

} // namespace aacbvh
