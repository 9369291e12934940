#include "optimize/treelet_optimizer.h"

#include <algorithm>
#include <vector>

#include "optimize/reinsertion.h"

namespace aacbvh {

namespace {

/// Leaves per treelet. Karras and Aila use 7 ((3^7 - 2^8 + 1) / 2 = 966
/// partitions weighed per treelet); 5 weighs 90, and on AAC-HQ's bunny one
/// pass of 5 gains 70% of what one pass of 7 gains in a quarter of the time
/// (docs/PERFORMANCE.md, entry 23).
constexpr int kTreeletLeaves = 5;
constexpr uint32_t kSubsets = 1u << kTreeletLeaves;

/// A treelet is replaced only when it gains more than this fraction of its
/// cost, so that rounding noise between equal trees never churns the topology.
constexpr double kMinGain = 1e-9;

class TreeletPass {
public:
    TreeletPass(BinaryTree &tree, const FlattenRule &rule, SubtreeChoices &choices, BuildContext &ctx)
        : t_(tree), rule_(rule), choices_(choices), ctx_(ctx), n_(tree.leaf_count()) {}

    /// One bottom-up pass over the whole tree; returns the treelets replaced.
    uint64_t run() { return t_.is_leaf(t_.root) ? 0 : pass_subtree(t_.root, 0); }

    /// Every inner box from its children and every choice from the
    /// children's, bottom-up (after reinsertion moved sub-trees); sub-trees
    /// run in parallel.
    void refresh() {
        if (!t_.is_leaf(t_.root)) refresh_subtree(t_.root, 0);
    }

private:
    static constexpr unsigned kParallelDepth = 24;

    void refresh_node(uint32_t id) {
        const uint32_t l = t_.left(id), r = t_.right(id);
        t_.boxes[id] = unite(t_.boxes[l], t_.boxes[r]);
        choices_.set(id - n_, rule_.inner(t_.boxes[id], choice(l), choice(r)));
    }

    void refresh_subtree(uint32_t root, unsigned depth) {
        // The primitive counts may be stale here: they only pick where to
        // fork, which does not change the result.
        if (depth < kParallelDepth && choices_.prims(root - n_) >= kParallelGrain) {
            const uint32_t l = t_.left(root), r = t_.right(root);
            ctx_.scheduler().fork_join(
                [&] {
                    if (!t_.is_leaf(l)) refresh_subtree(l, depth + 1);
                },
                [&] {
                    if (!t_.is_leaf(r)) refresh_subtree(r, depth + 1);
                });
            refresh_node(root);
            return;
        }
        struct Item {
            uint32_t id;
            bool expanded;
        };
        std::vector<Item> stack{{root, false}};
        while (!stack.empty()) {
            Item &it = stack.back();
            if (!it.expanded) {
                it.expanded = true;
                const uint32_t l = t_.left(it.id), r = t_.right(it.id);
                if (!t_.is_leaf(r)) stack.push_back({r, false});
                if (!t_.is_leaf(l)) stack.push_back({l, false});
                continue;
            }
            const uint32_t id = it.id;
            stack.pop_back();
            refresh_node(id);
        }
    }

    static constexpr uint32_t kParallelGrain = 1u << 13; ///< primitives below a node worth a task

    SubtreeChoice choice(uint32_t id) const {
        return t_.is_leaf(id) ? rule_.leaf(t_.boxes[id]) : choices_.get(id - n_);
    }

    /// The treelets replaced in the sub-tree, counted per task and summed
    /// up the recursion: one shared counter bumped by every replacement
    /// bounced its cache line between the threads (docs/PERFORMANCE.md,
    /// row 179).
    uint64_t pass_subtree(uint32_t root, unsigned depth) {
        if (depth < kParallelDepth && choices_.prims(root - n_) >= kParallelGrain) {
            const uint32_t l = t_.left(root), r = t_.right(root);
            uint64_t left_changed = 0, right_changed = 0;
            ctx_.scheduler().fork_join(
                [&] {
                    if (!t_.is_leaf(l)) left_changed = pass_subtree(l, depth + 1);
                },
                [&] {
                    if (!t_.is_leaf(r)) right_changed = pass_subtree(r, depth + 1);
                });
            const uint64_t changed = left_changed + right_changed + (restructure(root) ? 1 : 0);
            ctx_.poll();
            return changed;
        }
        // Post-order with an explicit stack: trees may be as deep as their leaf count.
        struct Item {
            uint32_t id;
            bool expanded;
        };
        std::vector<Item> stack{{root, false}};
        uint32_t done = 0;
        uint64_t changed = 0;
        while (!stack.empty()) {
            Item &it = stack.back();
            if (!it.expanded) {
                it.expanded = true;
                const uint32_t l = t_.left(it.id), r = t_.right(it.id);
                if (!t_.is_leaf(r)) stack.push_back({r, false});
                if (!t_.is_leaf(l)) stack.push_back({l, false});
                continue;
            }
            const uint32_t id = it.id;
            stack.pop_back();
            changed += restructure(id) ? 1 : 0;
            if ((++done & 0x3FF) == 0) ctx_.poll();
        }
        return changed;
    }

