// The binary tree's shape without its boxes: one byte per node instead of
// the 32 of a Node. Handles whose queries run on the 8-wide layout with
// triangle packets (the default) keep this instead of the binary nodes; the
// nodes are made again when asked for (aacbvh_bvh_get_nodes, optimize, a
// change of layout) from the packets' vertices, and refit walks this shape
// to give the wide nodes their boxes and the statistics their areas.
//
// Why a byte is enough: the emitted layout (build/flatten.cpp) places each
// inner node's two children at the next free pair of positions as a
// depth-first walk (left first) meets the node, and numbers leaf slots in
// the order that walk meets the leaves. So one byte per position, the leaf's
// primitive count or 0 for an inner node, gives every node's `first` back by
// the same walk with two counters. The byte's high bit marks the binary
// nodes behind the 8-wide tree's child slots.
//
// The walk is split for threads: the subtrees whose roots stand
// task_depth() deep are walked by tasks, the top of the tree above them afterwards on
// the calling thread. Each part adds its areas in its own fixed order and
// the top adds the parts' sums in walk order, so the figures are the same
// bits at any thread count.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "bvh/bvh.h"
#include "bvh/bvh_stats.h"
#include "core/box.h"
#include "core/memory.h"
#include "core/scheduler.h"

namespace aacbvh {

class CompactTopology {
public:
    static constexpr uint8_t kSourceBit = 0x80;
    /// Leaves of more primitives than this keep the binary nodes.
    static constexpr uint32_t kMaxLeafCount = 0x7F;
    /// Subtrees whose roots stand task_depth() deep are walked by tasks:
    /// about kTaskNodes nodes each in a balanced tree, at most 2^kMaxTaskDepth
    /// of them (each holds a stack of its height: small trees one task).
    static constexpr uint32_t kTaskNodes = 1u << 13;
    static constexpr uint32_t kMaxTaskDepth = 7;
    uint32_t task_depth() const { return task_depth_; }

    bool empty() const { return shape_.empty(); }
    size_t node_count() const { return shape_.size(); }
    size_t memory_bytes() const { return held_bytes(shape_) + held_bytes(targets_) + held_bytes(parts_) +
                                          held_bytes(frames_) + held_bytes(results_); }
    void clear();

    /// Encodes `bvh` (emitted by build/flatten.h) with `sources`: for each of
    /// `slot_count` wide child slots, the binary node behind it or
    /// 0xFFFFFFFF. False, leaving this empty, when the tree is not in the
    /// emitted layout or has a leaf of more than kMaxLeafCount primitives.
    /// Throws std::bad_alloc, leaving this as it was.
    bool encode(const Bvh &bvh, const uint32_t *sources, size_t slot_count);

    /// The nodes' `first` and `count`, boxes left empty; `nodes` is resized.
    void decode(Array<Node> &nodes) const;

    /// Bottom-up over the tree (not from two threads at once): each leaf's box is leaf_box(first slot,
    /// count) (a Box), each inner node's the union of its children's (left,
    /// then right, as refit_tree() unites them); each marked node's box goes
    /// to set_slot(wide child slot, box). Returns the tree's figures. Makes
    /// no allocation (its stacks were sized by encode); leaf_box and
    /// set_slot run on the scheduler's threads, each slot once.
    template <class LeafBox, class SetSlot>
    TreeFigures walk(LeafBox &&leaf_box, SetSlot &&set_slot, Scheduler &scheduler) const;

private:
    /// One task's subtree (or, last, the top of the tree): where its walk
    /// starts, what it covers, and its stack's place in frames_.
    struct Part {
        uint32_t root, depth;      ///< root position and depth
        uint32_t pair, slot;       ///< next free pair and leaf slot when the walk reaches the root
        uint32_t target;           ///< its first entry in targets_
        uint32_t pairs_used;       ///< positions below the root (two per inner node)
        uint32_t slots_used;       ///< leaf slots in the subtree
        uint32_t frame, height;    ///< its stack: frames_[frame, frame + height)
    };
    struct Frame {
        uint32_t pos, child, depth, has_left;
        Box left;
    };
    /// What a part's walk gives back.
    struct PartResult {
        Box box = Box::empty();
        double inner = 0.0, leaf = 0.0;
        uint64_t leaves = 0;
        uint32_t max_depth = 0;
    };

