// The collapse of a binary tree into wide nodes, shared by the 4-wide and
// 8-wide layouts (bvh/wide_bvh.cpp, bvh/wide8_bvh.cpp): which binary nodes
// become one wide node's children.
#pragma once

#include <cstdint>

#include "bvh/node.h"

namespace aacbvh {

/// The children of the wide node over binary node `root`: its two binary
/// children, then the child of largest area (the first of equals) opened
/// into its two until there are `Width` children or only leaves, as
/// `is_leaf(i)` says (binary leaves, or whatever else the layout keeps
/// whole). A root that is a leaf is its own only child (a tree that is one
/// leaf). Returns the count.
template <int Width, class IsLeaf>
int open_largest_children(const Node *nodes, uint32_t root, const IsLeaf &is_leaf, uint32_t (&kids)[Width]) {
    if (is_leaf(root)) {
        kids[0] = root;
        return 1;
    }
    int m = 0;
    kids[m++] = nodes[root].first;
    kids[m++] = nodes[root].first + 1;
    while (m < Width) {
        int open = -1;
        float open_area = -1.0f;
        for (int k = 0; k < m; ++k) {
            if (is_leaf(kids[k])) continue;
            const float a = nodes[kids[k]].box.half_area();
            if (a > open_area) {
                open = k;
                open_area = a;
            }
        }
        if (open < 0) break;
        const uint32_t first = nodes[kids[open]].first;
        kids[open] = first;
        kids[m++] = first + 1;
    }
    return m;
}

} // namespace aacbvh
