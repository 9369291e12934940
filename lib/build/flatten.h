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

/// The part of a choice that the layout reads.
struct SubtreeCounts {
    uint32_t prims;
    uint32_t leaves;
};

/// The builders' view of the choices of a tree's inner nodes (SubtreeChoices
/// below), indexed by id - leaf_count: two pointers, passed by value.
class ChoiceTable {
public:
    ChoiceTable(double *cost, SubtreeCounts *counts) : cost_(cost), counts_(counts) {}
    SubtreeChoice get(size_t k) const { return {cost_[k], counts_[k].prims, counts_[k].leaves}; }
    void set(size_t k, const SubtreeChoice &c) const {
        cost_[k] = c.cost;
        counts_[k] = SubtreeCounts{c.prims, c.leaves};
    }
    uint32_t prims(size_t k) const { return counts_[k].prims; }

private:
    double *cost_;
    SubtreeCounts *counts_;
};

/// Choices of a tree's inner nodes, indexed by id - leaf_count, as a cost
/// array and a counts array: the costs serve only while choices are made,
/// so emit_bvh() releases them before it allocates the finished tree (8
/// bytes per primitive off the build's peak, docs/PERFORMANCE.md row 123).
class SubtreeChoices {
public:
    void resize(size_t n) {
        cost_.resize(n);
        counts_.resize(n);
    }
    SubtreeChoice get(size_t k) const { return {cost_[k], counts_[k].prims, counts_[k].leaves}; }
    void set(size_t k, const SubtreeChoice &c) {
        cost_[k] = c.cost;
        counts_[k] = SubtreeCounts{c.prims, c.leaves};
    }
    double cost(size_t k) const { return cost_[k]; }
    uint32_t prims(size_t k) const { return counts_[k].prims; }
    uint32_t leaves(size_t k) const { return counts_[k].leaves; }
    void set_prims(size_t k, uint32_t prims) { counts_[k].prims = prims; }
    ChoiceTable table() { return ChoiceTable(cost_.data(), counts_.data()); }
    /// Frees the costs; get() and set() are then out of bounds.
    void release_costs() { Array<double>().swap(cost_); }
    void swap(SubtreeChoices &other) {
        cost_.swap(other.cost_);
        counts_.swap(other.counts_);
    }
    /// The two arrays, for copying a tree's choices whole (the optimiser's undo).
    Array<double> &costs() { return cost_; }
    Array<SubtreeCounts> &counts() { return counts_; }
    /// The counts alone (the binary emit reads them through a pointer).
    const Array<SubtreeCounts> &counts() const { return counts_; }

private:
    Array<double> cost_;
    Array<SubtreeCounts> counts_;
};

/// Bottom-up pass for builders that did not decide while building.
void choose_subtrees(const BinaryTree &tree, const FlattenRule &rule, BuildContext &ctx, SubtreeChoices &choices);

/// Top-down pass: depth-first layout with siblings adjacent. Returns the
/// tree's SAH cost normalised by the root's area (0 when that area is 0).
/// Releases the choices' costs first (SubtreeChoices::release_costs()).
double emit_bvh(const BinaryTree &tree, const FlattenRule &rule, SubtreeChoices &choices, BuildContext &ctx,
                Bvh &out);

} // namespace aacbvh
