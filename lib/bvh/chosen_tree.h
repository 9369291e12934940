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
#include <cstring>

#include "core/box.h"

namespace aacbvh {

/// What the layout reads of an inner node's flattening choice, in 8 bytes:
/// the primitives below, the leaves kept below (1: the node is one leaf),
/// and, for the 8-wide layout's packets (FlattenRule::packets,
/// build/flatten.h), whether the subtree is one packet leaf and its cost
/// there. Those two matter only for subtrees of at most kSmall primitives
/// (above, a node is a packet leaf exactly when it is one leaf, and its
/// cost is read by no choice), so a small subtree keeps its counts in one
/// word (flag, primitives, leaves, packet-leaf bit) and its packet cost in
/// the other; a larger one its primitives (< 2^31: node ids are 32-bit) and
/// leaves. 5 bytes a node less than separate packet arrays at AAC's peak
/// (docs/PERFORMANCE.md, row 212).
class SubtreeCounts {
public:
    /// Subtrees of at most this many primitives keep a packet choice
    /// (kMaxPacketLeaf, bvh/packet_leaf_sweep.h).
    static constexpr uint32_t kSmall = 16;

    SubtreeCounts() = default;
    SubtreeCounts(uint32_t prims, uint32_t leaves, float packet_cost = 0.0f, bool packet_leaf = false) {
        if (prims <= kSmall) {
            a_ = kSmallFlag | prims | (leaves << 8) | (packet_leaf ? kPacketLeafFlag : 0u);
            std::memcpy(&b_, &packet_cost, sizeof b_);
        } else {
            a_ = prims;
            b_ = leaves;
        }
    }
    uint32_t prims() const { return small() ? a_ & 0xFFu : a_; }
    uint32_t leaves() const { return small() ? (a_ >> 8) & 0xFFu : b_; }
    float packet_cost() const {
        float c = 0.0f;
        if (small()) std::memcpy(&c, &b_, sizeof c);
        return c;
    }
    bool packet_leaf() const { return small() ? (a_ & kPacketLeafFlag) != 0 : b_ == 1; }

private:
    static constexpr uint32_t kSmallFlag = 1u << 31, kPacketLeafFlag = 1u << 16;
    bool small() const { return (a_ & kSmallFlag) != 0; }
    uint32_t a_ = 0, b_ = 0;
};

static_assert(sizeof(SubtreeCounts) == 8, "SubtreeCounts must stay 8 bytes");

struct ChosenTree {
    /// Ids [0, n) are one-primitive leaves; an inner id k has children
    /// children[2(k-n)] and children[2(k-n)+1] and counts[k-n].
    const Box *boxes;
    const uint32_t *children;
    const SubtreeCounts *counts;
    uint32_t n;
    uint32_t root;

    uint32_t left(uint32_t id) const { return children[2 * size_t(id - n)]; }
    uint32_t right(uint32_t id) const { return children[2 * size_t(id - n) + 1]; }
    uint32_t prims(uint32_t id) const { return id < n ? 1u : counts[id - n].prims(); }
    uint32_t leaves(uint32_t id) const { return id < n ? 1u : counts[id - n].leaves(); }
    /// A leaf of the emitted layout: one primitive, or a subtree kept whole.
    bool is_leaf(uint32_t id) const { return leaves(id) == 1; }
    /// Whether the 8-wide layout keeps the subtree whole as one packet leaf
    /// (FlattenRule::packets, build/flatten.h): every leaf of the emitted
    /// layout is one.
    bool is_packet_leaf(uint32_t id) const { return id < n || counts[id - n].packet_leaf(); }
};

/// A node with its place in the emitted layout: its first leaf slot, its
/// position and, for an inner node of the emitted layout, the position of
/// its children's pair. A node's children follow from its own: the left at
/// (below, below + 2), the right at (below + 1, below + 2 leaves(left)), the
/// right's slot after the left's primitives (a subtree of L leaves uses
/// 2 (L - 1) positions below its root).
struct Place {
    uint32_t id;
    uint32_t slot;
    uint32_t pos;
    uint32_t below;
};

/// The emitted layout's shape (one byte a node: a leaf's primitive count, 0
/// for an inner node) and primitive order, as the default layout's collapse
/// writes them while it walks a builder's tree (Wide8Bvh::build(), which
/// meets every inner node above the packet leaves once, and every packet
/// leaf once), instead of a walk of its own before it (docs/PERFORMANCE.md,
/// row 217). `leaf_prims[id]` is the primitive of the builder's leaf id.
struct EmittedOrder {
    uint8_t *shape;
    uint32_t *prim_ids;
    const uint32_t *leaf_prims;
};

/// The inner node at `p` into `out`: its shape byte. Returns its children's places.
inline void emit_inner(const ChosenTree &tree, const EmittedOrder &out, const Place &p, Place &l, Place &r) {
    out.shape[p.pos] = 0;
    const uint32_t left = tree.left(p.id), right = tree.right(p.id);
    l = Place{left, p.slot, p.below, p.below + 2};
    r = Place{right, p.slot + tree.prims(left), p.below + 1, p.below + 2 * tree.leaves(left)};
}

/// The subtree at `p`, a packet leaf, into `out`: its emitted nodes' shape
/// bytes and its leaves' primitives, depth first, left first. A packet leaf
/// holds at most SubtreeCounts::kSmall primitives or is one emitted leaf, of
/// at most kMaxEmittedLeaf primitives (the shape's byte).
inline void emit_packet_leaf(const ChosenTree &tree, const EmittedOrder &out, const Place &p) {
    constexpr uint32_t kMaxEmittedLeaf = 0xFF;
    Place places[SubtreeCounts::kSmall + 1];
    uint32_t ids[kMaxEmittedLeaf + 1];
    int places_top = 0;
    places[places_top++] = p;
    while (places_top != 0) {
        Place at = places[--places_top];
        while (!tree.is_leaf(at.id)) { // emitted inner nodes: down the left, the right waits
            Place l, r;
            emit_inner(tree, out, at, l, r);
            places[places_top++] = r;
            at = l;
        }
        const uint32_t count = tree.prims(at.id);
        out.shape[at.pos] = uint8_t(count);
        uint32_t slot = at.slot;
        int ids_top = 0;
        ids[ids_top++] = at.id;
        while (ids_top != 0) { // the emitted leaf's binary leaves, left to right
            const uint32_t id = ids[--ids_top];
            if (id < tree.n) {
                out.prim_ids[slot++] = out.leaf_prims[id];
            } else {
                ids[ids_top++] = tree.right(id);
                ids[ids_top++] = tree.left(id);
            }
        }
    }
}

} // namespace aacbvh
