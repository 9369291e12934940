// Better trees after a build. Each pass is one round of reinsertion
// (optimize/reinsertion.h: sub-trees moved to better places anywhere a few
// levels up) followed by one pass of treelet restructuring after Karras and
// Aila, "Fast Parallel Construction of High-Quality Bounding Volume
// Hierarchies" (HPG 2013). A treelet is a node with the inner nodes grown
// below it (always opening its largest-area leaf) until it has 5 leaves
// (Karras and Aila: 7); the cheapest binary tree over those leaves is found
// exactly by dynamic programming over their subsets, with the same cost as
// sub-tree flattening (build/flatten.h: an inner node costs Ct A plus its
// children, a sub-tree of at most max_leaf_size primitives may instead become
// one leaf costing Ci A N), and replaces the treelet when it is cheaper.
// Working on the one-primitive-per-leaf BinaryTree lets primitives move
// between leaves; flattening then makes the leaves again, so the leaf-size
// limit holds.
//
// A treelet pass visits every inner node bottom-up (a node after both of its
// children's sub-trees), so its work is a constant times the primitive count.
// Sibling sub-trees are independent, so they run in parallel, and the result
// does not depend on the thread count.
#pragma once

#include <cstdint>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "build/flatten.h"
#include "bvh/bvh.h"
#include "core/geometry.h"

namespace aacbvh {

struct OptimizeReport {
    uint32_t passes_run = 0;       ///< passes made (they stop early once one changes nothing)
    uint64_t treelets_changed = 0; ///< treelets replaced and moves made (reinsertion.h), over all passes
    uint64_t moves = 0;            ///< of which reinsertion moves
};

/// Runs up to `passes` passes on `tree`, whose `choices` (flatten.h, for
/// `rule`) must be current for every inner node; keeps them current, so the
/// tree goes straight to emit_bvh(). The root's cost never rises (a
/// reinsertion round that would raise it is undone). Reports
/// progress in [from, to] through ctx; throws what ctx throws (cancel), with
/// the tree then a valid but partly optimised one.
OptimizeReport optimize_tree(BinaryTree &tree, const FlattenRule &rule, SubtreeChoices &choices, uint32_t passes,
                             BuildContext &ctx, double from, double to);

/// The one-primitive-per-leaf BinaryTree of a finished tree's shape, for
/// optimize_tree: leaf i is slot i of prim_ids[0, n), boxed from the
/// geometry; the inner nodes of `nodes` (emitted layout, node_count of them;
/// only their first and count are read, so a shape decoded without boxes
/// serves: bvh/compact_topology.h) are kept and each leaf of several
/// primitives becomes a balanced sub-tree over its slots. Boxes are computed
/// from the primitives.
void unflatten(const Node *nodes, size_t node_count, const uint32_t *prim_ids, size_t n, const Geometry &geometry,
               BuildContext &ctx, BinaryTree &out);

} // namespace aacbvh
