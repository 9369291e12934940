#include "bvh/compact_topology.h"

#include <utility>

namespace aacbvh {

void CompactTopology::clear() {
    Array<uint8_t>().swap(shape_);
    Array<Part>().swap(parts_);
    task_depth_ = 0;
}

bool CompactTopology::encode(const Bvh &bvh, Scheduler &scheduler) {
    const size_t n = bvh.nodes.size();
    if (n == 0 || n >= 0xFFFFFFFFu) return false;
    const Node *nodes = bvh.nodes.data();
    Array<uint8_t> shape(n);
    uint8_t *out = shape.data();
    const bool fits = scheduler.parallel_reduce(
        size_t(0), n, size_t(1) << 15, true,
        [&](size_t b, size_t e) {
            bool ok = true;
            for (size_t i = b; i < e; ++i) {
                ok = ok && nodes[i].count <= kMaxLeafCount;
                out[i] = uint8_t(nodes[i].count);
            }
            return ok;
        },
        [](bool a, bool b) { return a && b; });
    if (!fits) return false;

    const uint32_t task_depth = task_depth_for(n);
    // The tasks' roots in the order the walk meets them (depth first, left
    // first), and where the walk's counters stand there and after them, read
    // off the subtree's outer paths: its leftmost and rightmost leaves give
    // its slots; its last inner node in depth-first order, its last pair.
    std::vector<Part> tasks;
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}}; // position, depth
    while (!stack.empty()) {
        const auto [pos, depth] = stack.back();
        stack.pop_back();
        const Node &node = nodes[pos];
        if (depth < task_depth) {
            if (!node.is_leaf()) {
                stack.push_back({node.first + 1, depth + 1});
                stack.push_back({node.first, depth + 1});
            }
            continue;
        }
        uint32_t p = pos;
        while (!nodes[p].is_leaf()) p = nodes[p].first;
        const uint32_t slot = nodes[p].first;
        p = pos;
        while (!nodes[p].is_leaf()) p = nodes[p].first + 1;
        const uint32_t slot_end = nodes[p].first + nodes[p].count;
        uint32_t pair = 0, pairs_used = 0;
        if (!node.is_leaf()) {
            p = pos;
            for (;;) {
                const uint32_t l = nodes[p].first, r = l + 1;
                if (!nodes[r].is_leaf())
                    p = r;
                else if (!nodes[l].is_leaf())
                    p = l;
                else
                    break;
            }
            pair = node.first;
            pairs_used = nodes[p].first + 2 - pair;
        }
        tasks.push_back(Part{pos, depth, pair, slot, pairs_used, slot_end - slot});
    }
    Array<Part> parts(tasks.size() + 1);
    std::copy(tasks.begin(), tasks.end(), parts.begin());
    parts[tasks.size()] = Part{0, 0, 1, 0, uint32_t(n - 1), uint32_t(bvh.prim_ids.size())};

    shape_ = std::move(shape);
    parts_ = std::move(parts);
    task_depth_ = task_depth;
    return true;
}

bool CompactTopology::adopt(Array<uint8_t> &shape, const ChosenTree &tree) {
    const size_t n = shape.size();
    if (n == 0 || n >= 0xFFFFFFFFu) return false;
    const uint32_t task_depth = task_depth_for(n);
    // encode()'s walk over the top of the tree, on the builder's ids: a
    // node's children pair and first slot follow from the leaf and
    // primitive counts (build/flatten.cpp), and a subtree of L leaves uses
    // 2 (L - 1) positions below its root.
    struct Item {
        uint32_t id, pos, pair, slot, depth;
    };
    std::vector<Part> tasks;
    std::vector<Item> stack{{tree.root, 0u, 1u, 0u, 0u}};
    while (!stack.empty()) {
        const Item it = stack.back();
        stack.pop_back();
        const bool leaf = tree.is_leaf(it.id);
        if (it.depth < task_depth) {
            if (!leaf) {
                const uint32_t l = tree.left(it.id), r = tree.right(it.id);
                const uint32_t left_nodes = 2 * tree.leaves(l) - 1;
                stack.push_back({r, it.pair + 1, it.pair + 2 + (left_nodes - 1), it.slot + tree.prims(l), it.depth + 1});
                stack.push_back({l, it.pair, it.pair + 2, it.slot, it.depth + 1});
            }
            continue;
        }
        tasks.push_back(Part{it.pos, it.depth, leaf ? 0u : it.pair, it.slot, leaf ? 0u : 2 * (tree.leaves(it.id) - 1),
                             tree.prims(it.id)});
    }
    Array<Part> parts(tasks.size() + 1);
    std::copy(tasks.begin(), tasks.end(), parts.begin());
    parts[tasks.size()] = Part{0, 0, 1, 0, uint32_t(n - 1), tree.prims(tree.root)};

    shape_ = std::move(shape);
    parts_ = std::move(parts);
    task_depth_ = task_depth;
    return true;
}

void CompactTopology::decode(Array<Node> &nodes) const {
    const size_t n = shape_.size();
    nodes.resize(n);
    if (n == 0) return;
    // The emitted layout's own walk: left first, a pair for each inner node as it is met.
    std::vector<uint32_t> stack{0u};
    uint32_t pair = 1, slot = 0;
    while (!stack.empty()) {
        const uint32_t pos = stack.back();
        stack.pop_back();
        Node &node = nodes[pos];
        node.box = Box::empty();
        node.count = shape_[pos];
        if (node.count != 0) {
            node.first = slot;
            slot += node.count;
        } else {
            node.first = pair;
            stack.push_back(pair + 1);
            stack.push_back(pair);
            pair += 2;
        }
    }
}

} // namespace aacbvh
