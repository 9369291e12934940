// The 8-wide traversal's plain C++ kernel: loops over lanes doing, lane by
// lane, the operations of the SIMD kernels. Builds with any compiler; the
// reference the other kernels are tested against.
#include <cstring>

#include "trace/child_order.h"
#include "trace/hit_record.h"
#include "trace/ray_primitives.h"
#include "trace/spill_stack.h"
#include "trace/wide8_traversal.h"

namespace aacbvh {
namespace wide8_scalar {
namespace {

struct NodeRay {
    long near[3], far[3]; ///< rows of Wide8Node::box (long: no extension per node)
    float org[3], inv[3];
    float inv_exit[3];     ///< for exit distances: inv_far when window_from_zero, else inv
    bool window_from_zero; ///< tmin >= 0: exits as ray_box_from_zero() finds them
};

inline NodeRay make_node_ray(const aacbvh_ray &ray) {
    const BoxRay r = make_box_ray(ray.org, ray.dir);
    const float tmin = ray.tmin;
    NodeRay w;
    for (int a = 0; a < 3; ++a) {
        w.near[a] = 2 * a + (r.neg[a] ? 1 : 0);
        w.far[a] = 2 * a + (r.neg[a] ? 0 : 1);
        w.org[a] = r.org[a];
        w.inv[a] = r.inv[a];
    }
    w.window_from_zero = tmin >= 0.0f;
    for (int a = 0; a < 3; ++a) w.inv_exit[a] = w.window_from_zero ? r.inv_far[a] : r.inv[a];
    return w;
}

template <bool FromZero, bool Keys>
inline unsigned test_children(const Wide8Node &node, const NodeRay &r, float tmin, float bound, float t_entry[8]) {
    unsigned mask = 0;
    // ray_box_from_zero() where the window starts at 0 or later, else
    // ray_box_conservative(), lane by lane.
    for (int k = 0; k < 8; ++k) {
        float a = tmin, b = bound;
        for (int ax = 0; ax < 3; ++ax) {
            const float n = (node.box[r.near[ax]][k] - r.org[ax]) * r.inv[ax];
            const float f = (node.box[r.far[ax]][k] - r.org[ax]) * r.inv_exit[ax];
            a = n > a ? n : a;
            b = f < b ? f : b;
        }
        if (!FromZero) b += std::fabs(b) * kTwoGamma3;
        t_entry[k] = FromZero && Keys ? child_order_key(a, b, tmin) : a;
        if (a <= b) mask |= 1u << k;
    }
    return mask;
}

struct PacketRay {
    int kx = 0, ky = 0, kz = 0;
    float org[3] = {0.0f, 0.0f, 0.0f};
    float sx = 0.0f, sy = 0.0f;
};

inline PacketRay make_packet_ray(const TriangleRay &t) {
    PacketRay p;
    p.kx = t.kx;
    p.ky = t.ky;
    p.kz = t.kz;
    for (int a = 0; a < 3; ++a) p.org[a] = t.org[a];
    p.sx = t.sx;
    p.sy = t.sy;
    return p;
}

inline unsigned filter_packet(const TrianglePacket &p, const PacketRay &r, PacketEdges &edges) {
    unsigned keep = 0;
    for (int k = 0; k < 4; ++k) {
        const float az = p.v[0][r.kz][k] - r.org[r.kz];
        const float bz = p.v[1][r.kz][k] - r.org[r.kz];
        const float cz = p.v[2][r.kz][k] - r.org[r.kz];
        const float ax = (p.v[0][r.kx][k] - r.org[r.kx]) - r.sx * az;
        const float ay = (p.v[0][r.ky][k] - r.org[r.ky]) - r.sy * az;
        const float bx = (p.v[1][r.kx][k] - r.org[r.kx]) - r.sx * bz;
        const float by = (p.v[1][r.ky][k] - r.org[r.ky]) - r.sy * bz;
        const float cx = (p.v[2][r.kx][k] - r.org[r.kx]) - r.sx * cz;
        const float cy = (p.v[2][r.ky][k] - r.org[r.ky]) - r.sy * cz;
        const float eu = cx * by - cy * bx;
        const float ev = ax * cy - ay * cx;
        const float ew = bx * ay - by * ax;
        const bool mixed = (eu < 0.0f || ev < 0.0f || ew < 0.0f) && (eu > 0.0f || ev > 0.0f || ew > 0.0f);
        const bool ordered = !std::isnan(eu) && !std::isnan(ev) && !std::isnan(ew);
        if (mixed && ordered) continue;
        keep |= 1u << k;
        edges.eu[k] = eu;
        edges.ev[k] = ev;
        edges.ew[k] = ew;
        edges.mag[k] = std::fabs(cx * by) + std::fabs(ax * cy) + std::fabs(bx * ay);
    }
    return keep;
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
} // namespace wide8_scalar

extern const Wide8Kernel kWide8Scalar = {wide8_scalar::intersect_entry, wide8_scalar::intersect_batch_entry, wide8_scalar::occluded_entry, wide8_scalar::occluded_batch_entry,
                                         wide8_scalar::intersect_counted_entry};

} // namespace aacbvh
