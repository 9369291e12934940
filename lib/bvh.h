// The finished BVH: binary nodes in depth-first order (siblings adjacent) and
// the primitive index array their leaves point into.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry.h"
#include "memory.h"
#include "node.h"
#include "scheduler.h"

namespace aacbvh {

struct Bvh {
    Array<Node> nodes;                ///< nodes[0] is the root; empty for an empty scene
    Array<uint32_t> prim_ids;         ///< leaf slots -> caller's primitive index

    bool empty() const { return nodes.empty(); }
    size_t memory_bytes() const {
        return nodes.capacity() * sizeof(Node) + prim_ids.capacity() * sizeof(uint32_t);
    }
};

/// The area sums of the SAH cost, kept apart so that the cost can be given for
/// whatever Ct and Ci are in force: (Ct * inner_area + Ci * leaf_area_prims) / root_area.
struct AreaSums {
    double inner_area = 0.0;      ///< sum of inner nodes' surface areas
    double leaf_area_prims = 0.0; ///< sum of leaves' surface area times primitive count
    double root_area = 0.0;

    double sah_cost(double traversal_cost, double intersection_cost) const {
        return root_area > 0.0 ? (traversal_cost * inner_area + intersection_cost * leaf_area_prims) / root_area : 0.0;
    }
};

struct TreeFigures {
    uint64_t leaf_count = 0;
    uint32_t max_depth = 0;
    AreaSums areas;
};

/// The SAH area sums, added up in a fixed order (so the same tree always gives
/// the same bits, whatever the thread count or the caller).
AreaSums sum_areas(const Bvh &bvh, Scheduler &scheduler);

/// Leaf count, depth and SAH area sums of a tree.
TreeFigures measure_tree(const Bvh &bvh, Scheduler &scheduler);

/// Recomputes every node's box bottom-up from the geometry (same topology):
/// leaves in parallel, then inner nodes in one reverse sweep. Linear time.
void refit_tree(Bvh &bvh, const Geometry &geometry, Scheduler &scheduler);

} // namespace aacbvh
