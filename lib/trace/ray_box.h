// Robust ray/box slab test (Ize, "Robust BVH Ray Traversal", JCGT 2(2), 2013).
//
// Slab distances are (plane - org) * (1 / dir). Each carries at most three
// roundings (subtraction, reciprocal, product), so its relative error is at
// most gamma(3) = 3 eps / (1 - 3 eps), eps = 2^-24; widening the exit distance
// by 2 gamma(3) of its magnitude makes the node test conservative: it never
// culls a ray that meets the box in exact arithmetic, flat boxes included
// (the entry and exit distances of a zero-thickness slab are the same
// computation, so the widening keeps them ordered).
//
// A zero direction component (+0 or -0) gives an infinite inverse of that
// sign. The slab distance is then +-inf, or NaN when the origin lies exactly
// on the plane (0 * inf). NaNs are dropped by the min/max order below: a
// comparison with NaN is false, so the running bound is kept, which treats
// the slab as unbounded there. That is conservative for nodes and, for box
// primitives, counts a ray running inside a box face as inside the box (boxes
// are closed).
#pragma once

#include <cfloat>
#include <cmath>

#include "core/box.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#define AACBVH_RAY_BOX_SSE 1
#endif

namespace aacbvh {

/// 2 * gamma(3), gamma(n) = n eps / (1 - n eps), eps = 2^-24.
constexpr float kTwoGamma3 = float(2.0 * (3.0 * 0x1p-24) / (1.0 - 3.0 * 0x1p-24));

/// For a window that starts at 0 or later, the exit distances can be widened
/// by scaling 1 / dir instead (Ize's own form; ray_box_from_zero()):
/// (plane - org) times inv * kFarScale carries four roundings, so it is at
/// least the exact exit distance times 1 + gamma(3) as long as that distance
/// is not negative, which covers an entry distance rounded up to gamma(3)
/// late. Exits behind the origin (a negative tmin) would shrink under the
/// scale: those rays keep the additive widening. kFarScale is 1 + 12 eps,
/// above the 1 + 7 eps the bound needs. What it saves: the widening's two
/// dependent operations on each node test's critical path; tmax is widened
/// once instead (exit_reach()).
constexpr float kFarScale = float(1.0 + 3.0 * (3.0 * 0x1p-24) / (1.0 - 3.0 * 0x1p-24)) * (1.0f + 0x1p-23f);

/// tmax widened as the node test widens an exit distance: a pending node
/// whose entry lies within it may still hold a hit at or before tmax.
inline float exit_reach(float tmax) { return tmax + std::fabs(tmax) * kTwoGamma3; }

/// Per-ray constants of the slab test.
struct BoxRay {
    float org[3];
    float inv[3]; ///< 1 / dir, +-inf for a +-0 component
    float inv_far[3]; ///< inv * kFarScale (ray_box_from_zero())
    bool neg[3];  ///< dir (sign bit) negative: the slab is entered at hi, left at lo
#if AACBVH_RAY_BOX_SSE
    // The same in lanes x, y, z; lane 3 of inv4 is NaN so that lane's slab
    // distances are NaN and drop out like those of a degenerate slab.
    __m128 org4, inv4;
    __m128 neg4; ///< all-ones lanes where neg
#endif
};

inline BoxRay make_box_ray(const float org[3], const float dir[3]) {
    BoxRay r;
    for (int k = 0; k < 3; ++k) {
        r.org[k] = org[k];
        r.inv[k] = 1.0f / dir[k];
        r.inv_far[k] = r.inv[k] * kFarScale;
        r.neg[k] = std::signbit(dir[k]);
    }
#if AACBVH_RAY_BOX_SSE
    r.org4 = _mm_setr_ps(r.org[0], r.org[1], r.org[2], 0.0f);
    r.inv4 = _mm_setr_ps(r.inv[0], r.inv[1], r.inv[2], NAN);
    r.neg4 = _mm_castsi128_ps(_mm_setr_epi32(-int(r.neg[0]), -int(r.neg[1]), -int(r.neg[2]), 0));
#endif
    return r;
}


/// Entry and exit distances of the ray through box (lo, hi), clipped to
/// [tmin, tmax]. NaN slab distances are dropped (see the file comment).
inline void slab_interval(const BoxRay &r, const float lo[3], const float hi[3], float tmin,
                          float tmax, float &t0, float &t1) {
    const float nx = ((r.neg[0] ? hi[0] : lo[0]) - r.org[0]) * r.inv[0];
    const float fx = ((r.neg[0] ? lo[0] : hi[0]) - r.org[0]) * r.inv[0];
    const float ny = ((r.neg[1] ? hi[1] : lo[1]) - r.org[1]) * r.inv[1];
    const float fy = ((r.neg[1] ? lo[1] : hi[1]) - r.org[1]) * r.inv[1];
    const float nz = ((r.neg[2] ? hi[2] : lo[2]) - r.org[2]) * r.inv[2];
    const float fz = ((r.neg[2] ? lo[2] : hi[2]) - r.org[2]) * r.inv[2];
    // "x > a ? x : a" keeps a when x is NaN (and compiles to maxss/minss).
    float a = tmin;
    a = nx > a ? nx : a;
    a = ny > a ? ny : a;
    a = nz > a ? nz : a;
    float b = tmax;
    b = fx < b ? fx : b;
    b = fy < b ? fy : b;
    b = fz < b ? fz : b;
    t0 = a;
    t1 = b;
}

/// Conservative test for BVH nodes: true if the ray may meet the box within
/// [tmin, tmax]; t_entry is then the (clipped) entry distance, for ordering.
/// t_exit is then the widened exit distance the entry was compared with.
inline bool ray_box_conservative(const BoxRay &r, const Box &box, float tmin, float tmax,
                                 float &t_entry, float &t_exit) {
    float t0, t1;
    slab_interval(r, box.lo, box.hi, tmin, tmax, t0, t1);
    // Widen by 2 gamma(3) of |t1| (Ize multiplies by 1 + 2 gamma(3); using the
    // magnitude keeps the widening outward for boxes behind a negative tmin).
    t1 += std::fabs(t1) * kTwoGamma3;
    t_entry = t0;
    t_exit = t1;
    return t0 <= t1;
}

inline bool ray_box_conservative(const BoxRay &r, const Box &box, float tmin, float tmax,
                                 float &t_entry) {
    float t_exit;
    return ray_box_conservative(r, box, tmin, tmax, t_entry, t_exit);
}

/// ray_box_conservative() for a window [tmin, tmax] with tmin >= 0: the exit
/// distances through inv_far, tmax widened by exit_reach(). As conservative,
/// with fewer dependent operations; the wide kernels' node test, lane for lane.
inline bool ray_box_from_zero(const BoxRay &r, const Box &box, float tmin, float tmax, float &t_entry) {
    float a = tmin, b = exit_reach(tmax);
    for (int k = 0; k < 3; ++k) {
        const float n = ((r.neg[k] ? box.hi[k] : box.lo[k]) - r.org[k]) * r.inv[k];
        const float f = ((r.neg[k] ? box.lo[k] : box.hi[k]) - r.org[k]) * r.inv_far[k];
        a = n > a ? n : a;
        b = f < b ? f : b;
    }
    t_entry = a;
    return a <= b;
}

/// ray_box_conservative() of two boxes at once (the two children of a node).
/// Returns bit 0 set if box a may be hit, bit 1 if box b may; t_a and t_b are
/// their clipped entry distances (meaningful where the bit is set), x_a and
/// x_b their widened exit distances (the ones the entries were compared
/// with). Gives the same results as two ray_box_conservative() calls: same
/// operations, same order, same roundings.
inline unsigned ray_box_pair_conservative(const BoxRay &r, const Box &a, const Box &b, float tmin,
                                          float tmax, float &t_a, float &t_b, float &x_a, float &x_b) {
#if AACBVH_RAY_BOX_SSE
    // A Box is six contiguous floats: load [lo0 lo1 lo2 hi0] and, without
    // reading past the box, [lo2 hi0 hi1 hi2] rotated to [hi0 hi1 hi2 lo2].
    const float *pa = reinterpret_cast<const float *>(&a);
    const float *pb = reinterpret_cast<const float *>(&b);
    const __m128 lo_a = _mm_loadu_ps(pa);
    const __m128 lo_b = _mm_loadu_ps(pb);
    __m128 hi_a = _mm_loadu_ps(pa + 2);
    __m128 hi_b = _mm_loadu_ps(pb + 2);
    hi_a = _mm_shuffle_ps(hi_a, hi_a, _MM_SHUFFLE(0, 3, 2, 1));
    hi_b = _mm_shuffle_ps(hi_b, hi_b, _MM_SHUFFLE(0, 3, 2, 1));
    const __m128 tlo_a = _mm_mul_ps(_mm_sub_ps(lo_a, r.org4), r.inv4);
    const __m128 thi_a = _mm_mul_ps(_mm_sub_ps(hi_a, r.org4), r.inv4);
    const __m128 tlo_b = _mm_mul_ps(_mm_sub_ps(lo_b, r.org4), r.inv4);
    const __m128 thi_b = _mm_mul_ps(_mm_sub_ps(hi_b, r.org4), r.inv4);
    // near = neg ? thi : tlo, far = neg ? tlo : thi (bitwise select).
    const __m128 d_a = _mm_and_ps(_mm_xor_ps(tlo_a, thi_a), r.neg4);
    const __m128 d_b = _mm_and_ps(_mm_xor_ps(tlo_b, thi_b), r.neg4);
    const __m128 tmin4 = _mm_set1_ps(tmin), tmax4 = _mm_set1_ps(tmax);
    // maxps/minps return the second operand when the first is NaN: NaN
    // distances (and lane 3) become tmin / tmax.
    const __m128 near_a = _mm_max_ps(_mm_xor_ps(tlo_a, d_a), tmin4);
    const __m128 far_a = _mm_min_ps(_mm_xor_ps(thi_a, d_a), tmax4);
    const __m128 near_b = _mm_max_ps(_mm_xor_ps(tlo_b, d_b), tmin4);
    const __m128 far_b = _mm_min_ps(_mm_xor_ps(thi_b, d_b), tmax4);
    // Horizontal max / min: lanes [a0 a1 b0 b1] against [a2 a3 b2 b3], then pairs.
    __m128 n = _mm_max_ps(_mm_movelh_ps(near_a, near_b), _mm_movehl_ps(near_b, near_a));
    __m128 f = _mm_min_ps(_mm_movelh_ps(far_a, far_b), _mm_movehl_ps(far_b, far_a));
    n = _mm_max_ps(n, _mm_shuffle_ps(n, n, _MM_SHUFFLE(2, 3, 0, 1)));
    f = _mm_min_ps(f, _mm_shuffle_ps(f, f, _MM_SHUFFLE(2, 3, 0, 1)));
    const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7FFFFFFF));
    f = _mm_add_ps(f, _mm_mul_ps(_mm_and_ps(f, abs_mask), _mm_set1_ps(kTwoGamma3)));
    const unsigned mask = unsigned(_mm_movemask_ps(_mm_cmple_ps(n, f)));
    t_a = _mm_cvtss_f32(n);
    t_b = _mm_cvtss_f32(_mm_movehl_ps(n, n));
    x_a = _mm_cvtss_f32(f);
    x_b = _mm_cvtss_f32(_mm_movehl_ps(f, f));
    return (mask & 1u) | ((mask >> 1) & 2u);
