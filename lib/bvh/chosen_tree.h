// A builder's binary tree with its flattening choices made, before any
// layout exists: what the default layout (the 8-wide tree with triangle
// packets and the binary tree's shape, bvh/wide8_bvh.h and
// bvh/compact_topology.h) is made from without writing the binary nodes
// first (docs/PERFORMANCE.md, change 148). A view: the builder's arrays
// (build/binary_tree.h, build/flatten.h) stay where they are.
//
// The binary layout it stands for is the emitted one (build/flatten.h): the
// nodes the choices keep, depth first, left first, each inner node's children
// at the next free pair of positions, leaf slots in the order the walk meets
// the leaves. So a node's slots are one range, and its first slot is the
// first slot of the walk's nodes before it: a top-down walk carries it
// (Place).
#pragma once

#include <cstdint>

#include "core/box.h"

namespace aacbvh {

/// What the layout reads of an inner node's flattening choice.
struct SubtreeCounts {
    uint32_t prims;  ///< primitives below
    uint32_t leaves; ///< leaves kept below (1: the node is one leaf)
};

struct ChosenTree {
    /// Ids [0, n) are one-primitive leaves; an inner id k has children
    /// children[2(k-n)] and children[2(k-n)+1] and counts[k-n].
    const Box *boxes;
    const uint32_t *children;
    const SubtreeCounts *counts;
    /// Per inner id - n: whether the 8-wide layout keeps the subtree whole as
    /// one packet leaf (FlattenRule::packets, build/flatten.h); set for every
    /// leaf of the emitted layout.
    const uint8_t *packet_leaf;
    uint32_t n;
    uint32_t root;

    uint32_t left(uint32_t id) const { return children[2 * size_t(id - n)]; }
    uint32_t right(uint32_t id) const { return children[2 * size_t(id - n) + 1]; }
    uint32_t prims(uint32_t id) const { return id < n ? 1u : counts[id - n].prims; }
    uint32_t leaves(uint32_t id) const { return id < n ? 1u : counts[id - n].leaves; }
    /// A leaf of the emitted layout: one primitive, or a subtree kept whole.
    bool is_leaf(uint32_t id) const { return leaves(id) == 1; }
    bool is_packet_leaf(uint32_t id) const { return id < n || packet_leaf[id - n] != 0; }
};

/// A node with its first leaf slot in the emitted layout.
struct Place {
    uint32_t id;
    uint32_t slot;
};

} // namespace aacbvh
