// The packet filter of the 8-wide traversal's x86 kernels: the
// single-precision edge functions of intersect_triangle() for four triangles
// at once, by the same operations in the same order (SSE arithmetic rounds
// exactly as the scalar code's), so a lane is dropped only when the scalar
// test would reject it on the same values.
#pragma once

#if defined(__SSE2__)
#include <emmintrin.h>

#include "bvh/wide8_bvh.h"
#include "trace/triangle_intersect.h"

namespace aacbvh {

struct PacketRaySse {
    int kx = 0, ky = 0, kz = 0;
    /// The origin's kx, ky, kz coordinates, negated: v + -o rounds exactly
    /// as v - o and takes the vertex row straight from memory.
    __m128 nox{}, noy{}, noz{};
    __m128 sx{}, sy{};
};

[[gnu::always_inline]] inline PacketRaySse make_packet_ray_sse(const TriangleRay &t) {
    PacketRaySse p;
    p.kx = t.kx;
    p.ky = t.ky;
    p.kz = t.kz;
    p.nox = _mm_set1_ps(-t.org[t.kx]);
    p.noy = _mm_set1_ps(-t.org[t.ky]);
    p.noz = _mm_set1_ps(-t.org[t.kz]);
    p.sx = _mm_set1_ps(t.sx);
    p.sy = _mm_set1_ps(t.sy);
    return p;
}

/// Bit k set unless lane k's edge functions have certain, mixed signs (the
/// scalar test's rejection): those lanes go on to finish_triangle_edges()
/// with the values stored in `edges`.
[[gnu::always_inline]] inline unsigned filter_packet_sse(const TrianglePacket &p, const PacketRaySse &r,
                                                         PacketEdges &edges) {
    const __m128 az = _mm_add_ps(_mm_load_ps(p.v[0][r.kz]), r.noz);
    const __m128 bz = _mm_add_ps(_mm_load_ps(p.v[1][r.kz]), r.noz);
    const __m128 cz = _mm_add_ps(_mm_load_ps(p.v[2][r.kz]), r.noz);
    const __m128 ax = _mm_sub_ps(_mm_add_ps(_mm_load_ps(p.v[0][r.kx]), r.nox), _mm_mul_ps(r.sx, az));
    const __m128 ay = _mm_sub_ps(_mm_add_ps(_mm_load_ps(p.v[0][r.ky]), r.noy), _mm_mul_ps(r.sy, az));
    const __m128 bx = _mm_sub_ps(_mm_add_ps(_mm_load_ps(p.v[1][r.kx]), r.nox), _mm_mul_ps(r.sx, bz));
    const __m128 by = _mm_sub_ps(_mm_add_ps(_mm_load_ps(p.v[1][r.ky]), r.noy), _mm_mul_ps(r.sy, bz));
    const __m128 cx = _mm_sub_ps(_mm_add_ps(_mm_load_ps(p.v[2][r.kx]), r.nox), _mm_mul_ps(r.sx, cz));
    const __m128 cy = _mm_sub_ps(_mm_add_ps(_mm_load_ps(p.v[2][r.ky]), r.noy), _mm_mul_ps(r.sy, cz));
    const __m128 eu = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
    const __m128 ev = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
    const __m128 ew = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
    // A certain miss: some edge function below zero and some above, none
    // NaN. Without NaN the smallest is below zero exactly when one is, and the
    // largest above; a NaN lane is kept whatever min and max made of it.
    const __m128 zero = _mm_setzero_ps();
    const __m128 lo = _mm_min_ps(_mm_min_ps(eu, ev), ew), hi = _mm_max_ps(_mm_max_ps(eu, ev), ew);
    const __m128 ordered = _mm_and_ps(_mm_cmpord_ps(eu, ev), _mm_cmpord_ps(ew, ew));
    const __m128 miss = _mm_and_ps(_mm_and_ps(_mm_cmplt_ps(lo, zero), _mm_cmpgt_ps(hi, zero)), ordered);
    const unsigned keep = ~unsigned(_mm_movemask_ps(miss)) & 15u;
    if (keep != 0) {
        const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7FFFFFFF));
        const __m128 mag = _mm_add_ps(_mm_add_ps(_mm_and_ps(_mm_mul_ps(cx, by), abs_mask),
                                                 _mm_and_ps(_mm_mul_ps(ax, cy), abs_mask)),
                                      _mm_and_ps(_mm_mul_ps(bx, ay), abs_mask));
        _mm_store_ps(edges.eu, eu);
        _mm_store_ps(edges.ev, ev);
        _mm_store_ps(edges.ew, ew);
        _mm_store_ps(edges.mag, mag);
    }
    return keep;
}

} // namespace aacbvh
#endif
