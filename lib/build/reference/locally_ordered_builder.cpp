// Exact agglomerative clustering, the quality reference of the AAC paper:
// Walter, Bala, Kulkarni, Pingali, "Fast Agglomerative Clustering for
// Rendering", IEEE Symposium on Interactive Ray Tracing 2008, locally-ordered
// variant. Distance d(A, B) = surface area of the union of the two boxes.
//
// The locally-ordered idea is run as a nearest-neighbour chain: follow nearest
// neighbours from a cluster until two clusters are each other's nearest
// neighbour, merge them, and continue from the rest of the chain. d is
// reducible (the union with A u B contains the union with A, so d(A u B, C) >=
// d(A, C)), hence mutual nearest neighbours stay mutual until merged, and the
// result is exactly the tree of naive greedy clustering (always merge the
// globally closest pair) whenever distances have no ties.
//
// Nearest neighbours come from a static, implicit binary tree over "slots" in
// Morton order, whose bounds (CornerBounds) are refitted as clusters merge: a
// merged cluster takes the lower slot of its two parts and the other slot
// becomes empty. A query walks it depth first, nearer child first, and skips
// a subtree whose distance bound is no smaller than the best distance found.
// Each merge costs O(log n) refitting and a few queries, each near O(log n)
// on typical scenes (figures: docs/PERFORMANCE.md, "Figures from code comments").
//
// Distances are computed on extents scaled by 1 / the scene's largest extent,
// as AAC does (distance_scale()), so scenes at 1e30 or 1e-30 keep finite,
// distinct distances. Should a distance still overflow (a scene wider than
// FLT_MAX), it saturates at FLT_MAX (core/box.h), the search takes any cluster
// over none and the chain's "prev wins ties" rule still ends every chain in a
// merge.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <vector>

#include "build/morton.h"
#include "build/reference/reference_builders.h"
#include "core/memory.h"

namespace aacbvh {
namespace {

constexpr uint32_t kNone = UINT32_MAX;

/// What the search tree keeps per node to bound distances: the largest lower
/// corner and the smallest upper corner of the clusters below (each cluster a
/// point (lo, hi) in 6D). Every cluster C below has C.lo <= lo_max and
/// C.hi >= hi_min, so on each axis the union of a query with C is at least as
/// long as the union with the "box" (lo_max, hi_min), an inverted box in
/// general. This beats the plain bounding box, which cannot tell a subtree of
/// large clusters from one of small clusters inside the query.
struct CornerBounds {
    float lo_max[3];
    float hi_min[3];

    /// Covers no cluster: every bound computed from it is infinite.
    static CornerBounds none() { return CornerBounds{{-FLT_MAX, -FLT_MAX, -FLT_MAX}, {FLT_MAX, FLT_MAX, FLT_MAX}}; }
    static CornerBounds of(const Box &b) {
        return CornerBounds{{b.lo[0], b.lo[1], b.lo[2]}, {b.hi[0], b.hi[1], b.hi[2]}};
    }
    static CornerBounds join(const CornerBounds &a, const CornerBounds &b) {
        CornerBounds r;
        for (int k = 0; k < 3; ++k) {
            r.lo_max[k] = std::max(a.lo_max[k], b.lo_max[k]);
            r.hi_min[k] = std::min(a.hi_min[k], b.hi_min[k]);
        }
        return r;
    }
    /// Lower bound of d(query, C) over the clusters C below. Same float
    /// operations as scaled_union_half_area, so it never exceeds a true
    /// distance (and equals it for a single cluster).
    float distance_bound(const Box &q, float scale) const {
        const Box corners{{lo_max[0], lo_max[1], lo_max[2]}, {hi_min[0], hi_min[1], hi_min[2]}};
        return scaled_union_half_area(q, corners, scale);
    }
};

class LocallyOrderedBuilder {
public:
    LocallyOrderedBuilder(const BuildInput &input, BuildContext &ctx, BinaryTree &out)
        : input_(input), ctx_(ctx), out_(out), n_(uint32_t(input.size())) {}

