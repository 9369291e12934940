// The 8-wide traversal's x86 vector kernel, compiled once for each
// instruction set by a file that names it and includes this one
// (wide8_kernel_avx2.cpp, wide8_kernel_avx512.cpp):
//   AACBVH_WIDE8_X86_TARGET     the target, e.g. "avx2"
//   AACBVH_WIDE8_X86_NAMESPACE  the kernel's namespace, e.g. wide8_avx2
//   AACBVH_WIDE8_X86_TABLE      the kernel table it defines, e.g. kWide8Avx2
//   AACBVH_WIDE8_SINGLE_RAYS_FROM_AVX2  (optional) rays traced one by one go
//                               to the AVX2 kernel's code (wide8_kernel.inl)
// A node's eight boxes in one 256-bit register per slab. No fused
// multiply-add (the library builds with -ffp-contract=off), so every product
// and sum rounds as in the other kernels, whatever instruction set compiles
// it; the kernel is called only on CPUs that have its instruction set
// (wide8_traversal.cpp).
#include <cstring>

#include "trace/child_order.h"
#include "trace/hit_record.h"
#include "trace/ray_box.h"
#include "trace/ray_primitives.h"
#include "trace/spill_stack.h"
#include "trace/wide8_traversal.h"

#if AACBVH_WIDE8_X86_KERNELS
#include <immintrin.h>

#include "trace/wide8_packet_sse.h"

// Everything defined from here to the end of the region is compiled for the
// target; the headers above stay baseline code, so no out-of-line copy of a
// shared inline function is ever vector code.
#define AACBVH_WIDE8_PRAGMA(text) _Pragma(#text)
#define AACBVH_WIDE8_TARGET_PUSH(isa) \
    AACBVH_WIDE8_PRAGMA(clang attribute push(__attribute__((target(isa))), apply_to = function))
#define AACBVH_WIDE8_TARGET_GCC(isa) AACBVH_WIDE8_PRAGMA(GCC target(isa))
#if defined(__clang__)
AACBVH_WIDE8_TARGET_PUSH(AACBVH_WIDE8_X86_TARGET)
#else
#pragma GCC push_options
AACBVH_WIDE8_TARGET_GCC(AACBVH_WIDE8_X86_TARGET)
#endif

namespace aacbvh {
#if AACBVH_WIDE8_SINGLE_RAYS_FROM_AVX2
extern const Wide8Kernel kWide8Avx2;
#endif
namespace AACBVH_WIDE8_X86_NAMESPACE {
namespace {

struct NodeRay {
    long near[3], far[3]; ///< rows of Wide8Node::box (long: no extension per node)
    /// -org: a slab distance is (plane + -org) * inv, which rounds exactly as
    /// (plane - org) * inv (IEEE defines x - y as x + -y, zeros' signs
    /// included) and, the sum commuting, takes the plane straight from memory
    /// (one instruction a row instead of a load and a subtraction).
    __m256 neg_org[3];
    __m256 inv[3];
    __m256 inv_far[3];     ///< inv * kFarScale, for exits when the window starts at 0 or later
    bool window_from_zero; ///< tmin >= 0: exits as ray_box_from_zero() finds them
};

/// The node rows straight from the ray, four lanes at a time: the same
/// values as make_box_ray() makes one by one (1 / dir and its product with
/// kFarScale round alike in either form; -org is exact; the direction's sign
/// bits pick the rows), without its scalar divisions and stores.
inline NodeRay make_node_ray(const aacbvh_ray &ray) {
    NodeRay w;
    const __m128 org = _mm_loadu_ps(ray.org); // x, y, z, tmin
    const __m128 dir = _mm_loadu_ps(ray.dir); // x, y, z, tmax (lane 3 unused below)
    const __m128 inv = _mm_div_ps(_mm_set1_ps(1.0f), dir);
    const __m128 inv_far = _mm_mul_ps(inv, _mm_set1_ps(kFarScale));
    const __m128 neg_org = _mm_xor_ps(org, _mm_set1_ps(-0.0f));
    const int neg = _mm_movemask_ps(dir);
    for (int a = 0; a < 3; ++a) {
        const __m256i lane = _mm256_set1_epi32(a);
        const long n = long((neg >> a) & 1);
        w.near[a] = 2 * a + n;
        w.far[a] = 2 * a + 1 - n;
        w.neg_org[a] = _mm256_permutevar8x32_ps(_mm256_castps128_ps256(neg_org), lane);
        w.inv[a] = _mm256_permutevar8x32_ps(_mm256_castps128_ps256(inv), lane);
        w.inv_far[a] = _mm256_permutevar8x32_ps(_mm256_castps128_ps256(inv_far), lane);
    }
    w.window_from_zero = ray.tmin >= 0.0f;
    return w;
}

template <bool FromZero, bool Keys>
inline unsigned test_children(const Wide8Node &node, const NodeRay &r, float tmin, float bound, float t_entry[8]) {
    const __m256 nx = _mm256_mul_ps(_mm256_add_ps(_mm256_load_ps(node.box[r.near[0]]), r.neg_org[0]), r.inv[0]);
    const __m256 ny = _mm256_mul_ps(_mm256_add_ps(_mm256_load_ps(node.box[r.near[1]]), r.neg_org[1]), r.inv[1]);
    const __m256 nz = _mm256_mul_ps(_mm256_add_ps(_mm256_load_ps(node.box[r.near[2]]), r.neg_org[2]), r.inv[2]);
    __m256 a = _mm256_max_ps(nx, _mm256_set1_ps(tmin));
    a = _mm256_max_ps(ny, a);
    a = _mm256_max_ps(nz, a);
    if (!(FromZero && Keys)) _mm256_store_ps(t_entry, a);
    // max / min return their second operand when the first is NaN, as the
    // scalar "x > a ? x : a" keeps a.
    __m256 b;
    // Two copies of the exit loads, one per form, on purpose: the SSE2 and
    // scalar kernels' single copy with the widening branched after the min
    // chain measured 1-9 % slower here (bunny, pinned A/B, AMD EPYC).
    if (FromZero) { // ray_box_from_zero(), lane for lane
        const __m256 fx = _mm256_mul_ps(_mm256_add_ps(_mm256_load_ps(node.box[r.far[0]]), r.neg_org[0]), r.inv_far[0]);
        const __m256 fy = _mm256_mul_ps(_mm256_add_ps(_mm256_load_ps(node.box[r.far[1]]), r.neg_org[1]), r.inv_far[1]);
        const __m256 fz = _mm256_mul_ps(_mm256_add_ps(_mm256_load_ps(node.box[r.far[2]]), r.neg_org[2]), r.inv_far[2]);
        b = _mm256_min_ps(fx, _mm256_set1_ps(bound));
        b = _mm256_min_ps(fy, b);
        b = _mm256_min_ps(fz, b);
        if (Keys) { // child_order_key(), lane for lane
            const __m256 inside = _mm256_cmp_ps(a, _mm256_set1_ps(tmin), _CMP_LE_OQ);
            const __m256i exit_bits = _mm256_and_si256(_mm256_castps_si256(b), _mm256_set1_epi32(0x7FFFFFFF));
            const __m256 key = _mm256_castsi256_ps(_mm256_sub_epi32(_mm256_set1_epi32(int(0xFF800000u)), exit_bits));
            _mm256_store_ps(t_entry, _mm256_blendv_ps(a, key, inside));
        }
    } else { // ray_box_conservative()'s widening, lane for lane
        const __m256 fx = _mm256_mul_ps(_mm256_add_ps(_mm256_load_ps(node.box[r.far[0]]), r.neg_org[0]), r.inv[0]);
        const __m256 fy = _mm256_mul_ps(_mm256_add_ps(_mm256_load_ps(node.box[r.far[1]]), r.neg_org[1]), r.inv[1]);
        const __m256 fz = _mm256_mul_ps(_mm256_add_ps(_mm256_load_ps(node.box[r.far[2]]), r.neg_org[2]), r.inv[2]);
        b = _mm256_min_ps(fx, _mm256_set1_ps(bound));
        b = _mm256_min_ps(fy, b);
        b = _mm256_min_ps(fz, b);
        const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
        b = _mm256_add_ps(b, _mm256_mul_ps(_mm256_and_ps(b, abs_mask), _mm256_set1_ps(kTwoGamma3)));
    }
    return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LE_OS)));
}

