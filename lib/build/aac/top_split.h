// The SAH partition of a few large clusters (ours, issue 17), used by AAC at
// its root. AAC's greedy merge by union area never looks at overlap, and its
// last merge joins whichever two clusters remain, so the root's children can
// both span most of the scene; rays that start inside the scene then enter
// both. Splitting the clusters that reach the root once, top-down by SAH over
// their centroids (and merging each side greedily as before), gives the root
// children that a plane separates by centroid.
#pragma once

#include <cstdint>

#include "build/binary_tree.h"
#include "build/flatten.h"

namespace aacbvh {

/// Reorders clusters ids[0, count) (count >= 2; leaf or inner node ids of
/// `tree` with their boxes set; `choices` the flattening choices of the inner
/// ones, indexed by id - leaf count, whose `prims` count primitives) by box
/// centroid along the best axis and returns m in [1, count): ids[0, m) and
/// ids[m, count) minimise SA(left) * N(left) + SA(right) * N(right), N
/// counting primitives, over the sorted orders of the three axes. Ties go to
/// the lower axis and split, and centroid ties to the lower id, so the result
/// is deterministic.
uint32_t sah_partition(const BinaryTree &tree, ChoiceTable choices, uint32_t *ids, uint32_t count);

} // namespace aacbvh