    void build() {
        out_.resize(n_);
        Array<uint64_t> codes;
        Array<uint32_t> order;
        sort_by_morton_code(input_, ctx_.scheduler(), codes, order);
        gather_leaves(input_, order.data(), ctx_.scheduler(), out_);
        out_.root = 0;
        if (n_ == 1) return;
        scale_ = distance_scale(input_.bounds);

        leaf_base_ = 1;
        while (leaf_base_ < n_) leaf_base_ *= 2;
        tree_.assign(2 * size_t(leaf_base_), CornerBounds::none());
        slot_node_.assign(leaf_base_, kNone);
        node_slot_.assign(2 * size_t(n_), kNone);
        for (uint32_t i = 0; i < n_; ++i) {
            tree_[leaf_base_ + i] = CornerBounds::of(out_.boxes[i]);
            slot_node_[i] = i;
            node_slot_[i] = i;
        }
        for (uint32_t i = leaf_base_ - 1; i >= 1; --i) tree_[i] = CornerBounds::join(tree_[2 * i], tree_[2 * i + 1]);

        std::vector<uint32_t> chain;
        chain.reserve(n_);
        chain.push_back(0);
        uint32_t next_id = n_;
        // Searches are O(log n) on typical scenes but may visit every slot on
        // degenerate ones: polls follow the nodes visited.
        PollingCounter work(ctx_);
        while (next_id < 2 * n_ - 1) {
            const uint32_t x = chain.back();
            const uint32_t prev = chain.size() >= 2 ? chain[chain.size() - 2] : kNone;
            uint32_t visited = 0;
            const uint32_t y = nearest(x, prev, visited);
            testing::count_distances(visited);
            work.add(visited + 1);
            if (y != prev) {
                chain.push_back(y);
                continue;
            }
            chain.resize(chain.size() - 2);
            merge(next_id, prev, x);
            if (chain.empty()) chain.push_back(next_id);
            ++next_id;
        }
        out_.root = next_id - 1;
    }

private:
    /// The nearest active cluster to x (never kNone: at least one other is
    /// active). `prev` (the cluster before x in the chain, or kNone) wins
    /// ties, which keeps the chain's distances strictly decreasing; other ties
    /// go to whichever the walk meets first. Until a candidate is found nothing
    /// is pruned, so infinite distances still yield one.
    uint32_t nearest(uint32_t x, uint32_t prev, uint32_t &visited) const {
        const Box q = out_.boxes[x];
        float best = prev == kNone ? INFINITY : scaled_union_half_area(q, out_.boxes[prev], scale_);
        uint32_t best_id = prev;
        const auto beats_best = [&](float d) { return best_id == kNone || d < best; };
        struct Entry {
            uint32_t node;
            float bound;
        };
        Entry stack[2 * 33];
        int top = 0;
        stack[top++] = Entry{1, 0.0f};
        while (top > 0) {
            const Entry e = stack[--top];
            ++visited;
            if (!beats_best(e.bound)) continue;
            if (e.node >= leaf_base_) {
                const uint32_t id = slot_node_[e.node - leaf_base_];
                if (id == x || id == kNone) continue;
                const float d = scaled_union_half_area(q, out_.boxes[id], scale_);
                if (beats_best(d)) {
                    best = d;
                    best_id = id;
                }
                continue;
            }
            const uint32_t l = 2 * e.node, r = l + 1;
            const float bl = tree_[l].distance_bound(q, scale_);
            const float br = tree_[r].distance_bound(q, scale_);
            if (bl <= br) {
                if (beats_best(br)) stack[top++] = Entry{r, br};
                if (beats_best(bl)) stack[top++] = Entry{l, bl};
            } else {
                if (beats_best(bl)) stack[top++] = Entry{l, bl};
                if (beats_best(br)) stack[top++] = Entry{r, br};
            }
        }
        return best_id;
    }

    /// Makes inner node `id` over clusters a and b and updates the slot tree.
    void merge(uint32_t id, uint32_t a, uint32_t b) {
        out_.set_children(id, a, b);
        out_.boxes[id] = unite(out_.boxes[a], out_.boxes[b]);
        const uint32_t keep = std::min(node_slot_[a], node_slot_[b]);
        const uint32_t drop = std::max(node_slot_[a], node_slot_[b]);
        slot_node_[keep] = id;
        slot_node_[drop] = kNone;
        node_slot_[id] = keep;
        tree_[leaf_base_ + keep] = CornerBounds::of(out_.boxes[id]);
        tree_[leaf_base_ + drop] = CornerBounds::none();
        refit(leaf_base_ + drop);
        refit(leaf_base_ + keep);
    }

    void refit(uint32_t node) {
        for (node >>= 1; node >= 1; node >>= 1) tree_[node] = CornerBounds::join(tree_[2 * node], tree_[2 * node + 1]);
    }

    const BuildInput &input_;
    BuildContext &ctx_;
    BinaryTree &out_;
    uint32_t n_;
    float scale_ = 1.0f;              ///< distance_scale() of the scene
    uint32_t leaf_base_ = 1;          ///< slots are tree nodes [leaf_base_, 2 leaf_base_)
    Array<CornerBounds> tree_;  ///< implicit tree: node i has children 2i, 2i+1
    Array<uint32_t> slot_node_; ///< cluster (node id) in each slot, or kNone
    Array<uint32_t> node_slot_; ///< slot of each active cluster
};

} // namespace

void build_locally_ordered(const BuildInput &input, BuildContext &ctx, BinaryTree &out) {
    LocallyOrderedBuilder(input, ctx, out).build();
}

} // namespace aacbvh
