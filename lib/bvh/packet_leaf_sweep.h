// Which binary subtrees the 8-wide layout keeps whole as one packet leaf
// (bvh/wide8_bvh.cpp), decided by one bottom-up sweep over the binary tree;
// or, in a build of the default layout, by the same rule
// (choose_packet_leaf()) beside the flattening's choices
// (FlattenRule::packets, build/flatten.h).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "bvh/bvh.h"
#include "core/memory.h"
#include "core/scheduler.h"

namespace aacbvh {

/// The range count of a subtree whose slots are not one range.
constexpr uint32_t kNoRange = 0xFFFFFFFFu;

/// Packets of four triangles that hold `primitives` leaf slots.
inline uint32_t packets_for(uint32_t primitives) { return (primitives + 3) / 4; }

/// SAH costs of the packet-leaf choice, relative to a wide node's test.
constexpr float kPacketCost = 0.25f;
constexpr float kInnerCost = 0.35f;
/// Subtrees of at most this many primitives may become one packet leaf
/// (Wide8Bvh::kPacketLeaf).
constexpr uint32_t kMaxPacketLeaf = 16;

/// A packet leaf's cost: its packets'.
inline float packet_leaf_cost(float half_area, uint32_t count) {
    return half_area * kPacketCost * float(packets_for(count));
}

/// An inner node of `count` primitives (kNoRange: not one range) whose
/// children cost `left` and `right`: whether it becomes one packet leaf, and
/// its cost. A node of more than kMaxPacketLeaf primitives never does, and
/// its cost is read by no choice (its ancestors are as big): 0, uncomputed.
inline bool choose_packet_leaf(float half_area, uint32_t count, float left, float right, float &cost) {
    if (count > kMaxPacketLeaf) {
        cost = 0.0f;
        return false;
    }
    const float as_leaf = packet_leaf_cost(half_area, count);
    const float as_tree = half_area * kInnerCost + left + right;
    const bool leaf = as_leaf <= as_tree;
    cost = leaf ? as_leaf : as_tree;
    return leaf;
}

/// Per binary node: its subtree's slot range (count kNoRange unless its
/// slots are one range) and whether the subtree becomes one packet leaf. By
/// the SAH, bottom-up: a subtree of at most Wide8Bvh::kPacketLeaf primitives
/// is one leaf when testing its packets costs less than walking its inner
/// nodes (a binary inner node costs about a third of a wide node: a wide
/// node replaces about three levels) and testing their leaves' packets.
class PacketLeafSweep {
public:
    /// Subtrees of more nodes than this are swept by two tasks.
    static constexpr size_t kDefaultGrain = size_t(1) << 15;

    /// `bvh` in the emitted layout (build/flatten.h). `grain` is for tests:
    /// the answer is the same for any.
    PacketLeafSweep(const Bvh &bvh, Scheduler &scheduler, size_t grain = kDefaultGrain);

    Array<uint32_t> range_count, range_first;
    Array<uint8_t> packet_leaf;

private:
    void sweep(uint32_t i, size_t end, unsigned depth);
    void visit(uint32_t i);

    const Node *nodes_;
    /// The tree's extent_scale_of() (core/box.h), as FlattenRule::packet_area()
    /// scales the same areas in a build straight to the layout.
    float extent_scale_;
    Scheduler &scheduler_;
    size_t grain_;
    Array<float> cost_; ///< during the sweep only
};

} // namespace aacbvh
