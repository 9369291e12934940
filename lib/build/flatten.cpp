#include "build/flatten.h"

#include <vector>

namespace aacbvh {

void choose_subtrees(const BinaryTree &tree, const FlattenRule &rule, BuildContext &ctx, SubtreeChoices &choices) {
    const uint32_t n = tree.leaf_count();
    choices.resize(n, rule.packets);
    if (n < 2) return;
    for (uint32_t k = 0; k < n; ++k) choices.set_prims(k, 0); // 0 = not decided yet
    auto choice = [&](uint32_t id) { return tree.is_leaf(id) ? rule.leaf(tree.boxes[id]) : choices.get(id - n); };

    // Post-order with an explicit stack: trees may be as deep as n.
    std::vector<uint32_t> stack{tree.root};
    uint32_t done = 0;
    while (!stack.empty()) {
        const uint32_t id = stack.back();
        const uint32_t l = tree.left(id), r = tree.right(id);
        if (!tree.is_leaf(l) && choices.prims(l - n) == 0) { stack.push_back(l); continue; }
        if (!tree.is_leaf(r) && choices.prims(r - n) == 0) { stack.push_back(r); continue; }
        stack.pop_back();
        choices.set(id - n, rule.inner(tree.boxes[id], choice(l), choice(r)));
        if ((++done & 0xFFFF) == 0) ctx.poll();
    }
}

namespace {

/// Writes the emitted layout's binary nodes.
struct NodeSink {
    Node *nodes;
    const Box *boxes;
    void inner(uint32_t pos, uint32_t id, uint32_t below) const {
        Node &node = nodes[pos];
        node.box = boxes[id];
        node.first = below;
        node.count = 0;
    }
    void leaf(uint32_t pos, uint32_t id, uint32_t slot, uint32_t count) const {
        Node &node = nodes[pos];
        node.box = boxes[id];
        node.first = slot;
        node.count = count;
    }
};

/// Lays out one sub-tree. A node at `pos` whose children pair starts at
/// `below` puts its left child's descendants at below + 2 and its right
/// child's after them, so positions follow from the leaf counts alone and
/// large sub-trees can be laid out in parallel with the same result.
template <class Sink> class Emitter {
public:
    Emitter(const BinaryTree &tree, const SubtreeChoices &choices, BuildContext &ctx, const Sink &sink,
            uint32_t *prim_out)
        : tree_(tree), choices_(choices), ctx_(ctx), sink_(sink), prim_out_(prim_out), n_(tree.leaf_count()) {}

    void emit(uint32_t id, uint32_t pos, uint32_t below, uint32_t prim, unsigned depth) {
        // Large sub-trees near the top split into tasks; the rest, and any
        // very deep chain, go through the explicit stack below.
        while (depth < kParallelDepth && !tree_.is_leaf(id) && choices_.leaves(id - n_) > 1 &&
               choices_.prims(id - n_) >= kParallelGrain) {
            const uint32_t l = tree_.left(id), r = tree_.right(id);
            sink_.inner(pos, id, below);
            const uint32_t left_nodes = 2 * leaves(l) - 1;
            ctx_.scheduler().fork_join(
                [&] { emit(l, below, below + 2, prim, depth + 1); },
                [&] { emit(r, below + 1, below + 2 + (left_nodes - 1), prim + prims(l), depth + 1); });
            return;
        }
        emit_serial(id, pos, below, prim);
    }

private:
    static constexpr unsigned kParallelDepth = 24;
    static constexpr uint32_t kParallelGrain = 1u << 14;

    uint32_t leaves(uint32_t id) const { return tree_.is_leaf(id) ? 1 : choices_.leaves(id - n_); }
    uint32_t prims(uint32_t id) const { return tree_.is_leaf(id) ? 1 : choices_.prims(id - n_); }

    /// The loop below keeps the arrays' pointers and its stacks in locals:
    /// through members, every store to a node made the compiler read the
    /// vectors' pointers and sizes again (docs/PERFORMANCE.md row 134).
    void emit_serial(uint32_t root, uint32_t root_pos, uint32_t root_below, uint32_t root_prim) {
        struct Item { uint32_t id, pos, below, prim; };
        const uint32_t n = n_;
        const uint32_t *const children = tree_.children.data();
        const Box *const boxes = tree_.boxes.data();
        const uint32_t *const leaf_prims = tree_.prim_ids.data();
        const SubtreeCounts *const counts = choices_.counts().data();
        const Sink sink = sink_;
        uint32_t *const prim_out = prim_out_;
        auto leaves = [=](uint32_t id) { return id < n ? 1u : counts[id - n].leaves(); };
        auto prims = [=](uint32_t id) { return id < n ? 1u : counts[id - n].prims(); };

        std::vector<Item> stack_store(64);
        std::vector<uint32_t> gather_store(64);
        Item *stack = stack_store.data();
        uint32_t *gather = gather_store.data();
        size_t top = 0, gathered = 0;
        stack[top++] = Item{root, root_pos, root_below, root_prim};
        while (top != 0) {
            Item it = stack[--top];
            // Down the left children; the right ones wait on the stack.
            while (leaves(it.id) != 1) {
                const uint32_t l = children[2 * size_t(it.id - n)], r = children[2 * size_t(it.id - n) + 1];
                // The right child's children, counts and box, asked for
                // ahead of its turn: it waits while the left subtree is laid
                // out, and its reads are scattered (dragon AAC-Fast: the emit
                // 37 -> 31.5 ms with warm memory, docs/PERFORMANCE.md rows 74
                // and 157).
                if (r >= n) {
                    __builtin_prefetch(&children[2 * size_t(r - n)]);
                    __builtin_prefetch(&counts[r - n]);
                    __builtin_prefetch(&boxes[r]);
                }
                sink.inner(it.pos, it.id, it.below);
                const uint32_t left_nodes = 2 * leaves(l) - 1;
                if (top == stack_store.size()) {
                    stack_store.resize(2 * top);
                    stack = stack_store.data();
                }
                stack[top++] = Item{r, it.below + 1, it.below + 2 + (left_nodes - 1), it.prim + prims(l)};
                it = Item{l, it.below, it.below + 2, it.prim};
            }
            // The leaf's primitives, left to right. One primitive, or an
            // inner node over two (most leaves), without the gather stack
            // (docs/PERFORMANCE.md, change 143).
            uint32_t slot = it.prim;
            if (it.id < n) {
                sink.leaf(it.pos, it.id, slot, 1);
                prim_out[slot] = leaf_prims[it.id];
                continue;
            }
            sink.leaf(it.pos, it.id, slot, counts[it.id - n].prims());
            const uint32_t l = children[2 * size_t(it.id - n)], r = children[2 * size_t(it.id - n) + 1];
            if (l < n && r < n) {
                prim_out[slot] = leaf_prims[l];
                prim_out[slot + 1] = leaf_prims[r];
                continue;
            }
            gather[gathered++] = r;
            gather[gathered++] = l;
            while (gathered != 0) {
                const uint32_t g = gather[--gathered];
                if (g < n) {
                    prim_out[slot++] = leaf_prims[g];
                } else {
                    if (gathered + 2 > gather_store.size()) {
                        gather_store.resize(2 * gather_store.size());
                        gather = gather_store.data();
                    }
                    gather[gathered++] = children[2 * size_t(g - n) + 1];
                    gather[gathered++] = children[2 * size_t(g - n)];
                }
            }
        }
    }

    const BinaryTree &tree_;
    const SubtreeChoices &choices_;
    BuildContext &ctx_;
    const Sink sink_;
    uint32_t *prim_out_;
    uint32_t n_;
};

/// The root's choice.
SubtreeChoice root_choice(const BinaryTree &tree, const FlattenRule &rule, const SubtreeChoices &choices) {
    const uint32_t n = tree.leaf_count();
    return tree.is_leaf(tree.root) ? rule.leaf(tree.boxes[tree.root]) : choices.get(tree.root - n);
}

/// The tree's SAH cost normalised by the root's area (0 when that area is 0).
double normalised_cost(const BinaryTree &tree, const FlattenRule &rule, const SubtreeChoice &root) {
    const double root_area = rule.area(tree.boxes[tree.root]);
    return root_area > 0.0 ? root.cost / root_area : 0.0;
}

} // namespace

double emit_bvh(const BinaryTree &tree, const FlattenRule &rule, SubtreeChoices &choices, BuildContext &ctx,
                Bvh &out) {
    const uint32_t n = tree.leaf_count();
    out.nodes.clear();
    out.prim_ids.clear();
    if (n == 0) return 0.0;
    const SubtreeChoice root = root_choice(tree, rule, choices);
    choices.release_costs(); // the layout reads only the counts
    out.nodes.resize(2 * size_t(root.leaves) - 1);
    out.prim_ids.resize(n);
    const NodeSink sink{out.nodes.data(), tree.boxes.data()};
    Emitter<NodeSink>(tree, choices, ctx, sink, out.prim_ids.data()).emit(tree.root, 0, 1, 0, 0);
    return normalised_cost(tree, rule, root);
}

double prepare_shape(const BinaryTree &tree, const FlattenRule &rule, SubtreeChoices &choices, Array<uint8_t> &shape,
                     Array<uint32_t> &prim_ids) {
    const uint32_t n = tree.leaf_count();
    shape.clear();
    prim_ids.clear();
    if (n == 0) return 0.0;
    const SubtreeChoice root = root_choice(tree, rule, choices);
    choices.release_costs();
    shape.resize(2 * size_t(root.leaves) - 1);
    prim_ids.resize(n);
    return normalised_cost(tree, rule, root);
}

ChosenTree chosen_view(const BinaryTree &tree, const SubtreeChoices &choices) {
    return ChosenTree{tree.boxes.data(), tree.children.data(), choices.counts().data(), tree.leaf_count(), tree.root};
}

} // namespace aacbvh
