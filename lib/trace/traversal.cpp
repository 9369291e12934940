// Stack-based traversal of the binary BVH: both children's boxes are tested
// together, the nearer is entered first and the farther pushed with its entry
// distance, so that closest-hit queries skip it once a nearer hit is known.
#include "trace/traversal.h"

#include <cmath>
#include <vector>

#include "trace/child_order.h"
#include "trace/hit_record.h"
#include "trace/ray_primitives.h"
#include "trace/spill_stack.h"

namespace aacbvh {

namespace {

/// (node, entry distance) pairs waiting to be visited.
struct StackEntry {
    uint32_t node;
    float t;
};
using NodeStack = SpillStack<StackEntry, 64>;

/// Closest hit (AnyHit false) or any hit (AnyHit true) of a valid ray over a
/// non-empty tree. Returns whether something was hit; hit is filled for the
/// closest-hit query only.
///
/// Counters: nodes_visited counts the nodes whose box was tested (the root,
/// then both children of every inner node entered); primitive_tests counts
/// every primitive test of every leaf entered.
template <bool AnyHit, class Primitives>
bool traverse(const Bvh &bvh, const Primitives &prims, const BoxRay &box_ray, float tmin,
              float tmax, aacbvh_hit &hit, TraversalCounters *counters) {
    const Node *nodes = bvh.nodes.data();
    const uint32_t *prim_ids = bvh.prim_ids.data();
    uint64_t boxes_tested = 1, prims_tested = 0;
    HitRecord<AnyHit> best(tmax);

    float t_root;
    if (ray_box_conservative(box_ray, nodes[0].box, tmin, tmax, t_root)) {
        SpillBlock<StackEntry> spill;
        NodeStack stack(spill);
        StackEntry current{0, t_root};
        for (;;) {
            const Node &node = nodes[current.node];
            if (!node.is_leaf()) {
                const Node &left = nodes[node.first];
                const Node &right = nodes[node.first + 1];
                float tl, tr, xl, xr;
                const unsigned hits =
                    ray_box_pair_conservative(box_ray, left.box, right.box, tmin, best.tmax, tl, tr, xl, xr);
                const bool hit_l = (hits & 1u) != 0, hit_r = (hits & 2u) != 0;
                boxes_tested += 2;
                if (hit_l && hit_r) {
                    // Nearer entry first; a closest-hit query takes a box
                    // holding the origin by its exit (trace/child_order.h);
                    // of equal keys the smaller box, as in the wide layouts.
                    // The entries stay the pruning bounds.
                    const bool keys = !AnyHit && tmin >= 0.0f;
                    const float kl = keys ? child_order_key(tl, xl, tmin) : tl;
                    const float kr = keys ? child_order_key(tr, xr, tmin) : tr;
                    if (kr < kl || (kr == kl && right.box.half_area() < left.box.half_area())) {
                        stack.push({node.first, tl});
                        current = {node.first + 1, tr};
                    } else {
                        stack.push({node.first + 1, tr});
                        current = {node.first, tl};
                    }
                    continue;
                }
                if (hit_l) { current = {node.first, tl}; continue; }
                if (hit_r) { current = {node.first + 1, tr}; continue; }
            } else {
                prims_tested += node.count;
                if (best.test_leaf(prims, prim_ids, node.first, node.count, tmin)) break;
            }
            // Next: the nearest pending node still in reach of the closest hit.
            if (!best.pop_next(stack, current)) break;
        }
    }

    if (counters) {
        counters->nodes_visited += boxes_tested;
        counters->primitive_tests += prims_tested;
    }
    if (!AnyHit) write_closest(best.found, best.tmax, best.u, best.v, best.prim, hit);
    return best.found;
}

template <bool AnyHit>
bool query(const Bvh &bvh, const Geometry &geometry, const float *triangles, const aacbvh_ray &ray,
           aacbvh_hit &hit, TraversalCounters *counters) {
    ScaledRay scaled;
    const aacbvh_ray *traced = traced_ray(ray, scaled);
    if (bvh.empty() || geometry.kind == GeometryKind::None || traced == nullptr) {
        set_miss(hit);
        return false;
    }
    const aacbvh_ray &r = *traced;
    const BoxRay box_ray = make_box_ray(r.org, r.dir);
    const bool found =
        with_primitives(geometry, bvh.prim_ids.data(), triangles, r, box_ray, [&](const auto &prims) {
            return traverse<AnyHit>(bvh, prims, box_ray, r.tmin, r.tmax, hit, counters);
        });
    if (!AnyHit) scaled.unscale(hit);
    return found;
}

} // namespace

void intersect_ray(const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray, aacbvh_hit &hit,
                   TraversalCounters *counters, const float *triangles) {
    query<false>(bvh, geometry, triangles, ray, hit, counters);
}

bool occluded_ray(const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                  TraversalCounters *counters, const float *triangles) {
    aacbvh_hit unused;
    return query<true>(bvh, geometry, triangles, ray, unused, counters);
}

} // namespace aacbvh