using PacketRay = PacketRaySse;
inline PacketRay make_packet_ray(const TriangleRay &t) { return make_packet_ray_sse(t); }
/// Two packets' rows side by side: lanes 0-3 from `a`, 4-7 from `b`.
inline __m256 rows(const float *a, const float *b) {
    return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(a)), _mm_load_ps(b), 1);
}

/// filter_packet_sse() on eight lanes: the same operations in the same order.
inline unsigned filter_pair(const TrianglePacket &p, const TrianglePacket &q, const PacketRaySse &r,
                            PacketEdges &edges) {
    const __m256 nox = _mm256_set_m128(r.nox, r.nox), noy = _mm256_set_m128(r.noy, r.noy);
    const __m256 noz = _mm256_set_m128(r.noz, r.noz);
    const __m256 sx = _mm256_set_m128(r.sx, r.sx), sy = _mm256_set_m128(r.sy, r.sy);
    const __m256 az = _mm256_add_ps(rows(p.v[0][r.kz], q.v[0][r.kz]), noz);
    const __m256 bz = _mm256_add_ps(rows(p.v[1][r.kz], q.v[1][r.kz]), noz);
    const __m256 cz = _mm256_add_ps(rows(p.v[2][r.kz], q.v[2][r.kz]), noz);
    const __m256 ax = _mm256_sub_ps(_mm256_add_ps(rows(p.v[0][r.kx], q.v[0][r.kx]), nox), _mm256_mul_ps(sx, az));
    const __m256 ay = _mm256_sub_ps(_mm256_add_ps(rows(p.v[0][r.ky], q.v[0][r.ky]), noy), _mm256_mul_ps(sy, az));
    const __m256 bx = _mm256_sub_ps(_mm256_add_ps(rows(p.v[1][r.kx], q.v[1][r.kx]), nox), _mm256_mul_ps(sx, bz));
    const __m256 by = _mm256_sub_ps(_mm256_add_ps(rows(p.v[1][r.ky], q.v[1][r.ky]), noy), _mm256_mul_ps(sy, bz));
    const __m256 cx = _mm256_sub_ps(_mm256_add_ps(rows(p.v[2][r.kx], q.v[2][r.kx]), nox), _mm256_mul_ps(sx, cz));
    const __m256 cy = _mm256_sub_ps(_mm256_add_ps(rows(p.v[2][r.ky], q.v[2][r.ky]), noy), _mm256_mul_ps(sy, cz));
    const __m256 eu = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
    const __m256 ev = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
    const __m256 ew = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
    const __m256 zero = _mm256_setzero_ps();
    const __m256 lo = _mm256_min_ps(_mm256_min_ps(eu, ev), ew), hi = _mm256_max_ps(_mm256_max_ps(eu, ev), ew);
    const __m256 ordered = _mm256_and_ps(_mm256_cmp_ps(eu, ev, _CMP_ORD_Q), _mm256_cmp_ps(ew, ew, _CMP_ORD_Q));
    const __m256 miss = _mm256_and_ps(
        _mm256_and_ps(_mm256_cmp_ps(lo, zero, _CMP_LT_OS), _mm256_cmp_ps(hi, zero, _CMP_GT_OS)), ordered);
    const unsigned keep = ~unsigned(_mm256_movemask_ps(miss)) & 255u;
    if (keep != 0) {
        const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
        const __m256 mag = _mm256_add_ps(_mm256_add_ps(_mm256_and_ps(_mm256_mul_ps(cx, by), abs_mask),
                                                       _mm256_and_ps(_mm256_mul_ps(ax, cy), abs_mask)),
                                         _mm256_and_ps(_mm256_mul_ps(bx, ay), abs_mask));
        _mm256_store_ps(edges.eu, eu);
        _mm256_store_ps(edges.ev, ev);
        _mm256_store_ps(edges.ew, ew);
        _mm256_store_ps(edges.mag, mag);
    }
    return keep;
}

