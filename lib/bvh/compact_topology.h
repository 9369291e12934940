// The binary tree's shape without its boxes: one byte per node instead of
// the 32 of a Node. Handles whose queries run on the 8-wide layout with
// triangle packets (the default) keep this instead of the binary nodes; the
// nodes are made again when asked for (aacbvh_bvh_get_nodes, optimize, a
// change of layout) from the packets' vertices, the 8-wide tree refits from
// its packets alone (Wide8Bvh::refit_from_packets), and the statistics'
// areas come from a walk over this shape.
//
// Why a byte is enough: the emitted layout (build/flatten.cpp) places each
// inner node's two children at the next free pair of positions as a
// depth-first walk (left first) meets the node, and numbers leaf slots in
// the order that walk meets the leaves. So one byte per position, the leaf's
// primitive count or 0 for an inner node, gives every node's `first` back by
// the same walk with two counters.
//
// The walk is split for threads: the subtrees whose roots stand
// task_depth() deep are walked by tasks, the top of the tree above them
// afterwards on the calling thread. Each part adds its areas in its own
// fixed order and the top adds the parts' sums in walk order, so the figures
// are the same bits at any thread count.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "bvh/bvh.h"
#include "bvh/bvh_stats.h"
#include "bvh/chosen_tree.h"
#include "core/box.h"
#include "core/memory.h"
#include "core/scheduler.h"

namespace aacbvh {

class CompactTopology {
public:
    /// Leaves of more primitives than this keep the binary nodes.
    static constexpr uint32_t kMaxLeafCount = 0xFF;
    /// Subtrees whose roots stand task_depth() deep are walked by tasks:
    /// about kTaskNodes nodes each in a balanced tree, at most 2^kMaxTaskDepth
    /// of them.
    static constexpr uint32_t kTaskNodes = 1u << 13;
    static constexpr uint32_t kMaxTaskDepth = 7;

    bool empty() const { return shape_.empty(); }
    size_t node_count() const { return shape_.size(); }
    uint32_t task_depth() const { return task_depth_; }
    /// For tests: the shape bytes, and each part's fields in walk order.
    const Array<uint8_t> &shape() const { return shape_; }
    std::vector<uint32_t> part_fields() const {
        std::vector<uint32_t> out;
        for (const Part &p : parts_) out.insert(out.end(), {p.root, p.depth, p.pair, p.slot, p.pairs_used, p.slots_used});
        return out;
    }
    size_t memory_bytes() const { return held_bytes(shape_) + held_bytes(parts_); }
    void clear();

    /// Encodes `bvh`, which must be in the emitted layout (build/flatten.h:
    /// every tree a build or optimize makes). False, leaving this empty, for
    /// an empty tree or a leaf of more than kMaxLeafCount primitives.
    /// Throws std::bad_alloc, leaving this as it was.
    bool encode(const Bvh &bvh, Scheduler &scheduler);

    /// Takes `shape` (prepare_shape()'s, build/flatten.h, which the 8-wide
    /// collapse fills: EmittedOrder, bvh/chosen_tree.h) as the shape of the
    /// emitted layout of `tree`, which tells where the tasks' parts start.
    /// False, leaving both as they were, for an empty shape. Throws
    /// std::bad_alloc, leaving both as they were.
    bool adopt(Array<uint8_t> &shape, const ChosenTree &tree);

    /// The nodes' `first` and `count`, boxes empty; `nodes` is resized.
    void decode(Array<Node> &nodes) const;

    /// Bottom-up over the tree: each leaf's box is leaf_box(first slot,
    /// count) (a Box, called on the scheduler's threads), each inner node's
    /// the union of its children's (left, then right, as refit_tree()
    /// unites them). Returns the tree's leaf count, depth and areas. Throws
    /// std::bad_alloc (its stacks).
    template <class LeafBox> TreeFigures walk(LeafBox &&leaf_box, Scheduler &scheduler) const;

private:
    static uint32_t task_depth_for(size_t node_count) {
        uint32_t depth = 0;
        while (depth < kMaxTaskDepth && (node_count >> depth) >= 2 * size_t(kTaskNodes)) ++depth;
        return depth;
    }

    /// One task's subtree (or, last, the top of the tree): where its walk
    /// starts and what it covers.
    struct Part {
        uint32_t root, depth;  ///< root position and depth
        uint32_t pair, slot;   ///< next free pair and leaf slot when the walk reaches the root
        uint32_t pairs_used;   ///< positions below the root (two per inner node)
        uint32_t slots_used;   ///< leaf slots in the subtree
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

    template <class LeafBox>
    PartResult walk_part(const Part &part, bool top, const PartResult *task_results, LeafBox &leaf_box,
                         std::vector<Frame> &stack) const;

    Array<uint8_t> shape_; ///< per position: the leaf's primitive count, 0 for an inner node
    Array<Part> parts_;    ///< the tasks in walk order, then the top
    uint32_t task_depth_ = 0;
};

template <class LeafBox>
CompactTopology::PartResult CompactTopology::walk_part(const Part &part, bool top, const PartResult *task_results,
                                                       LeafBox &leaf_box, std::vector<Frame> &stack) const {
    PartResult r;
    stack.clear();
    uint32_t pos = part.root, depth = part.depth, pair = part.pair, slot = part.slot;
    size_t task = 0;
    for (;;) {
        // Down the left side from `pos` to a leaf or, in the top, a task's root.
        Box box;
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
                break;
            }
            const uint32_t count = shape_[pos];
            if (count != 0) {
                box = leaf_box(slot, count);
                slot += count;
                r.leaf += box.area() * count;
                ++r.leaves;
                r.max_depth = std::max(r.max_depth, depth);
                break;
            }
            stack.push_back(Frame{pos, pair, depth, 0, Box::empty()});
            pos = pair;
            pair += 2;
            ++depth;
        }
        // Up while right children are done.
        for (;;) {
            if (stack.empty()) {
                r.box = box;
                return r;
            }
            Frame &f = stack.back();
            if (!f.has_left) {
                f.left = box;
                f.has_left = 1;
                pos = f.child + 1;
                depth = f.depth + 1;
                break;
            }
            box = unite(f.left, box);
            r.inner += box.area();
            stack.pop_back();
        }
    }
}

template <class LeafBox> TreeFigures CompactTopology::walk(LeafBox &&leaf_box, Scheduler &scheduler) const {
    TreeFigures f;
    if (shape_.empty()) return f;
    const size_t tasks = parts_.size() - 1;
    std::vector<PartResult> results(tasks);
    scheduler.parallel_for(0, tasks, 1, [&](size_t b, size_t e) {
        std::vector<Frame> stack;
        stack.reserve(64);
        for (size_t t = b; t < e; ++t) results[t] = walk_part(parts_[t], false, nullptr, leaf_box, stack);
    });
    std::vector<Frame> stack;
    stack.reserve(kMaxTaskDepth + 1);
    const PartResult top = walk_part(parts_[tasks], true, results.data(), leaf_box, stack);
    f.leaf_count = top.leaves;
    f.max_depth = top.max_depth;
    f.areas.inner_area = top.inner;
    f.areas.leaf_area_prims = top.leaf;
    f.areas.root_area = top.box.area();
    return f;
}

} // namespace aacbvh