#else
    const bool hit_a = ray_box_conservative(r, a, tmin, tmax, t_a, x_a);
    const bool hit_b = ray_box_conservative(r, b, tmin, tmax, t_b, x_b);
    return unsigned(hit_a) | (unsigned(hit_b) << 1);
#endif
}

/// The same without the exits.
inline unsigned ray_box_pair_conservative(const BoxRay &r, const Box &a, const Box &b, float tmin,
                                          float tmax, float &t_a, float &t_b) {
    float x_a, x_b;
    return ray_box_pair_conservative(r, a, b, tmin, tmax, t_a, t_b, x_a, x_b);
}

/// Test for box primitives, without widening: true if the ray meets the
/// closed box (lo, hi) within [tmin, tmax]; t_entry is then the entry distance
/// clamped to tmin (tmin when the origin is inside).
inline bool ray_box_primitive(const BoxRay &r, const float lo[3], const float hi[3], float tmin,
                              float tmax, float &t_entry) {
    float t0, t1;
    slab_interval(r, lo, hi, tmin, tmax, t0, t1);
    // An entry beyond FLT_MAX (a denormal direction component crawling towards
    // the box) is not a hit: no float t describes it, as for triangles; nor is
    // an exit before -FLT_MAX. An entry before -FLT_MAX (tmin = -inf, the ray
    // inside the box, a component so small that the slab distance overflows)
    // is a hit whose t saturates at -FLT_MAX: hits always have a finite t.
    t_entry = t0 > -FLT_MAX ? t0 : -FLT_MAX;
    return t0 <= t1 && t0 < INFINITY && t1 > -INFINITY;
}

} // namespace aacbvh