inline unsigned filter_packets(const TrianglePacket *p, uint32_t available, const PacketRay &r, PacketEdges &edges,
                               uint32_t &used) {
    if (available >= 2) {
        used = 2;
        return filter_pair(p[0], p[1], r, edges);
    }
    used = 1;
    return filter_packet_sse(*p, r, edges);
}

/// Always inlined: a call in the inner-node loop cost about 36 instructions
/// a sorted node (callgrind, docs/PERFORMANCE.md row 105).
[[gnu::always_inline]] inline int sort_hits(unsigned mask, const float t_entry[8], uint32_t key[8]);

/// The finish takes each kept lane's plane distance from a whole packet's,
/// made four lanes at once (plane_distances(), below).
constexpr bool kPlaneDistances = true;
struct PacketPlanes;
[[gnu::always_inline]] inline void plane_distances(const TrianglePacket *p, unsigned lanes, const TriangleRay &r,
                                                   PacketPlanes &out);

#define AACBVH_WIDE8_PACKETS 1
#include "trace/wide8_kernel.inl"

/// Eight rays traced together for their closest hits (intersect_packet()):
/// a lane a ray.
constexpr int kPacketRays = 8;

/// The rows of eight rays of one octant whose windows start at 0 or later,
/// one ray a lane: each lane holds what make_node_ray() broadcasts for its ray.
struct RayLanes {
    long near[3], far[3]; ///< shared: one octant
    __m256 neg_org[3], inv[3], inv_far[3], tmin;
};

/// A pending child of a ray packet, with each lane's entry distance.
struct PacketEntry {
    uint32_t child, count;
    uint32_t lanes; ///< bit i: ray i enters the child
    float t[kPacketRays];
};

/// Whether rays[0, 8) can be traced as one packet: each plain (no scaling),
/// its window from 0 or later, all directions with the same signs.
inline bool packet_eligible(const aacbvh_ray *rays) {
    const __m128 sign0 = _mm_loadu_ps(rays[0].dir);
    const int octant = _mm_movemask_ps(sign0) & 7;
    for (int i = 0; i < kPacketRays; ++i) {
        if (!ray_is_plain(rays[i]) || !(rays[i].tmin >= 0.0f)) return false;
        if ((_mm_movemask_ps(_mm_loadu_ps(rays[i].dir)) & 7) != octant) return false;
    }
    return true;
}

/// The lanes of rays[0, 8) (packet_eligible()).
inline RayLanes make_ray_lanes(const aacbvh_ray *rays) {
    alignas(32) float o[3][kPacketRays], d[3][kPacketRays], tmin[kPacketRays];
    for (int i = 0; i < kPacketRays; ++i) {
        for (int a = 0; a < 3; ++a) {
            o[a][i] = rays[i].org[a];
            d[a][i] = rays[i].dir[a];
        }
        tmin[i] = rays[i].tmin;
    }
    RayLanes w;
    const int neg = _mm_movemask_ps(_mm_loadu_ps(rays[0].dir));
    for (int a = 0; a < 3; ++a) {
        const long n = long((neg >> a) & 1);
        w.near[a] = 2 * a + n;
        w.far[a] = 2 * a + 1 - n;
        // The same operations as make_node_ray(), lane for lane.
        w.inv[a] = _mm256_div_ps(_mm256_set1_ps(1.0f), _mm256_load_ps(d[a]));
        w.inv_far[a] = _mm256_mul_ps(w.inv[a], _mm256_set1_ps(kFarScale));
        w.neg_org[a] = _mm256_xor_ps(_mm256_load_ps(o[a]), _mm256_set1_ps(-0.0f));
    }
    w.tmin = _mm256_load_ps(tmin);
    return w;
}

