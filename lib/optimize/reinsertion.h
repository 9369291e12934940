// Reinsertion (Bittner, Hapala and Havran, "Fast Insertion-Based Optimization
// of Bounding Volume Hierarchies", CGF 2013), in rounds as Meister and Bittner
// run it in parallel ("Parallel Reinsertion for Bounding Volume Hierarchy
// Optimization", CGF 2018): every node searches, on the unchanged tree, the
// place where taking it out and putting it back as the sibling of another
// node lowers the sum of inner-node areas most; the moves are then taken
// greedily, best first, skipping any that touches a node an earlier one
// changed or that could close a cycle, and the boxes are refitted.
//
// Unlike treelets, a move may carry a sub-tree anywhere within a few levels
// up, which is what agglomerative trees need: their excess SAH is spread over
// the middle levels (docs/PERFORMANCE.md, entry 23), out of a treelet's reach.
//
// Bounded work: each search walks at most kReinsertLevels levels up and
// visits at most kReinsertVisits nodes, so a round is a constant times the
// node count (plus sorting the moves found). Searches run in parallel on
// the context's threads, each reading only the unchanged tree; the moves are
// chosen and made in one fixed order, so the result is the same at any
// thread count.
#pragma once

#include <cstdint>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "build/flatten.h"

namespace aacbvh {

/// One round on `tree` (boxes must be exact unions of the children's).
/// Returns the moves made; boxes are refitted, choices (build/flatten.h) are
/// left to the caller. Throws what ctx throws (cancel) and std::bad_alloc;
/// the tree is then unchanged if the throw came before the moves, else valid.
uint64_t reinsertion_round(BinaryTree &tree, const SubtreeChoices &choices, BuildContext &ctx);

} // namespace aacbvh
