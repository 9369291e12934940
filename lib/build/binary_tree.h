// The builders' common output: a binary tree with one primitive per leaf,
// which flatten.h turns into the finished Bvh. Every builder ends there, so
// trees from different builders are comparable.
#pragma once

#include <cstdint>
#include <vector>

#include "core/box.h"
#include "core/memory.h"

namespace aacbvh {

struct BinaryTree {
    /// Nodes [0, n) are leaves: node i holds primitive prim_ids[i]. Inner nodes
    /// are any ids in [n, 2n); ids need not be dense or ordered.
    Array<Box> boxes;                    ///< 2n entries (one may stay unused)
    Array<uint32_t> children;            ///< inner node k: children[2(k-n)], children[2(k-n)+1]
    Array<uint32_t> prim_ids;            ///< n entries
    uint32_t root = 0;

    uint32_t leaf_count() const { return uint32_t(prim_ids.size()); }
    bool is_leaf(uint32_t id) const { return id < prim_ids.size(); }
    uint32_t left(uint32_t id) const { return children[2 * size_t(id - prim_ids.size())]; }
    uint32_t right(uint32_t id) const { return children[2 * size_t(id - prim_ids.size()) + 1]; }
    void set_children(uint32_t id, uint32_t l, uint32_t r) {
        children[2 * size_t(id - prim_ids.size())] = l;
        children[2 * size_t(id - prim_ids.size()) + 1] = r;
    }
    /// Sizes the arrays for n leaves (n >= 1).
    void resize(uint32_t n) {
        boxes.resize(2 * size_t(n));
        children.resize(2 * size_t(n));
        prim_ids.resize(n);
    }
};

} // namespace aacbvh