/// A box whose six planes (lo x, hi x, lo y, hi y, lo z, hi z, Wide8Node's
/// row order) lie `stride` floats apart from `rows`, against the packet:
/// test_children<true, ...>()'s test of one child, lane for lane with the
/// rays in the lanes (the same operations in the same order); each lane's
/// clipped entry into `entry`.
[[gnu::always_inline]] inline unsigned test_box_lanes(const float *rows, size_t stride, const RayLanes &r,
                                                      __m256 bound, __m256 &entry) {
    const __m256 nx = _mm256_mul_ps(_mm256_add_ps(_mm256_broadcast_ss(rows + r.near[0] * stride), r.neg_org[0]), r.inv[0]);
    const __m256 ny = _mm256_mul_ps(_mm256_add_ps(_mm256_broadcast_ss(rows + r.near[1] * stride), r.neg_org[1]), r.inv[1]);
    const __m256 nz = _mm256_mul_ps(_mm256_add_ps(_mm256_broadcast_ss(rows + r.near[2] * stride), r.neg_org[2]), r.inv[2]);
    __m256 a = _mm256_max_ps(nx, r.tmin);
    a = _mm256_max_ps(ny, a);
    a = _mm256_max_ps(nz, a);
    const __m256 fx = _mm256_mul_ps(_mm256_add_ps(_mm256_broadcast_ss(rows + r.far[0] * stride), r.neg_org[0]), r.inv_far[0]);
    const __m256 fy = _mm256_mul_ps(_mm256_add_ps(_mm256_broadcast_ss(rows + r.far[1] * stride), r.neg_org[1]), r.inv_far[1]);
    const __m256 fz = _mm256_mul_ps(_mm256_add_ps(_mm256_broadcast_ss(rows + r.far[2] * stride), r.neg_org[2]), r.inv_far[2]);
    __m256 b = _mm256_min_ps(fx, bound);
    b = _mm256_min_ps(fy, b);
    b = _mm256_min_ps(fz, b);
    entry = a;
    return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LE_OS)));
}

/// Child k of `node` against the packet (test_box_lanes()).
[[gnu::always_inline]] inline unsigned test_child_lanes(const Wide8Node &node, int k, const RayLanes &r,
                                                        __m256 bound, __m256 &entry) {
    return test_box_lanes(&node.box[0][k], 8, r, bound, entry);
}

/// The smallest and largest lane of v.
inline float lane_min(__m256 v) {
    __m128 m = _mm_min_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    m = _mm_min_ps(m, _mm_movehl_ps(m, m));
    return _mm_cvtss_f32(_mm_min_ss(m, _mm_shuffle_ps(m, m, 1)));
}
inline float lane_max(__m256 v) {
    __m128 m = _mm_max_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    m = _mm_max_ps(m, _mm_movehl_ps(m, m));
    return _mm_cvtss_f32(_mm_max_ss(m, _mm_shuffle_ps(m, m, 1)));
}

/// What a packet of rays from one origin (camera rays) has in common, for
/// a test of a node's eight children at once against all of its rays
/// (packet_candidates()): the origin, for each axis the range of the lanes'
/// 1 / dir and of its far form, and the smallest tmin. `usable` where the
/// rays share their origin and every 1 / dir is finite (no direction
/// component zero or denormal), so that no product in the test is NaN.
struct PacketBounds {
    __m256 neg_org[3];
    __m256 inv_lo[3], inv_hi[3], inv_far_lo[3], inv_far_hi[3];
    __m256 tmin_lo;
    bool usable;
};

inline PacketBounds make_packet_bounds(const RayLanes &r) {
    PacketBounds b;
    __m256 ok = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
    const __m256 inf = _mm256_set1_ps(INFINITY);
    for (int a = 0; a < 3; ++a) {
        // The lanes' -org, each against lane 0's (all lanes: bits equal).
        b.neg_org[a] = _mm256_permutevar8x32_ps(r.neg_org[a], _mm256_setzero_si256());
        ok = _mm256_and_ps(ok, _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_castps_si256(r.neg_org[a]),
                                                                       _mm256_castps_si256(b.neg_org[a]))));
        ok = _mm256_and_ps(ok, _mm256_cmp_ps(_mm256_and_ps(r.inv[a], abs_mask), inf, _CMP_LT_OQ));
        ok = _mm256_and_ps(ok, _mm256_cmp_ps(_mm256_and_ps(r.inv_far[a], abs_mask), inf, _CMP_LT_OQ));
    }
    b.usable = _mm256_movemask_ps(ok) == 0xFF;
    if (!b.usable) return b;
    for (int a = 0; a < 3; ++a) {
        b.inv_lo[a] = _mm256_set1_ps(lane_min(r.inv[a]));
        b.inv_hi[a] = _mm256_set1_ps(lane_max(r.inv[a]));
        b.inv_far_lo[a] = _mm256_set1_ps(lane_min(r.inv_far[a]));
        b.inv_far_hi[a] = _mm256_set1_ps(lane_max(r.inv_far[a]));
    }
    b.tmin_lo = _mm256_set1_ps(lane_min(r.tmin));
    return b;
}

/// The smallest (Lowest) or largest of (row + -org) * inv over the
/// packet's range of inv, for the eight children of a row: rounding is
/// monotone, so each lane's own product (test_child_lanes()'s, the same
/// operations on the same -org) lies between those at the range's ends.
template <bool Lowest>
[[gnu::always_inline]] inline __m256 slab_extreme(const float *row, __m256 neg_org, __m256 inv_lo, __m256 inv_hi) {
    const __m256 u = _mm256_add_ps(_mm256_load_ps(row), neg_org);
    const __m256 a = _mm256_mul_ps(u, inv_lo), b = _mm256_mul_ps(u, inv_hi);
    return Lowest ? _mm256_min_ps(a, b) : _mm256_max_ps(a, b);
}

