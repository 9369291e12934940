// Traversal of the 4-wide layout. The node test is trace/ray_box.h's
// conservative slab test (Ize, JCGT 2013) done on four boxes at once,
// operation for operation, so a wide child passes exactly when the binary
// test of the same box would; the primitive tests are the binary traversal's.
// Closest-hit results therefore equal the binary layout's (the set of
// primitives a ray can reach only grows, and the nearest hit is the same).
#include "trace/wide_traversal.h"

#include <cmath>
#include <cstring>

#include "trace/child_order.h"
#include "trace/hit_record.h"
#include "trace/ray_primitives.h"
#include "trace/spill_stack.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#define AACBVH_WIDE_SSE 1
#endif

namespace aacbvh {

namespace {

/// Per-ray constants of the four-box test, taken from make_box_ray() so the
/// slab distances are the binary test's: near[a] / far[a] are the rows of
/// WideNode::box the ray enters / leaves the slab of axis a by.
struct WideRay {
    int near[3], far[3];
#if AACBVH_WIDE_SSE
    __m128 org[3], inv[3];
#else
    float org[3], inv[3];
#endif
};

WideRay make_wide_ray(const BoxRay &r) {
    WideRay w;
    for (int a = 0; a < 3; ++a) {
        w.near[a] = 2 * a + (r.neg[a] ? 1 : 0);
        w.far[a] = 2 * a + (r.neg[a] ? 0 : 1);
#if AACBVH_WIDE_SSE
        w.org[a] = _mm_set1_ps(r.org[a]);
        w.inv[a] = _mm_set1_ps(r.inv[a]);
#else
        w.org[a] = r.org[a];
        w.inv[a] = r.inv[a];
#endif
    }
    return w;
}

/// ray_box_conservative() of the node's four child boxes: returns bit k set
/// when child k may be hit within [tmin, tmax], its clipped entry distance in
/// t_entry[k], or with Keys (closest-hit queries) and tmin >= 0 its visiting
/// key (child_order_key(), trace/child_order.h). Same operations in the same
/// order as slab_interval(): maxps / minps return their second operand when
/// the first is NaN, which is the scalar "x > a ? x : a" that drops NaN slab
/// distances.
template <bool Keys>
inline unsigned test_children(const WideNode &node, const WideRay &r, float tmin, float tmax, float t_entry[4]) {
#if AACBVH_WIDE_SSE
    const __m128 nx = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.near[0]]), r.org[0]), r.inv[0]);
    const __m128 ny = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.near[1]]), r.org[1]), r.inv[1]);
    const __m128 nz = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.near[2]]), r.org[2]), r.inv[2]);
    const __m128 fx = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.far[0]]), r.org[0]), r.inv[0]);
    const __m128 fy = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.far[1]]), r.org[1]), r.inv[1]);
    const __m128 fz = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.box[r.far[2]]), r.org[2]), r.inv[2]);
    __m128 a = _mm_set1_ps(tmin);
    a = _mm_max_ps(nx, a);
    a = _mm_max_ps(ny, a);
    a = _mm_max_ps(nz, a);
    __m128 b = _mm_set1_ps(tmax);
    b = _mm_min_ps(fx, b);
    b = _mm_min_ps(fy, b);
    b = _mm_min_ps(fz, b);
    const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7FFFFFFF));
    b = _mm_add_ps(b, _mm_mul_ps(_mm_and_ps(b, abs_mask), _mm_set1_ps(kTwoGamma3)));
    if (Keys && tmin >= 0.0f) { // child_order_key(), lane for lane
        const __m128 inside = _mm_cmple_ps(a, _mm_set1_ps(tmin));
        const __m128i exit_bits = _mm_and_si128(_mm_castps_si128(b), _mm_set1_epi32(0x7FFFFFFF));
        const __m128 key = _mm_castsi128_ps(_mm_sub_epi32(_mm_set1_epi32(int(0xFF800000u)), exit_bits));
        _mm_store_ps(t_entry, _mm_or_ps(_mm_and_ps(inside, key), _mm_andnot_ps(inside, a)));
    } else {
        _mm_store_ps(t_entry, a);
    }
    return unsigned(_mm_movemask_ps(_mm_cmple_ps(a, b)));
