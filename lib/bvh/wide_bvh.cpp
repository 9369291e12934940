// Collapse and refit of the 4-wide layout (its traversal: trace/wide_traversal.cpp).
#include "bvh/wide_bvh.h"

#include <cmath>
#include <vector>

#include "bvh/wide_collapse.h"
#include "core/memory.h"

namespace aacbvh {

void WideBvh::clear() {
    Array<WideNode>().swap(nodes_);
    Array<uint32_t>().swap(sources_);
    node_count_ = 0;
    built_ = false;
}

namespace {

void set_empty_slot(WideNode &node, int k) {
    node.box[0][k] = node.box[2][k] = node.box[4][k] = INFINITY;
    node.box[1][k] = node.box[3][k] = node.box[5][k] = -INFINITY;
    node.child[k] = WideNode::kEmptyChild;
    node.count[k] = 0;
}

void set_slot_box(WideNode &node, int k, const Box &b) {
    for (int a = 0; a < 3; ++a) {
        node.box[2 * a][k] = b.lo[a];
        node.box[2 * a + 1][k] = b.hi[a];
    }
}

} // namespace

void WideBvh::build(const Bvh &bvh, Scheduler &scheduler) {
    if (bvh.empty()) {
        clear();
        built_ = true;
        return;
    }
    const Node *bnodes = bvh.nodes.data();
    size_t inner = 0;
    for (size_t i = 0; i < bvh.nodes.size(); ++i) inner += bnodes[i].is_leaf() ? 0 : 1;
    // Every wide node but a lone leaf's consumes a distinct binary inner node.
    const size_t capacity = inner > 0 ? inner : 1;

    // Pass 1, depth-first: the binary nodes that become each wide node's
    // children (kept for refit as `sources`), and the index of its first
    // inner child's wide node (the others follow it). The wide nodes
    // themselves are written in pass 2, once their number is known.
    Array<uint32_t> sources(4 * capacity);
    Array<uint32_t> first_child(capacity);
    struct Work {
        uint32_t binary; ///< binary node whose subtree the wide node covers
        uint32_t wide;
    };
    std::vector<Work> work{{0u, 0u}};
    const float scale = extent_scale_of(bnodes[0].box);
    uint32_t next = 1;
    while (!work.empty()) {
        const Work w = work.back();
        work.pop_back();
        uint32_t kids[4];
        const int n =
            open_largest_children(bnodes, scale, w.binary, [bnodes](uint32_t i) { return bnodes[i].is_leaf(); }, kids);
        uint32_t *src = &sources[4 * size_t(w.wide)];
        uint32_t wide_kid[4];
        first_child[w.wide] = next;
        for (int k = 0; k < 4; ++k) {
            src[k] = k < n ? kids[k] : WideNode::kEmptyChild;
            wide_kid[k] = k < n && !bnodes[kids[k]].is_leaf() ? next++ : WideNode::kEmptyChild;
        }
        // Reverse order: the first child's subtree is laid out first.
        for (int k = n; k-- > 0;)
            if (wide_kid[k] != WideNode::kEmptyChild) work.push_back(Work{kids[k], wide_kid[k]});
    }

    // Pass 2, in parallel: the nodes, exactly as many as pass 1 made.
    Array<WideNode> nodes(next);
    scheduler.parallel_for(0, next, 1u << 12, [&](size_t b, size_t e) {
        for (size_t w = b; w < e; ++w) {
            WideNode &node = nodes[w];
            uint32_t child = first_child[w];
            for (int k = 0; k < 4; ++k) {
                const uint32_t src = sources[4 * w + k];
                if (src == WideNode::kEmptyChild) {
                    set_empty_slot(node, k);
                    continue;
                }
                const Node &c = bnodes[src];
                set_slot_box(node, k, c.box);
                node.child[k] = c.is_leaf() ? c.first : child++;
                node.count[k] = c.count;
            }
        }
    });
    Array<uint32_t>().swap(first_child);
    // A copy of the used part (shrink_to_fit() would swallow an allocation
    // failure and keep the whole array).
    Array<uint32_t> used_sources(sources.begin(), sources.begin() + 4 * ptrdiff_t(next));
    Array<uint32_t>().swap(sources); // a small copy: 16 bytes per wide node
    nodes_ = std::move(nodes);
    sources_ = std::move(used_sources);
    node_count_ = next;
    built_ = true;
}

void WideBvh::refit(const Bvh &bvh, Scheduler &scheduler) {
    const Node *bnodes = bvh.nodes.data();
    WideNode *nodes = nodes_.data();
    const uint32_t *sources = sources_.data();
    scheduler.parallel_for(0, node_count_, 1u << 12, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i)
            for (int k = 0; k < 4; ++k)
                if (sources[4 * i + k] != WideNode::kEmptyChild) set_slot_box(nodes[i], k, bnodes[sources[4 * i + k]].box);
    });
}

} // namespace aacbvh