/// The children of `node` that some ray of a packet from one origin may
/// enter (PacketBounds usable): bit k clear only where no lane's
/// test_child_lanes() can pass child k. Every lane's entry is at least the
/// largest of the smallest near distances (and the smallest tmin), its exit
/// at most the smallest of the largest far distances (and `bound_hi`, the
/// largest lane's bound): where the first exceeds the second no lane
/// enters. One test of all eight children, against the per-lane tests'
/// eight (one a child), which then run only for the children it keeps.
[[gnu::always_inline]] inline unsigned packet_candidates(const Wide8Node &node, const RayLanes &r,
                                                         const PacketBounds &b, __m256 bound_hi) {
    __m256 lo = b.tmin_lo, hi = bound_hi;
    for (int a = 0; a < 3; ++a) {
        lo = _mm256_max_ps(slab_extreme<true>(node.box[r.near[a]], b.neg_org[a], b.inv_lo[a], b.inv_hi[a]), lo);
        hi = _mm256_min_ps(slab_extreme<false>(node.box[r.far[a]], b.neg_org[a], b.inv_far_lo[a], b.inv_far_hi[a]),
                           hi);
    }
    return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(lo, hi, _CMP_LE_OQ)));
}

/// Closest hits of rays[0, 8) (packet_eligible()) over a tree with packet
/// leaves, walked together: a child is visited for the lanes whose own
/// node test (test_child_lanes(), the single ray's) lets them in, a packet
/// leaf tested by each such lane's own test_packets(), and a pending child
/// skipped for the lanes whose closest hit now lies before their entry.
/// Rays from one origin (camera rays) first test a node's eight children
/// at once against the whole packet (packet_candidates()), and only the
/// children it keeps against each lane (docs/PERFORMANCE.md, row 249).
/// Each ray keeps its own record, every box test passes the boxes the
/// single ray's would, and the closest hit does not depend on the visiting
/// order (trace/hit_record.h): the answers are intersect_entry()'s.
void intersect_packet(const Wide8Bvh &wide, const aacbvh_ray *rays, aacbvh_hit *hits) {
    const RayLanes r = make_ray_lanes(rays);
    TriangleRay tray[kPacketRays];
    PacketRay pray[kPacketRays];
    HitRecord<false> best[kPacketRays] = {HitRecord<false>(rays[0].tmax), HitRecord<false>(rays[1].tmax),
                                          HitRecord<false>(rays[2].tmax), HitRecord<false>(rays[3].tmax),
                                          HitRecord<false>(rays[4].tmax), HitRecord<false>(rays[5].tmax),
                                          HitRecord<false>(rays[6].tmax), HitRecord<false>(rays[7].tmax)};
    alignas(32) float reach[kPacketRays];
    for (int i = 0; i < kPacketRays; ++i) {
        tray[i] = make_triangle_ray(rays[i].org, rays[i].dir);
        pray[i] = make_packet_ray(tray[i]);
        reach[i] = best[i].reach();
    }
    __m256 bound = _mm256_load_ps(reach);
    const PacketBounds pb = make_packet_bounds(r);
    __m256 bound_hi = _mm256_set1_ps(lane_max(bound)); // read only where pb.usable
    const Wide8Node *nodes = wide.nodes();
    const TrianglePacket *packets = wide.packets();
    SpillBlock<PacketEntry> spill;
    SpillStack<PacketEntry, 192> stack(spill);
    PacketEntry current{0u, 0u, (1u << kPacketRays) - 1, {0, 0, 0, 0, 0, 0, 0, 0}};
    for (;;) {
        if (current.count == 0) {
            const Wide8Node &node = nodes[current.child];
            const int lead = __builtin_ctz(current.lanes);
            uint32_t key[8];
            alignas(32) float entry[8][kPacketRays];
            unsigned lanes[8];
            int n = 0;
            const unsigned candidates = pb.usable ? packet_candidates(node, r, pb, bound_hi) : 0xFFu;
            for (unsigned left = candidates; left != 0; left &= left - 1) {
                const int k = __builtin_ctz(left);
                if (node.child[k] == Wide8Node::kEmptyChild) break; // children fill the lowest slots
                __m256 a;
                const unsigned m = test_child_lanes(node, k, r, bound, a) & current.lanes;
                if (m == 0) continue;
                _mm256_store_ps(entry[k], a);
                lanes[k] = m;
                // Near to far by the lead lane's entry (the lowest lane the
                // parent let in; a child it misses goes by its own lowest).
                const int by = ((m >> lead) & 1u) ? lead : __builtin_ctz(m);
                const uint32_t kk = order_key8(entry[k][by]) | (7u - unsigned(k));
                int j = n++;
                while (j > 0 && key[j - 1] > kk) {
                    key[j] = key[j - 1];
                    --j;
                }
                key[j] = kk;
            }
            if (n != 0) {
                stack.reserve(size_t(n));
                for (int j = n; j-- > 0;) {
                    const unsigned k = ~key[j] & 7u;
                    PacketEntry e{node.child[k], node.count[k], lanes[k], {}};
                    std::memcpy(e.t, entry[k], sizeof e.t);
                    stack.push_within(e);
                    prefetch_child(nodes, packets, node.child[k], node.count[k]);
                }
            }
        } else {
            for (unsigned left = current.lanes; left != 0; left &= left - 1) {
                const int i = __builtin_ctz(left);
                test_packets<false>(packets + current.child, current.count, tray[i], pray[i], rays[i].tmin, best[i]);
                reach[i] = best[i].reach();
            }
            bound = _mm256_load_ps(reach);
            if (pb.usable) bound_hi = _mm256_set1_ps(lane_max(bound));
        }
        // The next pending child with a lane that can still find a nearer hit in it.
        for (;;) {
            if (stack.empty()) {
                for (int i = 0; i < kPacketRays; ++i)
                    write_closest(best[i].found, best[i].tmax, best[i].u, best[i].v, best[i].prim, hits[i]);
                return;
            }
            current = stack.pop();
            current.lanes &= unsigned(_mm256_movemask_ps(_mm256_cmp_ps(_mm256_loadu_ps(current.t), bound, _CMP_LE_OQ)));
            if (current.lanes != 0) break;
        }
    }
}

