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
    __m128 ox{}, oy{}, oz{}; ///< the origin's kx, ky, kz coordinates
    __m128 sx{}, sy{};
};

[[gnu::always_inline]] inline PacketRaySse make_packet_ray_sse(const TriangleRay &t) {
    PacketRaySse p;
    p.kx = t.kx;
    p.ky = t.ky;
    p.kz = t.kz;
    p.ox = _mm_set1_ps(t.org[t.kx]);
    p.oy = _mm_set1_ps(t.org[t.ky]);
    p.oz = _mm_set1_ps(t.org[t.kz]);
    p.sx = _mm_set1_ps(t.sx);
    p.sy = _mm_set1_ps(t.sy);
    return p;
}

/// Bit k set unless lane k's edge functions have certain, mixed signs (the
/// scalar test's rejection): those lanes go on to intersect_triangle_edges()
/// with the values stored in `edges`.
[[gnu::always_inline]] inline unsigned filter_packet_sse(const TrianglePacket &p, const PacketRaySse &r,
                                                         PacketEdges &edges) {
    const __m128 az = _mm_sub_ps(_mm_load_ps(p.v[0][r.kz]), r.oz);
    const __m128 bz = _mm_sub_ps(_mm_load_ps(p.v[1][r.kz]), r.oz);
    const __m128 cz = _mm_sub_ps(_mm_load_ps(p.v[2][r.kz]), r.oz);
    const __m128 ax = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(p.v[0][r.kx]), r.ox), _mm_mul_ps(r.sx, az));
    const __m128 ay = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(p.v[0][r.ky]), r.oy), _mm_mul_ps(r.sy, az));
    const __m128 bx = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(p.v[1][r.kx]), r.ox), _mm_mul_ps(r.sx, bz));
    const __m128 by = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(p.v[1][r.ky]), r.oy), _mm_mul_ps(r.sy, bz));
    const __m128 cx = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(p.v[2][r.kx]), r.ox), _mm_mul_ps(r.sx, cz));
    const __m128 cy = _mm_sub_ps(_mm_sub_ps(_mm_load_ps(p.v[2][r.ky]), r.oy), _mm_mul_ps(r.sy, cz));
    const __m128 eu = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
    const __m128 ev = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
    const __m128 ew = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
    const __m128 zero = _mm_setzero_ps();
    const __m128 neg = _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(eu, zero), _mm_cmplt_ps(ev, zero)), _mm_cmplt_ps(ew, zero));
    const __m128 pos = _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(eu, zero), _mm_cmpgt_ps(ev, zero)), _mm_cmpgt_ps(ew, zero));
    const __m128 ordered = _mm_and_ps(_mm_cmpord_ps(eu, ev), _mm_cmpord_ps(ew, ew));
    const __m128 miss = _mm_and_ps(_mm_and_ps(neg, pos), ordered);
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
