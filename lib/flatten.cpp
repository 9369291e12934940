#include "flatten.h"

#include <vector>

namespace aacbvh {

namespace {

/// Per tree node: primitives below, the cheapest SAH cost of its sub-tree
/// (unnormalised: Ct A per inner node, Ci A N per leaf), and whether that
/// cheapest form is a single leaf.
struct Choice {
    double cost;
    uint32_t prims;
    uint32_t leaves; ///< leaves of the flattened sub-tree
};

} // namespace

void flatten(const BinaryTree &tree, uint32_t max_leaf_size, double traversal_cost, double intersection_cost,
             BuildContext &ctx, Bvh &out) {
    const uint32_t n = tree.leaf_count();
    out.nodes.clear();
    out.prim_ids.clear();
    if (n == 0) return;

    // Bottom-up: post-order with an explicit stack (trees may be as deep as n).
    Array<Choice> choice(tree.boxes.size());
    for (uint32_t id = 0; id < tree.boxes.size(); ++id) choice[id].prims = 0; // 0 = not visited yet
    {
        std::vector<uint32_t> stack;
        stack.push_back(tree.root);
        while (!stack.empty()) {
            const uint32_t id = stack.back();
            if (tree.is_leaf(id)) {
                choice[id] = {intersection_cost * tree.boxes[id].area(), 1, 1};
                stack.pop_back();
                continue;
            }
            const uint32_t l = tree.left(id), r = tree.right(id);
            // prims == 0 marks a child not yet visited.
            if (!tree.is_leaf(l) && choice[l].prims == 0) { stack.push_back(l); continue; }
            if (!tree.is_leaf(r) && choice[r].prims == 0) { stack.push_back(r); continue; }
            if (tree.is_leaf(l)) choice[l] = {intersection_cost * tree.boxes[l].area(), 1, 1};
            if (tree.is_leaf(r)) choice[r] = {intersection_cost * tree.boxes[r].area(), 1, 1};
            stack.pop_back();
            const double area = tree.boxes[id].area();
            const uint32_t prims = choice[l].prims + choice[r].prims;
            const double split = traversal_cost * area + choice[l].cost + choice[r].cost;
            const double as_leaf = intersection_cost * area * prims;
            if (prims <= max_leaf_size && as_leaf <= split)
                choice[id] = {as_leaf, prims, 1};
            else
                choice[id] = {split, prims, choice[l].leaves + choice[r].leaves};
            if ((stack.size() & 0x3FFF) == 0) ctx.check_cancelled();
        }
    }

    // Top-down: depth-first layout, siblings adjacent. A node at `pos` whose
    // children pair starts at `below` puts the left child's descendants at
    // below + 2 and the right child's after them.
    const uint32_t leaf_count = choice[tree.root].leaves;
    out.nodes.resize(2 * size_t(leaf_count) - 1);
    out.prim_ids.resize(n);
    struct Item { uint32_t id, pos, below, prim; };
    std::vector<Item> stack;
    std::vector<uint32_t> gather;
    stack.push_back({tree.root, 0, 1, 0});
    while (!stack.empty()) {
        const Item it = stack.back();
        stack.pop_back();
        Node &node = out.nodes[it.pos];
        node.box = tree.boxes[it.id];
        const Choice &c = choice[it.id];
        if (c.leaves == 1) {
            node.first = it.prim;
            node.count = c.prims;
            uint32_t slot = it.prim;
            gather.push_back(it.id);
            while (!gather.empty()) {
                const uint32_t g = gather.back();
                gather.pop_back();
                if (tree.is_leaf(g)) {
                    out.prim_ids[slot++] = tree.prim_ids[g];
                } else {
                    gather.push_back(tree.right(g));
                    gather.push_back(tree.left(g));
                }
            }
            continue;
        }
        const uint32_t l = tree.left(it.id), r = tree.right(it.id);
        node.first = it.below;
        node.count = 0;
        const uint32_t left_nodes = 2 * choice[l].leaves - 1;
        stack.push_back({r, it.below + 1, it.below + 2 + (left_nodes - 1), it.prim + choice[l].prims});
        stack.push_back({l, it.below, it.below + 2, it.prim});
    }
}

} // namespace aacbvh
