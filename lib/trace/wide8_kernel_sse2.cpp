// The 8-wide traversal's SSE2 kernel (the x86-64 baseline): a node's eight
// boxes as two groups of four lanes, a packet's four triangles in one
// register per coordinate. Same operations, same order as the plain C++
// kernel (wide8_kernel_scalar.cpp), hence the same answers.
#include <cstring>

#include "trace/child_order.h"
#include "trace/hit_record.h"
#include "trace/ray_primitives.h"
#include "trace/spill_stack.h"
#include "trace/wide8_traversal.h"

#if defined(__SSE2__)
#include <emmintrin.h>

#include "trace/wide8_packet_sse.h"

namespace aacbvh {
namespace wide8_sse2 {
namespace {

struct NodeRay {
    long near[3], far[3]; ///< rows of Wide8Node::box (long: no extension per node)
    __m128 org[3], inv[3];
    __m128 inv_exit[3];    ///< for exit distances: inv_far when window_from_zero, else inv
    bool window_from_zero; ///< tmin >= 0: exits as ray_box_from_zero() finds them
};

inline NodeRay make_node_ray(const aacbvh_ray &ray) {
    const BoxRay r = make_box_ray(ray.org, ray.dir);
    const float tmin = ray.tmin;
    NodeRay w;
    for (int a = 0; a < 3; ++a) {
        w.near[a] = 2 * a + (r.neg[a] ? 1 : 0);
        w.far[a] = 2 * a + (r.neg[a] ? 0 : 1);
        w.org[a] = _mm_set1_ps(r.org[a]);
        w.inv[a] = _mm_set1_ps(r.inv[a]);
    }
    w.window_from_zero = tmin >= 0.0f;
    for (int a = 0; a < 3; ++a) w.inv_exit[a] = _mm_set1_ps(w.window_from_zero ? r.inv_far[a] : r.inv[a]);
    return w;
}

/// Lanes [h, h + 4) of the node test (see wide_traversal.cpp's four-box test;
/// exits as in the AVX2 kernel). `bound` is the window's end as the exits
/// are compared with it: exit_reach(tmax) when the window starts at 0 or
/// later, else tmax, the exits then widened by their magnitude.
template <bool FromZero, bool Keys>
inline unsigned test_four(const Wide8Node &node, const NodeRay &r, int h, __m128 tmin, __m128 bound,
                          float *t_entry) {
    const __m128 nx = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.near[0]] + h), r.org[0]), r.inv[0]);
    const __m128 ny = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.near[1]] + h), r.org[1]), r.inv[1]);
    const __m128 nz = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.near[2]] + h), r.org[2]), r.inv[2]);
    const __m128 fx = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.far[0]] + h), r.org[0]), r.inv_exit[0]);
    const __m128 fy = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.far[1]] + h), r.org[1]), r.inv_exit[1]);
    const __m128 fz = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.far[2]] + h), r.org[2]), r.inv_exit[2]);
    __m128 a = _mm_max_ps(nx, tmin);
    a = _mm_max_ps(ny, a);
    a = _mm_max_ps(nz, a);
    __m128 b = _mm_min_ps(fx, bound);
    b = _mm_min_ps(fy, b);
    b = _mm_min_ps(fz, b);
    if (!FromZero) {
        const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7FFFFFFF));
        b = _mm_add_ps(b, _mm_mul_ps(_mm_and_ps(b, abs_mask), _mm_set1_ps(kTwoGamma3)));
    }
    if (FromZero && Keys) { // child_order_key(), lane for lane
        const __m128 inside = _mm_cmple_ps(a, tmin);
        const __m128i exit_bits = _mm_and_si128(_mm_castps_si128(b), _mm_set1_epi32(0x7FFFFFFF));
        const __m128 key = _mm_castsi128_ps(_mm_sub_epi32(_mm_set1_epi32(int(0xFF800000u)), exit_bits));
        _mm_store_ps(t_entry + h, _mm_or_ps(_mm_and_ps(inside, key), _mm_andnot_ps(inside, a)));
    } else {
        _mm_store_ps(t_entry + h, a);
    }
    return unsigned(_mm_movemask_ps(_mm_cmple_ps(a, b)));
}

template <bool FromZero, bool Keys>
inline unsigned test_children(const Wide8Node &node, const NodeRay &r, float tmin, float bound, float t_entry[8]) {
    const __m128 lo = _mm_set1_ps(tmin), hi = _mm_set1_ps(bound);
    return test_four<FromZero, Keys>(node, r, 0, lo, hi, t_entry) |
           (test_four<FromZero, Keys>(node, r, 4, lo, hi, t_entry) << 4);
}

using PacketRay = PacketRaySse;
inline PacketRay make_packet_ray(const TriangleRay &t) { return make_packet_ray_sse(t); }
inline unsigned filter_packet(const TrianglePacket &p, const PacketRay &r, PacketEdges &edges) {
    return filter_packet_sse(p, r, edges);
}

int sort_hits(unsigned mask, const float t_entry[8], uint32_t key[8]);

inline unsigned filter_packets(const TrianglePacket *p, uint32_t, const PacketRay &r, PacketEdges &edges,
                               uint32_t &used) {
    used = 1;
    return filter_packet(*p, r, edges);
}

/// The finish makes each lane's plane distance itself.
constexpr bool kPlaneDistances = false;
struct PacketPlanes;
inline void plane_distances(const TrianglePacket *, unsigned, const TriangleRay &, PacketPlanes &) {}

#include "trace/wide8_kernel.inl"

int sort_hits(unsigned mask, const float t_entry[8], uint32_t key[8]) { return sort_hits_insertion(mask, t_entry, key); }

} // namespace
} // namespace wide8_sse2

extern const Wide8Kernel kWide8Sse2 = {wide8_sse2::intersect_entry, wide8_sse2::intersect_batch_entry, wide8_sse2::occluded_entry, wide8_sse2::occluded_batch_entry,
                                       wide8_sse2::intersect_counted_entry};

} // namespace aacbvh
#endif