#else
    unsigned mask = 0;
    for (int k = 0; k < 4; ++k) {
        float a = tmin, b = tmax;
        for (int ax = 0; ax < 3; ++ax) {
            const float n = (node.box[r.near[ax]][k] - r.org[ax]) * r.inv[ax];
            const float f = (node.box[r.far[ax]][k] - r.org[ax]) * r.inv[ax];
            a = n > a ? n : a;
            b = f < b ? f : b;
        }
        b += std::fabs(b) * kTwoGamma3;
        t_entry[k] = Keys && tmin >= 0.0f ? child_order_key(a, b, tmin) : a;
        if (a <= b) mask |= 1u << k;
    }
    return mask;
#endif
}

/// A reference to a child (node index, or leaf: first slot and count) with
/// its entry distance.
struct Entry {
    uint32_t child;
    uint32_t count;
    float t;
};

using EntryStack = SpillStack<Entry, 128>;

/// A key whose unsigned order is the order of the distance t (the usual
/// sign-magnitude to two's-complement flip), low two bits cleared for
/// 3 - lane. Only the visiting order depends on it: dropping two bits can
/// reorder distances within 4 ulps, which the pruning (on the exact t)
/// does not see.
inline uint32_t order_key(float t) {
    uint32_t u;
    std::memcpy(&u, &t, sizeof u);
    u ^= (u >> 31) != 0 ? 0xFFFFFFFFu : 0x80000000u;
    return u & ~3u;
}

inline void sort_keys(uint32_t &a, uint32_t &b) {
    const uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
    a = lo;
    b = hi;
}

/// Asks for an inner child's two cache lines ahead of its visit.
inline void prefetch_node(const WideNode *nodes, uint32_t child, uint32_t count) {
#if AACBVH_WIDE_SSE
    if (count == 0) {
        const char *p = reinterpret_cast<const char *>(nodes + child);
        _mm_prefetch(p, _MM_HINT_T0);
        _mm_prefetch(p + 64, _MM_HINT_T0);
    }
#else
    (void)nodes;
    (void)child;
    (void)count;
#endif
}

