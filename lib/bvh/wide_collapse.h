// The collapse of a binary tree into wide nodes, shared by the 4-wide and
// 8-wide layouts (bvh/wide_bvh.cpp, bvh/wide8_bvh.cpp): which binary nodes
// become one wide node's children.
#pragma once

#include <cstdint>

#include "bvh/node.h"

namespace aacbvh {

/// kids[0, m) reordered by area[0, m) (moved along), largest first, equals
/// in the order given (a stable insertion sort): the order of a wide node's
/// children that the traversals read (open_largest(), below, and the
/// planned collapse, bvh/collapse_plan.h).
template <class Handle> void sort_largest_first(int m, Handle *kids, float *area) {
    for (int k = 1; k < m; ++k) {
        const Handle kid = kids[k];
        const float a = area[k];
        int i = k;
        for (; i > 0 && area[i - 1] < a; --i) {
            kids[i] = kids[i - 1];
            area[i] = area[i - 1];
        }
        kids[i] = kid;
        area[i] = a;
    }
}

/// The children of the wide node over binary node `root` of `source` (a
/// Source: Handle, is_leaf(h), half_area(h), children(h, l, r), and
/// prefetch_children(h), a hint that h may be opened next): its two binary
/// children, then the child of largest area (the first of equals) opened
/// into its two until there are `Width` children or only leaves, as
/// `is_leaf(i)` says (binary leaves, or whatever else the layout keeps
/// whole). A root that is a leaf is its own only child (a tree that is one
/// leaf). Returns the count, the children in order of surface area, largest
/// first (equals keep the order they were opened in).
///
/// The wide traversals read that order: an any-hit query visits the largest
/// box first (the one most likely to hold an occluder), and a closest-hit
/// query whose keys for two boxes tie (trace/child_order.h: the same entry
/// distance, or, for boxes holding the origin, the same exit) visits the
/// smaller first, whose hits lie nearer on average.
template <int Width, class Source>
int open_largest(const Source &source, typename Source::Handle root, typename Source::Handle (&kids)[Width]) {
    using Handle = typename Source::Handle;
    if (source.is_leaf(root)) {
        kids[0] = root;
        return 1;
    }
    // Each child's area and leafness are found once, when it joins.
    float area[Width];
    bool leaf[Width];
    int m = 0;
    const auto join = [&](int k, Handle node) {
        kids[k] = node;
        source.prefetch_children(node);
        area[k] = source.half_area(node);
        leaf[k] = source.is_leaf(node);
    };
    Handle l, r;
    source.children(root, l, r);
    join(m++, l);
    join(m++, r);
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
        source.children(kids[open], l, r);
        join(open, l);
        join(m++, r);
    }
    sort_largest_first(m, kids, area);
    return m;
}

/// The emitted binary nodes' areas and children as open_largest() reads
/// them; a Source adds is_leaf().
struct EmittedShape {
    using Handle = uint32_t;
    const Node *nodes;
    /// extent_scale_of() the root's box (core/box.h): areas on scaled extents,
    /// so that a scene near 1e20 does not compare infinite areas.
    float extent_scale;
    /// The emitted children lie next to their parent's siblings: no hint.
    void prefetch_children(uint32_t) const {}
    float half_area(uint32_t i) const {
        return nodes[i].box.is_empty() ? 0.0f : scaled_half_area(nodes[i].box, extent_scale);
    }
    void children(uint32_t i, uint32_t &l, uint32_t &r) const {
        l = nodes[i].first;
        r = l + 1;
    }
};

/// open_largest() over the emitted binary nodes, with the leaves
/// `is_leaf(i)` says; `extent_scale` is extent_scale_of(nodes[0].box).
template <int Width, class IsLeaf>
int open_largest_children(const Node *nodes, float extent_scale, uint32_t root, const IsLeaf &is_leaf,
                          uint32_t (&kids)[Width]) {
    struct Source : EmittedShape {
        const IsLeaf &leaf;
        bool is_leaf(uint32_t i) const { return leaf(i); }
    };
    return open_largest<Width>(Source{{nodes, extent_scale}, is_leaf}, root, kids);
}

} // namespace aacbvh
