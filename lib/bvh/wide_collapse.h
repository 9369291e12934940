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
/// leaf). Returns the count, the children in order of surface area, largest
/// first (equals keep the order they were opened in).
///
/// The wide traversals read that order: an any-hit query visits the largest
/// box first (the one most likely to hold an occluder), and a closest-hit
/// query that enters two boxes at the same distance (a ray starting inside
/// both) visits the smaller first, whose hits lie nearer on average.
template <int Width, class IsLeaf>
int open_largest_children(const Node *nodes, uint32_t root, const IsLeaf &is_leaf, uint32_t (&kids)[Width]) {
    if (is_leaf(root)) {
        kids[0] = root;
        return 1;
    }
    // Each child's area and leafness are found once, when it joins.
    float area[Width];
    bool leaf[Width];
    int m = 0;
    const auto join = [&](int k, uint32_t node) {
        kids[k] = node;
        area[k] = nodes[node].box.half_area();
        leaf[k] = is_leaf(node);
    };
    join(m++, nodes[root].first);
    join(m++, nodes[root].first + 1);
    while (m < Width) {
        // Leaves count as area -1: never opened, and no branch on leafness.
        int open = -1;
        float open_area = -1.0f;
        for (int k = 0; k < m; ++k) {
            const float a = leaf[k] ? -1.0f : area[k];
            open = a > open_area ? k : open;
            open_area = a > open_area ? a : open_area;
        }
        if (open < 0) break;
        const uint32_t first = nodes[kids[open]].first;
        join(open, first);
        join(m++, first + 1);
    }
    for (int k = 1; k < m; ++k) { // insertion sort, stable
        const uint32_t kid = kids[k];
        const float a = area[k];
        int i = k;
        for (; i > 0 && area[i - 1] < a; --i) {
            kids[i] = kids[i - 1];
            area[i] = area[i - 1];
        }
        kids[i] = kid;
        area[i] = a;
    }
    return m;
}

} // namespace aacbvh