/// Closest hit (AnyHit false) or any hit of a valid ray over a non-empty wide
/// tree. Hit children are visited near to far (by their keys,
/// trace/child_order.h, for closest hits): the nearest next, the others
/// pushed farthest first, each skipped when popped beyond the closest hit.
template <bool AnyHit, class Primitives>
bool traverse(const WideBvh &wide, const Bvh &bvh, const Primitives &prims, const WideRay &ray, float tmin,
              float tmax, aacbvh_hit &hit) {
    const WideNode *nodes = wide.nodes();
    const uint32_t *prim_ids = bvh.prim_ids.data();
    HitRecord<AnyHit> best(tmax);

    SpillBlock<Entry> spill;
    EntryStack stack(spill);
    Entry current{0u, 0u, tmin}; // the root, an inner wide node
    for (;;) {
        if (current.count == 0) {
            const WideNode &node = nodes[current.child];
            alignas(16) float t_entry[4];
            unsigned mask = test_children<!AnyHit>(node, ray, tmin, best.tmax, t_entry);
            if (mask != 0) {
                const unsigned k0 = unsigned(__builtin_ctz(mask));
                mask &= mask - 1;
                if (mask == 0) { // one child: no ordering, nothing pushed
                    current = Entry{node.child[k0], node.count[k0], t_entry[k0]};
                    continue;
                }
                if (AnyHit) { // any hit ends the query: order matters little
                    do {
                        const unsigned k = unsigned(__builtin_ctz(mask));
                        mask &= mask - 1;
                        stack.push(Entry{node.child[k], node.count[k], t_entry[k]});
                        prefetch_node(nodes, node.child[k], node.count[k]);
                    } while (mask != 0);
                    current = Entry{node.child[k0], node.count[k0], t_entry[k0]};
                    continue;
                }
                const unsigned k1 = unsigned(__builtin_ctz(mask));
                mask &= mask - 1;
                if (mask == 0) { // two: one comparison, made without a branch
                    const bool swap = t_entry[k1] <= t_entry[k0]; // equal: the smaller box (k1)
                    const unsigned near = swap ? k1 : k0, far = swap ? k0 : k1;
                    stack.push(Entry{node.child[far], node.count[far], t_entry[far]});
                    prefetch_node(nodes, node.child[far], node.count[far]);
                    current = Entry{node.child[near], node.count[near], t_entry[near]};
                    continue;
                }
                // Three or four: a sorting network on integer keys (distance
                // order in the high bits, 3 - lane in the low two: of equal
                // distances the higher lane, the smaller box, comes first;
                // bvh/wide_collapse.h), min/max only.
                uint32_t key[4];
                key[0] = order_key(t_entry[k0]) | (3u - k0);
                key[1] = order_key(t_entry[k1]) | (3u - k1);
                const unsigned k2 = unsigned(__builtin_ctz(mask));
                mask &= mask - 1;
                key[2] = order_key(t_entry[k2]) | (3u - k2);
                int n = 3;
                if (mask != 0) {
                    const unsigned k3 = unsigned(__builtin_ctz(mask));
                    key[3] = order_key(t_entry[k3]) | (3u - k3);
                    n = 4;
                    sort_keys(key[0], key[1]);
                    sort_keys(key[2], key[3]);
                    sort_keys(key[0], key[2]);
                    sort_keys(key[1], key[3]);
                    sort_keys(key[1], key[2]);
                } else {
                    sort_keys(key[0], key[1]);
                    sort_keys(key[1], key[2]);
                    sort_keys(key[0], key[1]);
                }
                for (int i = n; i-- > 1;) {
                    const unsigned k = ~key[i] & 3u;
                    stack.push(Entry{node.child[k], node.count[k], t_entry[k]});
                    prefetch_node(nodes, node.child[k], node.count[k]);
                }
                const unsigned k = ~key[0] & 3u;
                current = Entry{node.child[k], node.count[k], t_entry[k]};
                continue;
            }
        } else if (best.test_leaf(prims, prim_ids, current.child, current.count, tmin)) {
            break;
        }
        // Next: the nearest pending child still in reach of the closest hit.
        if (!best.pop_next(stack, current)) break;
    }

    if (!AnyHit) write_closest(best.found, best.tmax, best.u, best.v, best.prim, hit);
    return best.found;
}

template <bool AnyHit>
bool query(const WideBvh &wide, const Bvh &bvh, const Geometry &geometry, const float *triangles,
           const aacbvh_ray &ray, aacbvh_hit &hit, TraversalCounters *counters) {
    ScaledRay scaled;
    const aacbvh_ray *traced = traced_ray(ray, scaled);
    if (wide.node_count() == 0 || geometry.kind == GeometryKind::None || traced == nullptr) {
        set_miss(hit);
        return false;
    }
    const aacbvh_ray &r = *traced;
    const BoxRay box_ray = make_box_ray(r.org, r.dir);
    const WideRay wide_ray = make_wide_ray(box_ray);
    const bool found =
        with_primitives(geometry, bvh.prim_ids.data(), triangles, r, box_ray, [&](const auto &prims) {
            if (counters)
                return traverse<AnyHit>(wide, bvh, count_tests(prims, &counters->primitive_tests), wide_ray,
                                        r.tmin, r.tmax, hit);
            return traverse<AnyHit>(wide, bvh, prims, wide_ray, r.tmin, r.tmax, hit);
        });
    if (!AnyHit) scaled.unscale(hit);
    return found;
}

} // namespace

void intersect_ray_wide(const WideBvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                        aacbvh_hit &hit, const float *triangles, TraversalCounters *counters) {
    query<false>(wide, bvh, geometry, triangles, ray, hit, counters);
}

bool occluded_ray_wide(const WideBvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                       const float *triangles) {
    aacbvh_hit unused;
    return query<true>(wide, bvh, geometry, triangles, ray, unused, nullptr);
}

} // namespace aacbvh