    /// Grows the treelet at `root`, finds its cheapest topology and installs
    /// it if that lowers the root's cost (then returns true). Children of
    /// the treelet's leaves, and the root's id (its parent points at it),
    /// stay as they were.
    bool restructure(uint32_t root) {
        // The children were visited first and may have changed: the root's
        // choice is made again from theirs, before anything else reads it.
        choices_.set(root - n_, rule_.inner(t_.boxes[root], choice(t_.left(root)), choice(t_.right(root))));
        uint32_t leaf[kTreeletLeaves];
        double leaf_area[kTreeletLeaves];
        uint32_t inner[kTreeletLeaves - 1];
        int nl = 2, ni = 1;
        inner[0] = root;
        leaf[0] = t_.left(root);
        leaf[1] = t_.right(root);
        leaf_area[0] = t_.boxes[leaf[0]].area();
        leaf_area[1] = t_.boxes[leaf[1]].area();
        // Open the largest treelet leaf that is an inner node (Karras and
        // Aila: large nodes are where restructuring pays); the first on ties.
        while (nl < kTreeletLeaves) {
            int pick = -1;
            for (int i = 0; i < nl; ++i)
                if (!t_.is_leaf(leaf[i]) && (pick < 0 || leaf_area[i] > leaf_area[pick])) pick = i;
            if (pick < 0) break;
            const uint32_t id = leaf[pick];
            inner[ni++] = id;
            leaf[pick] = t_.left(id);
            leaf[nl] = t_.right(id);
            leaf_area[pick] = t_.boxes[leaf[pick]].area();
            leaf_area[nl] = t_.boxes[leaf[nl]].area();
            ++nl;
        }
        if (nl < 3) return false; // two leaves have one topology

        // cost[S]: the cost of the cheapest sub-tree over the treelet leaves
        // in S, as flattening decides it (FlattenRule::inner_cost(): the
        // whole choice, with the packet-leaf one, is made only for the
        // nodes installed, docs/PERFORMANCE.md row 181); prims[S]: the
        // primitives below; side[S]: the part holding S's lowest leaf.
        Box box[kSubsets];
        double cost[kSubsets];
        uint32_t prims[kSubsets];
        uint8_t side[kSubsets];
        SubtreeChoice leaf_choice[kTreeletLeaves];
        const uint32_t full = (1u << nl) - 1;
        for (int i = 0; i < nl; ++i) {
            box[1u << i] = t_.boxes[leaf[i]];
            leaf_choice[i] = choice(leaf[i]);
            cost[1u << i] = leaf_choice[i].cost;
            prims[1u << i] = leaf_choice[i].prims;
        }
        for (uint32_t s = 3; s <= full; ++s) {
            const uint32_t low = s & (0u - s);
            if (s == low) continue;
            const uint32_t rest = s ^ low;
            box[s] = unite(box[rest], box[low]);
            prims[s] = prims[rest] + prims[low];
            double split_cost = cost[rest] + cost[low];
            uint32_t split_side = low;
            // The other partitions: low plus a non-empty proper part of rest.
            for (uint32_t sub = (rest - 1) & rest; sub != 0; sub = (sub - 1) & rest) {
                const uint32_t part = low | sub;
                const double c = cost[part] + cost[s ^ part];
                if (c < split_cost) {
                    split_cost = c;
                    split_side = part;
                }
            }
            cost[s] = rule_.inner_cost(box[s], cost[split_side], cost[s ^ split_side], prims[s]);
            side[s] = uint8_t(split_side);
        }
        const SubtreeChoice old = choices_.get(root - n_);
        if (!(cost[full] < old.cost * (1.0 - kMinGain))) return false;

        // Install: the treelet's inner nodes are reused, the root first;
        // pre-order ids and children, then boxes and choices bottom-up.
        int next_inner = 1;
        struct Frame {
            uint32_t set, id;
        };
        Frame stack[kTreeletLeaves];
        Frame order[kTreeletLeaves - 1];
        int top = 0, no = 0;
        stack[top++] = {full, root};
        while (top > 0) {
            const Frame f = stack[--top];
            order[no++] = f;
            const uint32_t parts[2] = {side[f.set], f.set ^ side[f.set]};
            uint32_t child[2];
            for (int c = 0; c < 2; ++c) {
                if ((parts[c] & (parts[c] - 1)) == 0) {
                    child[c] = leaf[__builtin_ctz(parts[c])];
                } else {
                    child[c] = inner[next_inner++];
                    stack[top++] = {parts[c], child[c]};
                }
            }
            t_.set_children(f.id, child[0], child[1]);
        }
        // The installed nodes' whole choices, children first, from their
        // parts' (in double, as the costs above were summed).
        SubtreeChoice made[kSubsets];
        auto part_choice = [&](uint32_t part) -> const SubtreeChoice & {
            return (part & (part - 1)) == 0 ? leaf_choice[__builtin_ctz(part)] : made[part];
        };
        for (int k = no; k-- > 0;) {
            const uint32_t set = order[k].set;
            made[set] = rule_.inner(box[set], part_choice(side[set]), part_choice(set ^ side[set]));
            t_.boxes[order[k].id] = box[set];
            choices_.set(order[k].id - n_, made[set]);
        }
        return true;
    }

