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

struct TreeFigures {
    uint64_t leaf_count = 0;
    uint32_t max_depth = 0;
    double sah_cost = 0.0;
};

/// Leaf count, depth and SAH cost (normalised by the root's area) of a tree.
TreeFigures measure_tree(const Bvh &bvh, double traversal_cost, double intersection_cost);

/// Recomputes every node's box bottom-up from the geometry (same topology):
/// leaves in parallel, then inner nodes in one reverse sweep. Linear time.
void refit_tree(Bvh &bvh, const Geometry &geometry, Scheduler &scheduler);

} // namespace aacbvh