/// A pending child of an any-hit ray packet.
struct AnyPacketEntry {
    uint32_t child, count;
    uint32_t lanes; ///< bit i: ray i enters the child
};

/// The packet leaf that last occluded a ray of a batch's runs of eight, and
/// its box (its triangles' bounds, made from the packets when it is
/// remembered): coherent shadow rays (from neighbouring pixels toward one
/// light) are often stopped by the same wall or roof, so the next run tests
/// that leaf first, and the lanes it occludes need no walk. Only a shortcut:
/// a lane it does not occlude is walked as before, so the answers do not
/// depend on it (docs/PERFORMANCE.md, row 283).
struct LastOccluder {
    uint32_t first = 0; ///< the leaf's first packet
    uint32_t count = 0; ///< its packets; 0: none remembered
    float rows[6] = {};  ///< lo x, hi x, lo y, hi y, lo z, hi z (Wide8Node's row order)

    void remember(const TrianglePacket *packets, uint32_t leaf_first, uint32_t leaf_count) {
        if (count == leaf_count && first == leaf_first) return;
        first = leaf_first;
        count = leaf_count;
        for (int a = 0; a < 3; ++a) {
            __m128 lo = _mm_load_ps(packets[first].v[0][a]), hi = lo;
            for (uint32_t j = 0; j < count; ++j)
                for (int i = 0; i < 3; ++i) {
                    const __m128 v = _mm_load_ps(packets[first + j].v[i][a]);
                    lo = _mm_min_ps(lo, v);
                    hi = _mm_max_ps(hi, v);
                }
            lo = _mm_min_ps(lo, _mm_movehl_ps(lo, lo));
            hi = _mm_max_ps(hi, _mm_movehl_ps(hi, hi));
            rows[2 * a] = _mm_cvtss_f32(_mm_min_ss(lo, _mm_shuffle_ps(lo, lo, 1)));
            rows[2 * a + 1] = _mm_cvtss_f32(_mm_max_ss(hi, _mm_shuffle_ps(hi, hi, 1)));
        }
    }
};

/// Any hits of rays[0, 8) (packet_eligible()) over a tree with packet
/// leaves into out[0, 8), walked together as intersect_packet() walks them:
/// a lane leaves the packet at its first hit; no child order (the largest
/// box first, as the single ray's any-hit walk goes) and no pruning but the
/// node tests' (an any-hit window never shrinks). The answers are
/// occluded_entry()'s: every box the single ray would enter is entered, and
/// whether some triangle is hit does not depend on the visiting order.
/// `last` (from the batch's earlier runs) is tested first, forgotten when it
/// occludes none of the lanes, and replaced by the leaf of the walk's last
/// occlusion.
void occluded_packet(const Wide8Bvh &wide, const aacbvh_ray *rays, uint8_t *out, LastOccluder &last) {
    const RayLanes r = make_ray_lanes(rays);
    TriangleRay tray[kPacketRays];
    PacketRay pray[kPacketRays];
    alignas(32) float reach[kPacketRays];
    for (int i = 0; i < kPacketRays; ++i) {
        tray[i] = make_triangle_ray(rays[i].org, rays[i].dir);
        pray[i] = make_packet_ray(tray[i]);
        reach[i] = exit_reach(rays[i].tmax); // never shrinks: the first hit ends a lane
        out[i] = 0;
    }
    const __m256 bound = _mm256_load_ps(reach);
    const Wide8Node *nodes = wide.nodes();
    const TrianglePacket *packets = wide.packets();
    constexpr unsigned kAllLanes = (1u << kPacketRays) - 1;
    unsigned live = kAllLanes;
    if (last.count != 0) {
        __m256 unused;
        for (unsigned left = test_box_lanes(last.rows, 1, r, bound, unused); left != 0; left &= left - 1) {
            const int i = __builtin_ctz(left);
            HitRecord<true> best(rays[i].tmax);
            if (test_packets<true>(packets + last.first, last.count, tray[i], pray[i], rays[i].tmin, best)) {
                out[i] = 1;
                live &= ~(1u << i);
            }
        }
        if (live == kAllLanes) last.count = 0; // no longer the occluder here
        if (live == 0) return;
    }
    SpillBlock<AnyPacketEntry> spill;
    SpillStack<AnyPacketEntry, 192> stack(spill);
    AnyPacketEntry current{0u, 0u, live};
    for (;;) {
        if (current.count == 0) {
            const Wide8Node &node = nodes[current.child];
            unsigned lanes[8];
            unsigned hit = 0;
            for (int k = 0; k < 8; ++k) {
                if (node.child[k] == Wide8Node::kEmptyChild) break; // children fill the lowest slots
                __m256 a;
                lanes[k] = test_child_lanes(node, k, r, bound, a) & current.lanes;
                hit |= (lanes[k] != 0 ? 1u : 0u) << k;
            }
            if (hit != 0) {
                stack.reserve(8);
                for (int k = 7; k >= 0; --k) // the largest box (lane 0) on top
                    if ((hit >> k) & 1u) {
                        stack.push_within(AnyPacketEntry{node.child[k], node.count[k], lanes[k]});
                        prefetch_child(nodes, packets, node.child[k], node.count[k]);
                    }
            }
        } else {
            for (unsigned left = current.lanes; left != 0; left &= left - 1) {
                const int i = __builtin_ctz(left);
                HitRecord<true> best(rays[i].tmax);
                if (test_packets<true>(packets + current.child, current.count, tray[i], pray[i], rays[i].tmin,
                                       best)) {
                    out[i] = 1;
                    live &= ~(1u << i);
                    last.remember(packets, current.child, current.count);
                }
            }
            if (live == 0) return;
        }
        do {
            if (stack.empty()) return;
            current = stack.pop();
            current.lanes &= live;
        } while (current.lanes == 0);
    }
}

