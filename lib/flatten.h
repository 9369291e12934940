// Sub-tree flattening (Gu et al. 2013, section "sub-tree flattening"): turns a
// builder's BinaryTree into the finished Bvh, collapsing each sub-tree of at
// most max_leaf_size primitives into one leaf where the SAH says that is cheaper.
#pragma once

#include <cstdint>

#include "binary_tree.h"
#include "build_context.h"
#include "bvh.h"

namespace aacbvh {

void flatten(const BinaryTree &tree, uint32_t max_leaf_size, double traversal_cost,
             double intersection_cost, BuildContext &ctx, Bvh &out);

} // namespace aacbvh