    template <class LeafBox, class SetSlot>
    PartResult walk_part(const Part &part, bool top, const PartResult *task_results, LeafBox &leaf_box,
                         SetSlot &set_slot) const;

    Array<uint8_t> shape_;   ///< per position: leaf primitive count (0: inner) | kSourceBit
    Array<uint32_t> targets_; ///< the marked nodes' wide slots, part by part in walk order
    Array<Part> parts_;      ///< the tasks in walk order, then the top
    /// The walks' stacks (each part its own range) and the tasks' results:
    /// so walk() allocates nothing, and two walks of one topology must not
    /// run at once.
    mutable Array<Frame> frames_;
    mutable Array<PartResult> results_;
    uint32_t task_depth_ = 0;
};

template <class LeafBox, class SetSlot>
CompactTopology::PartResult CompactTopology::walk_part(const Part &part, bool top, const PartResult *task_results,
                                                       LeafBox &leaf_box, SetSlot &set_slot) const {
    PartResult r;
    Frame *stack = frames_.data() + part.frame;
    size_t height = 0;
    uint32_t pos = part.root, depth = part.depth, pair = part.pair, slot = part.slot, target = part.target;
    size_t task = 0;
    for (;;) {
        // Down the left side from `pos` to a leaf or, in the top, a task's root.
        Box box;
        bool from_task = false;
        for (;;) {
            if (top && depth == task_depth_) {
                const PartResult &t = task_results[task];
                const Part &tp = parts_[task++];
                box = t.box;
                r.inner += t.inner;
                r.leaf += t.leaf;
                r.leaves += t.leaves;
                r.max_depth = std::max(r.max_depth, t.max_depth);
                pair += tp.pairs_used;
                slot += tp.slots_used;
                from_task = true;
                break;
            }
            const uint32_t count = shape_[pos] & ~uint32_t(kSourceBit);
            if (count != 0) {
                box = leaf_box(slot, count);
                slot += count;
                r.leaf += box.area() * count;
                ++r.leaves;
                r.max_depth = std::max(r.max_depth, depth);
                break;
            }
            stack[height++] = Frame{pos, pair, depth, 0, Box::empty()};
            pos = pair;
            pair += 2;
            ++depth;
        }
        // Up while right children are done.
        for (;;) {
            if (!from_task && (shape_[pos] & kSourceBit)) set_slot(targets_[target++], box);
            from_task = false;
            if (height == 0) {
                r.box = box;
                return r;
            }
            Frame &f = stack[height - 1];
            if (!f.has_left) {
                f.left = box;
                f.has_left = 1;
                pos = f.child + 1;
                depth = f.depth + 1;
                break;
            }
            box = unite(f.left, box);
            r.inner += box.area();
            pos = f.pos;
            --height;
        }
    }
}

template <class LeafBox, class SetSlot>
TreeFigures CompactTopology::walk(LeafBox &&leaf_box, SetSlot &&set_slot, Scheduler &scheduler) const {
    TreeFigures f;
    if (shape_.empty()) return f;
    const size_t tasks = parts_.size() - 1;
    PartResult *results = results_.data();
    scheduler.parallel_for(0, tasks, 1, [&](size_t b, size_t e) {
        for (size_t t = b; t < e; ++t) results[t] = walk_part(parts_[t], false, nullptr, leaf_box, set_slot);
    });
    const PartResult top = walk_part(parts_[tasks], true, results, leaf_box, set_slot);
    f.leaf_count = top.leaves;
    f.max_depth = top.max_depth;
    f.areas.inner_area = top.inner;
    f.areas.leaf_area_prims = top.leaf;
    f.areas.root_area = top.box.area();
    return f;
}

} // namespace aacbvh
