// The greedy step of agglomerative clustering inside one AAC node (Gu et al.
// 2013, "CombineClusters"): repeatedly merge the two clusters whose union box
// has the smallest surface area until `target` clusters remain.
#pragma once

#include <cstdint>
#include <vector>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "build/flatten.h"
#include "core/box.h"

namespace aacbvh {

/// Scratch memory reused across calls (one per thread) so the hot path does not allocate.
struct CombineScratch {
    std::vector<float> columns;          ///< 6 coordinate columns of the live clusters' boxes
    std::vector<float> distances;        ///< pairwise matrix, row-major, stride = padded count
    std::vector<float> nearest_distance;
    std::vector<uint32_t> nearest;
    std::vector<uint32_t> rescan;        ///< slots whose nearest neighbour must be found again
};

/// Merges clusters ids[0, count) of `tree` (leaf or inner node ids whose boxes
/// are set) until `target` remain, creating one inner node per merge with ids
/// taken in order from free_ids[0, count). On return ids[0, result) are the
/// clusters left and free_ids[0, result) the ids not used. Distances are half
/// surface areas scaled by `scale` (keeps huge and tiny scenes in float range).
/// Ties go to the lowest slot, so results are deterministic. Long combines
/// (thousands of clusters) poll `ctx` for a cancel. Each new node's
/// flattening decision is made at once (its sub-tree is complete): choices
/// are indexed by id - leaf count.
uint32_t combine_clusters(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                          float scale, const FlattenRule &rule, SubtreeChoice *choices, CombineScratch &scratch,
                          BuildContext &ctx);

} // namespace aacbvh
