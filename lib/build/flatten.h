// Sub-tree flattening (Gu et al. 2013, "sub-tree flattening"): turns a
// builder's BinaryTree into the finished Bvh, collapsing each sub-tree of at
// most max_leaf_size primitives into one leaf where the SAH says that is
// cheaper. Every builder goes through the same rule, so trees are comparable.
#pragma once

#include <cstdint>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "bvh/bvh.h"
#include "core/memory.h"

namespace aacbvh {

/// The cheapest form of one sub-tree: its SAH cost (unnormalised: Ct A per
/// inner node plus Ci A N per leaf), primitives below, and leaves it keeps
/// (1 = the whole sub-tree becomes one leaf).
struct SubtreeChoice {
    double cost;
    uint32_t prims;
    uint32_t leaves;
};

struct FlattenRule {
    uint32_t max_leaf_size;
    double traversal_cost;
    double intersection_cost;

    SubtreeChoice leaf(const Box &box) const { return {intersection_cost * box.area(), 1, 1}; }
    /// The decision for an inner node whose children chose l and r.
    SubtreeChoice inner(const Box &box, const SubtreeChoice &l, const SubtreeChoice &r) const {
        const double area = box.area();
        const uint32_t prims = l.prims + r.prims;
        const double split = traversal_cost * area + l.cost + r.cost;
        const double as_leaf = intersection_cost * area * prims;
        if (prims <= max_leaf_size && as_leaf <= split) return {as_leaf, prims, 1};
        return {split, prims, l.leaves + r.leaves};
    }
};

/// Choices of a tree's inner nodes, indexed by id - leaf_count.
using SubtreeChoices = Array<SubtreeChoice>;

/// Bottom-up pass for builders that did not decide while building.
void choose_subtrees(const BinaryTree &tree, const FlattenRule &rule, BuildContext &ctx, SubtreeChoices &choices);

/// Top-down pass: depth-first layout with siblings adjacent. Returns the
/// tree's SAH cost normalised by the root's area (0 when that area is 0).
double emit_bvh(const BinaryTree &tree, const FlattenRule &rule, const SubtreeChoices &choices, BuildContext &ctx,
                Bvh &out);

} // namespace aacbvh
