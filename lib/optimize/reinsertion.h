// Reinsertion (Bittner, Hapala and Havran, "Fast Insertion-Based Optimization
// of Bounding Volume Hierarchies", CGF 2013), in rounds as Meister and Bittner
// run it in parallel ("Parallel Reinsertion for Bounding Volume Hierarchy
// Optimization", CGF 2018): every node searches, on the unchanged tree, the
// place where taking it out and putting it back as the sibling of another
// node lowers the sum of inner-node areas most; the moves are then taken
// greedily, best first, skipping any that touches a node an earlier one
// changed or that would close a cycle (the caller then refits the boxes).
//
// Unlike treelets, a move may carry a sub-tree anywhere within a few levels
// up, which is what agglomerative trees need: their excess SAH is spread over
// the middle levels (docs/PERFORMANCE.md, "Optimisation (issue 14)"), out of
// a treelet's reach.
//
// Bounded work: each search walks at most 12 levels up and visits at most 32
// nodes below them (reinsertion.cpp), so a round is a constant times the
// node count (plus sorting the moves found). Searches run in parallel on
// the context's threads, each reading only the unchanged tree; the moves are
// chosen and made in one fixed order, so the result is the same at any
// thread count.
#pragma once

#include <cstdint>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "build/flatten.h"
#include "core/memory.h"

namespace aacbvh {

/// Rounds on one tree, keeping their scratch arrays from round to round.
class Reinsertion {
public:
    /// `choices` (build/flatten.h) tell which sub-trees flattening makes one
    /// leaf: those move whole and are not searched inside.
    Reinsertion(BinaryTree &tree, const SubtreeChoices &choices, BuildContext &ctx)
        : t_(tree), choices_(choices), ctx_(ctx), n_(tree.leaf_count()) {}

    /// One round; returns the moves made. Inner boxes above the moves are
    /// left stale, and choices too: the caller recomputes both. Throws what
    /// ctx throws (cancel) and std::bad_alloc before it moves anything.
    uint64_t round();

    /// Puts back the children and the root the last round changed (the
    /// boxes it left alone; the caller recomputes them and the choices),
    /// instead of a copy of the tree kept for the purpose.
    void undo();

private:
    struct Move {
        double delta;    ///< change of the sum of inner-node areas (negative: a gain)
        uint32_t node;   ///< the node that moves
        uint32_t target; ///< it becomes this node's sibling; UINT32_MAX: no move
    };
    bool atomic(uint32_t id) const { return t_.is_leaf(id) || choices_.leaves(id - n_) == 1; }
    /// Half surface areas as the searches weigh them: in single precision,
    /// on extents scaled by the tree's extent_scale_of() (core/box.h); in
    /// double they cost a third of the search's instructions
    /// (docs/PERFORMANCE.md, row 180). The root's cost check after the round
    /// (optimize/treelet_optimizer.cpp) is in double, so rounding here can
    /// only make a round be undone.
    float half_area(const Box &b) const { return scaled_half_area(b, area_scale_); }
    float joined_half_area(const Box &a, const Box &b) const { return half_area(unite(a, b)); }
    uint32_t sibling(uint32_t id) const;
    size_t preorder();
    Move search(uint32_t node) const;
    bool take(const Move &m);
    void replace_child(uint32_t parent, uint32_t from, uint32_t to);
    /// Records a node's children before a move changes them (undo()).
    void remember(uint32_t node) { undo_log_.push_back({node, t_.left(node), t_.right(node)}); }

    struct Children {
        uint32_t node, left, right;
    };

    BinaryTree &t_;
    const SubtreeChoices &choices_;
    BuildContext &ctx_;
    const uint32_t n_;
    double root_area_ = 0.0;
    float area_scale_ = 1.0f; ///< extent_scale_of() the root's box, set by round()
    Array<uint32_t> parent_;
    Array<uint32_t> order_; ///< the nodes searched, in pre-order
    Array<uint32_t> stack_;
    Array<uint8_t> flags_;  ///< 1: a move taken this round changed this node
    Array<Move> moves_;
    Array<Children> undo_log_;       ///< the last round's changes, in order (3 per move)
    uint32_t root_before_ = 0;       ///< the root before the last round
};

} // namespace aacbvh