/// One run of eight rays traced together, or one ray alone, into closest
/// hits or occlusion flags (1: occluded): trace_runs()'s two steps. Runs of
/// occlusion queries share the last occluder found (LastOccluder).
inline void trace_run(const Wide8Bvh &wide, const aacbvh_ray *rays, aacbvh_hit *hits, LastOccluder &) {
    intersect_packet(wide, rays, hits);
}
inline void trace_run(const Wide8Bvh &wide, const aacbvh_ray *rays, uint8_t *out, LastOccluder &last) {
    occluded_packet(wide, rays, out, last);
}
inline void trace_one(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                      aacbvh_hit &hit) {
    intersect_entry(wide, bvh, geometry, ray, hit);
}
inline void trace_one(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                      uint8_t &out) {
    out = occluded_entry(wide, bvh, geometry, ray) ? 1 : 0;
}

/// The eight rays of a run that packet_eligible() does not take, one by one.
inline void trace_alone(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray *rays,
                        aacbvh_hit *hits, const LastOccluder &) {
    for (int k = 0; k < kPacketRays; ++k) trace_one(wide, bvh, geometry, rays[k], hits[k]);
}

/// The same for occlusion rays (their directions' signs differ: shadow rays
/// around a light): each plain one whose window starts at 0 or later and
/// whose node test (ray_box_conservative()) lets it into the box of the
/// runs' last occluder (LastOccluder) tests that leaf first, and where the
/// leaf stops it, its walk is saved. Only a shortcut, as for the runs: any
/// hit within the window is the answer. Out of line, so that the runs' loop
/// keeps its code (docs/PERFORMANCE.md, row 295).
[[gnu::noinline]] void trace_alone(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry,
                                   const aacbvh_ray *rays, uint8_t *out, const LastOccluder &last) {
    Box box;
    for (int a = 0; a < 3; ++a) {
        box.lo[a] = last.rows[2 * a];
        box.hi[a] = last.rows[2 * a + 1];
    }
    for (int k = 0; k < kPacketRays; ++k) {
        const aacbvh_ray &ray = rays[k];
        float entry;
        if (last.count != 0 && ray_is_plain(ray) && ray.tmin >= 0.0f &&
            ray_box_conservative(make_box_ray(ray.org, ray.dir), box, ray.tmin, ray.tmax, entry)) {
            const TriangleRay tray = make_triangle_ray(ray.org, ray.dir);
            HitRecord<true> best(ray.tmax);
            if (test_packets<true>(wide.packets() + last.first, last.count, tray, make_packet_ray(tray), ray.tmin,
                                   best)) {
                out[k] = 1;
                continue;
            }
        }
        trace_one(wide, bvh, geometry, ray, out[k]);
    }
}

/// The batch entry points over rays[0, count) into out[0, count): each run
/// of eight rays that packet_eligible() takes is traced together
/// (intersect_packet() or occluded_packet()), every other ray alone
/// (trace_alone(), trace_one()). Runs
/// start at the batch's first ray (a batch call's chunks are multiples of
/// eight).
template <class Out>
inline void trace_runs(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray *rays,
                       Out *out, size_t count) {
    const bool packets = wide.node_count() != 0 && wide.has_packets() && geometry.kind == GeometryKind::Triangles;
    LastOccluder last;
    size_t i = 0;
    if (packets)
        for (; i + kPacketRays <= count; i += kPacketRays) {
            if (packet_eligible(rays + i)) {
                trace_run(wide, rays + i, out + i, last);
                continue;
            }
            trace_alone(wide, bvh, geometry, rays + i, out + i, last);
        }
    for (; i < count; ++i) trace_one(wide, bvh, geometry, rays[i], out[i]);
}

/// intersect_entry() over rays[0, count) into hits[0, count), runs of
/// coherent rays together (trace_runs()).
void intersect_batch_entry(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray *rays,
                           aacbvh_hit *hits, size_t count) {
    trace_runs(wide, bvh, geometry, rays, hits, count);
}

/// occluded_entry() over rays[0, count) into out[0, count), runs of
/// coherent rays together (trace_runs()).
void occluded_batch_entry(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray *rays,
                          uint8_t *out, size_t count) {
    trace_runs(wide, bvh, geometry, rays, out, count);
}

/// A packet row (four floats) in double: exact.
inline __m256d double_row(const float *row) { return _mm256_cvtps_pd(_mm_load_ps(row)); }