    BinaryTree &t_;
    const FlattenRule &rule_;
    SubtreeChoices &choices_;
    BuildContext &ctx_;
    const uint32_t n_;
};

} // namespace

OptimizeReport optimize_tree(BinaryTree &tree, const FlattenRule &rule, SubtreeChoices &choices, uint32_t passes,
                             BuildContext &ctx, double from, double to) {
    OptimizeReport report;
    if (tree.leaf_count() < 3) return report;
    TreeletPass pass(tree, rule, choices, ctx);
    Reinsertion reinsertion(tree, choices, ctx);
    const uint32_t n = tree.leaf_count();
    for (uint32_t p = 0; p < passes; ++p) {
        ctx.report(from + (to - from) * p / passes);
        // Reinsertion first (far moves), then treelets (the best local
        // shape, leaves included). A round whose moves together raise the
        // cost (each was weighed alone) is undone.
        // Undone by putting the moved children back and recomputing the
        // boxes and choices, which are functions of the children: the same
        // bits as before the round, without a copy of the tree
        // (docs/PERFORMANCE.md, row 178).
        const double before = choices.cost(tree.root - n);
        uint64_t changed = reinsertion.round();
        if (changed) {
            pass.refresh();
            if (!(choices.cost(tree.root - n) < before)) {
                reinsertion.undo();
                pass.refresh();
                changed = 0;
            }
        }
        report.moves += changed;
        changed += pass.run();
        ++report.passes_run;
        report.treelets_changed += changed;
        if (changed == 0) break; // the next pass would see the same tree
    }
    ctx.report(to);
    return report;
}

void unflatten(const Node *nodes, size_t node_count, const uint32_t *prim_ids, size_t n, const Geometry &geometry,
               BuildContext &ctx, BinaryTree &out) {
    if (n == 0) {
        out = BinaryTree();
        return;
    }
    out.resize(uint32_t(n));
    Scheduler &sched = ctx.scheduler();
    sched.parallel_for(0, n, size_t(1) << 13, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            out.prim_ids[i] = prim_ids[i];
            out.boxes[i] = geometry.primitive_box(prim_ids[i]);
        }
    });
    ctx.check_cancelled();
    // Children sit after their parent in the Bvh: a reverse sweep meets both
    // children of a node before it. id_of maps Bvh nodes to tree ids.
    Array<uint32_t> id_of(node_count);
    uint32_t next = uint32_t(n);
    std::vector<uint32_t> stack;
    for (size_t j = node_count; j-- > 0;) {
        const Node &node = nodes[j];
        if (!node.is_leaf()) {
            const uint32_t id = next++, l = id_of[node.first], r = id_of[node.first + 1];
            out.set_children(id, l, r);
            out.boxes[id] = unite(out.boxes[l], out.boxes[r]);
            id_of[j] = id;
            continue;
        }
        // A balanced sub-tree over slots [first, first + count), halving in
        // slot order; built bottom-up by merging neighbours level by level.
        stack.clear();
        for (uint32_t k = 0; k < node.count; ++k) stack.push_back(node.first + k);
        while (stack.size() > 1) {
            size_t w = 0;
            for (size_t k = 0; k + 1 < stack.size(); k += 2) {
                const uint32_t id = next++;
                out.set_children(id, stack[k], stack[k + 1]);
                out.boxes[id] = unite(out.boxes[stack[k]], out.boxes[stack[k + 1]]);
                stack[w++] = id;
            }
            if (stack.size() % 2) stack[w++] = stack.back();
            stack.resize(w);
        }
        id_of[j] = stack[0];
        if ((j & 0xFFFF) == 0) ctx.poll();
    }
    out.root = id_of[0];
}

} // namespace aacbvh
