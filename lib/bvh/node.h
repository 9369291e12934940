// The finished tree's 32-byte node: the same layout as the public aacbvh_node.
#pragma once

#include <cstddef>
#include <cstdint>

#include "aacbvh/aacbvh.h"
#include "core/box.h"

namespace aacbvh {

struct Node {
    Box box;
    uint32_t first; ///< inner: left child (right = first + 1); leaf: first primitive slot
    uint32_t count; ///< 0 for an inner node, else primitives in the leaf

    bool is_leaf() const { return count != 0; }
};

static_assert(sizeof(Node) == 32, "Node must be 32 bytes");
static_assert(sizeof(Node) == sizeof(aacbvh_node), "Node must match aacbvh_node");
static_assert(offsetof(Node, first) == offsetof(aacbvh_node, first), "layout");
static_assert(offsetof(Node, count) == offsetof(aacbvh_node, count), "layout");

} // namespace aacbvh