/// triangle_distance_of()'s plane distance and box test for a packet's four
/// triangles, one a lane, by the same operations in the same order (the
/// scalar code's axis lanes become a vector each): plane[k] and bit k of
/// the result (the plane point lies in the triangle's box) are lane k's.
inline unsigned packet_plane_distances(const TrianglePacket &p, const TriangleRay &r, double plane[4]) {
    __m256d e1[3], e2[3], w[3], d[3];
    for (int a = 0; a < 3; ++a) {
        const __m256d p0 = double_row(p.v[0][a]);
        e1[a] = _mm256_sub_pd(double_row(p.v[1][a]), p0);
        e2[a] = _mm256_sub_pd(double_row(p.v[2][a]), p0);
        w[a] = _mm256_sub_pd(p0, _mm256_set1_pd(r.org_d[a]));
        d[a] = _mm256_set1_pd(r.dir_d[a]);
    }
    __m256d n[3];
    for (int a = 0; a < 3; ++a) {
        const int b = a == 2 ? 0 : a + 1, c = b == 2 ? 0 : b + 1; // the lanes rotated: (y, z, x) and (z, x, y)
        n[a] = _mm256_sub_pd(_mm256_mul_pd(e1[b], e2[c]), _mm256_mul_pd(e1[c], e2[b]));
    }
    const __m256d den = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(d[0], n[0]), _mm256_mul_pd(d[1], n[1])),
                                      _mm256_mul_pd(d[2], n[2]));
    const __m256d num = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(w[0], n[0]), _mm256_mul_pd(w[1], n[1])),
                                      _mm256_mul_pd(w[2], n[2]));
    const __m256d t = _mm256_div_pd(num, den);
    _mm256_store_pd(plane, t);
    // min_pd(a, b) is a < b ? a : b and max_pd(a, b) a > b ? a : b, as the
    // scalar selections; the ordered compares are false for NaN.
    const __m256d zero = _mm256_setzero_pd();
    __m256d inside = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    for (int a = 0; a < 3; ++a) {
        const __m256d x = _mm256_sub_pd(_mm256_mul_pd(t, d[a]), w[a]);
        const __m256d lo = _mm256_min_pd(_mm256_min_pd(e1[a], e2[a]), zero);
        const __m256d hi = _mm256_max_pd(_mm256_max_pd(e1[a], e2[a]), zero);
        const __m256d flat = _mm256_and_pd(_mm256_cmp_pd(e1[a], zero, _CMP_EQ_OQ), _mm256_cmp_pd(e2[a], zero, _CMP_EQ_OQ));
        const __m256d within =
            _mm256_or_pd(_mm256_and_pd(_mm256_cmp_pd(x, lo, _CMP_GE_OQ), _mm256_cmp_pd(x, hi, _CMP_LE_OQ)), flat);
        inside = _mm256_and_pd(inside, within);
    }
    return unsigned(_mm256_movemask_pd(inside));
}

[[gnu::always_inline]] inline void plane_distances(const TrianglePacket *p, unsigned lanes, const TriangleRay &r,
                                                   PacketPlanes &out) {
    out.inside = 0;
    if ((lanes & 15u) != 0) out.inside = packet_plane_distances(p[0], r, out.plane);
    if ((lanes >> 4) != 0) out.inside |= packet_plane_distances(p[1], r, out.plane + 4) << 4;
}

/// One layer of the sorting network: each lane meets lane i ^ partner and
/// keeps the smaller key where bit i of kMinLanes is set, else the larger.
template <int kMinLanes>
inline __m256i sort_layer(__m256i x, __m256i partner) {
    const __m256i y = _mm256_permutevar8x32_epi32(x, partner);
    return _mm256_blend_epi32(_mm256_max_epu32(x, y), _mm256_min_epu32(x, y), kMinLanes);
}

/// The hit lanes' keys sorted by a bitonic network on one register (six
/// layers, no branch); lanes not hit get all-ones keys and sort last.
[[gnu::always_inline]] inline int sort_hits(unsigned mask, const float t_entry[8], uint32_t key[8]) {
    const int n = __builtin_popcount(mask);
    if (n < 5) return sort_hits_insertion(mask, t_entry, key);
    const __m256i lane = _mm256_setr_epi32(7, 6, 5, 4, 3, 2, 1, 0); // 7 - k: see order_key8()
    const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    __m256i u = _mm256_castps_si256(_mm256_load_ps(t_entry));
    // order_key8(): flip all bits of negatives, the sign bit of the others.
    u = _mm256_xor_si256(u, _mm256_or_si256(_mm256_srai_epi32(u, 31), _mm256_set1_epi32(int(0x80000000u))));
    u = _mm256_or_si256(_mm256_and_si256(u, _mm256_set1_epi32(~7)), lane);
    const __m256i hit = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(int(mask)), bit), bit);
    __m256i x = _mm256_or_si256(u, _mm256_andnot_si256(hit, _mm256_set1_epi32(-1)));
    const __m256i p1 = _mm256_setr_epi32(1, 0, 3, 2, 5, 4, 7, 6);
    const __m256i p2 = _mm256_setr_epi32(2, 3, 0, 1, 6, 7, 4, 5);
    const __m256i p4 = _mm256_setr_epi32(4, 5, 6, 7, 0, 1, 2, 3);
    x = sort_layer<0x99>(x, p1);
    x = sort_layer<0xC3>(x, p2);
    x = sort_layer<0xA5>(x, p1);
    x = sort_layer<0x0F>(x, p4);
    x = sort_layer<0x33>(x, p2);
    x = sort_layer<0x55>(x, p1);
    _mm256_store_si256(reinterpret_cast<__m256i *>(key), x);
    return n;
}

} // namespace
} // namespace AACBVH_WIDE8_X86_NAMESPACE

extern const Wide8Kernel AACBVH_WIDE8_X86_TABLE = {
    AACBVH_WIDE8_X86_NAMESPACE::intersect_entry, AACBVH_WIDE8_X86_NAMESPACE::intersect_batch_entry,
    AACBVH_WIDE8_X86_NAMESPACE::occluded_entry, AACBVH_WIDE8_X86_NAMESPACE::occluded_batch_entry,
    AACBVH_WIDE8_X86_NAMESPACE::intersect_counted_entry};

} // namespace aacbvh

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif
