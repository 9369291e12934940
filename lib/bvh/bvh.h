// The finished BVH: binary nodes in depth-first order (siblings adjacent) and
// the primitive index array their leaves point into.
#pragma once

#include <cstdint>
#include <vector>

#include "bvh/node.h"
#include "core/memory.h"

namespace aacbvh {

struct Bvh {
    Array<Node> nodes;                ///< nodes[0] is the root; empty for an empty scene
    Array<uint32_t> prim_ids;         ///< leaf slots -> caller's primitive index

    bool empty() const { return nodes.empty(); }
    size_t memory_bytes() const {
        return held_bytes(nodes) + held_bytes(prim_ids);
    }
};

} // namespace aacbvh
