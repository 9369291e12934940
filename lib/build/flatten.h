// Sub-tree flattening (Gu et al. 2013, "sub-tree flattening"): turns a
// builder's BinaryTree into the finished Bvh, collapsing each sub-tree of at
// most max_leaf_size primitives into one leaf where the SAH says that is
// cheaper. Every builder goes through the same rule, so trees are comparable.
#pragma once

#include <cstdint>
#include <utility>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "bvh/bvh.h"
#include "bvh/chosen_tree.h"
#include "bvh/packet_leaf_sweep.h"
#include "core/memory.h"

namespace aacbvh {

/// The cheapest form of one sub-tree: its SAH cost (unnormalised: Ct A per
/// inner node plus Ci A N per leaf), primitives below, and leaves it keeps
/// (1 = the whole sub-tree becomes one leaf). Where the 8-wide layout with
/// packets is made straight from the tree (FlattenRule::packets), also the
/// 8-wide layout's own choice (bvh/packet_leaf_sweep.h): whether the sub-tree
/// becomes one packet leaf, and its cost there.
struct SubtreeChoice {
    double cost;
    uint32_t prims;
    uint32_t leaves;
    float packet_cost = 0.0f;
    bool packet_leaf = false;
};

static_assert(SubtreeCounts::kSmall == kMaxPacketLeaf, "SubtreeCounts keeps the packet choices of packet-leaf sizes");

struct FlattenRule {
    uint32_t max_leaf_size;
    double traversal_cost;
    double intersection_cost;
    /// Whether the choices include the packet-leaf ones.
    bool packets = false;
    /// The scene's extent_scale_of() (core/box.h): costs are of areas on
    /// extents scaled by it, so that they fit the single-precision costs of
    /// SubtreeChoices in any scene (unscaled, a scene with coordinates near
    /// 1e20 had infinite costs and its leaves chosen by ties), and a scene
    /// scaled by a power of two gets the same choices.
    float extent_scale = 1.0f;

    /// A box's surface area as the costs weigh it (scaled, in double).
    double area(const Box &box) const {
        return box.area() * (double(extent_scale) * double(extent_scale));
    }
    /// Its half area for the packet-leaf choice (scaled, in single precision).
    float packet_area(const Box &box) const { return scaled_half_area(box, extent_scale); }

    SubtreeChoice leaf(const Box &box) const {
        SubtreeChoice c{intersection_cost * area(box), 1, 1};
        if (packets) {
            c.packet_cost = packet_leaf_cost(packet_area(box), 1);
            c.packet_leaf = true;
        }
        return c;
    }
    /// The cost of an inner node over `prims` primitives whose children cost
    /// l and r: one leaf's where that is cheaper (then `leaf` is set) and
    /// the primitives fit one, else the split's.
    double weigh(const Box &box, double l, double r, uint32_t prims, bool &leaf) const {
        const double area = this->area(box);
        const double split = traversal_cost * area + l + r;
        const double as_leaf = intersection_cost * area * prims;
        leaf = prims <= max_leaf_size && as_leaf <= split;
        return leaf ? as_leaf : split;
    }
    /// The cost of inner() below alone, from the children's costs and the
    /// primitives below.
    double inner_cost(const Box &box, double l, double r, uint32_t prims) const {
        bool leaf;
        return weigh(box, l, r, prims, leaf);
    }
    /// The decision for an inner node whose children chose l and r.
    SubtreeChoice inner(const Box &box, const SubtreeChoice &l, const SubtreeChoice &r) const {
        const uint32_t prims = l.prims + r.prims;
        bool leaf;
        const double cost = weigh(box, l.cost, r.cost, prims, leaf);
        SubtreeChoice c{cost, prims, leaf ? 1u : l.leaves + r.leaves};
        if (packets) {
            // A leaf of the binary layout is a packet leaf whatever its size;
            // above kMaxPacketLeaf primitives no cost is read
            // (choose_packet_leaf()), so no area is needed.
            if (prims > kMaxPacketLeaf) {
                c.packet_leaf = c.leaves == 1;
            } else if (c.leaves == 1) {
                c.packet_cost = packet_leaf_cost(packet_area(box), prims);
                c.packet_leaf = true;
            } else {
                c.packet_leaf =
                    choose_packet_leaf(packet_area(box), prims, l.packet_cost, r.packet_cost, c.packet_cost);
            }
        }
        return c;
    }
};

/// The builders' view of the choices of a tree's inner nodes (SubtreeChoices
/// below), indexed by id - leaf_count: pointers, passed by value; with
/// `packets`, the choices include the packet-leaf ones.
class ChoiceTable {
public:
    ChoiceTable(float *cost, SubtreeCounts *counts, bool packets) : cost_(cost), counts_(counts), packets_(packets) {}
    SubtreeChoice get(size_t k) const { return choice(cost_[k], counts_[k], packets_); }
    /// One node's choice from its cost and counts.
    static SubtreeChoice choice(float cost, const SubtreeCounts &c, bool packets) {
        SubtreeChoice out{cost, c.prims(), c.leaves()};
        if (packets) {
            out.packet_cost = c.packet_cost();
            out.packet_leaf = c.packet_leaf();
        }
        return out;
    }
    void set(size_t k, const SubtreeChoice &c) const {
        cost_[k] = float(c.cost);
        counts_[k] = SubtreeCounts(c.prims, c.leaves, c.packet_cost, c.packet_leaf);
    }
    uint32_t prims(size_t k) const { return counts_[k].prims(); }
    /// Asks for node k's counts ahead of a read (a walk over scattered ids).
    void prefetch_counts(size_t k) const { __builtin_prefetch(counts_ + k); }

private:
    float *cost_;
    SubtreeCounts *counts_;
    bool packets_;
};

/// Choices of a tree's inner nodes, indexed by id - leaf_count, as arrays:
/// the costs serve only while choices are made, so emit_bvh() and
/// prepare_shape() release them before they allocate the finished tree (4 bytes
/// per primitive off the build's peak, docs/PERFORMANCE.md row 123); the
/// counts, with the packet-leaf choices of small subtrees inside
/// (SubtreeCounts, bvh/chosen_tree.h; row 212), are what the layout reads.
/// The costs are kept in single precision (4 bytes a node off AAC's peak,
/// row 177); FlattenRule::inner() adds them in double. The rounding (2^-24
/// of a cost) can flip a near tie between one leaf and a sub-tree: of the
/// shared scenes, sibenik's trees changed, at the same SAH to six digits.
class SubtreeChoices {
public:
    /// With `packets`, the choices include the packet-leaf ones
    /// (FlattenRule::packets must say the same).
    void resize(size_t n, bool packets = false) {
        cost_.resize(n);
        counts_.resize(n);
        packets_ = packets;
    }
    SubtreeChoice get(size_t k) const { return ChoiceTable::choice(cost_[k], counts_[k], packets_); }
    void set(size_t k, const SubtreeChoice &c) { table().set(k, c); }
    double cost(size_t k) const { return cost_[k]; }
    uint32_t prims(size_t k) const { return counts_[k].prims(); }
    uint32_t leaves(size_t k) const { return counts_[k].leaves(); }
    void set_prims(size_t k, uint32_t prims) { counts_[k] = SubtreeCounts(prims, 0); }
    ChoiceTable table() { return ChoiceTable(cost_.data(), counts_.data(), packets_); }
    /// Frees the costs; get() and set() are then out of bounds.
    void release_costs() { Array<float>().swap(cost_); }
    void swap(SubtreeChoices &other) {
        cost_.swap(other.cost_);
        counts_.swap(other.counts_);
        std::swap(packets_, other.packets_);
    }
    /// The counts (the emits and the layouts read them through a pointer).
    const Array<SubtreeCounts> &counts() const { return counts_; }

private:
    Array<float> cost_;
    Array<SubtreeCounts> counts_;
    bool packets_ = false;
};

/// Bottom-up pass for builders that did not decide while building.
void choose_subtrees(const BinaryTree &tree, const FlattenRule &rule, BuildContext &ctx, SubtreeChoices &choices);

/// Top-down pass: depth-first layout with siblings adjacent. Returns the
/// tree's SAH cost normalised by the root's area (0 when that area is 0).
/// Releases the choices' costs first (SubtreeChoices::release_costs()).
double emit_bvh(const BinaryTree &tree, const FlattenRule &rule, SubtreeChoices &choices, BuildContext &ctx,
                Bvh &out);
/// emit_bvh() without the nodes and without the walk: `shape` sized for the
/// emitted layout's shape (one byte a node: a leaf's primitive count, 0 for
/// an inner node; every leaf must hold at most 255 primitives) and
/// `prim_ids` for its primitive indices, which the default layout's collapse
/// fills as it walks the tree (EmittedOrder, bvh/chosen_tree.h). Returns the
/// same cost.
double prepare_shape(const BinaryTree &tree, const FlattenRule &rule, SubtreeChoices &choices, Array<uint8_t> &shape,
                     Array<uint32_t> &prim_ids);
/// The tree and its choices as the layouts read them (both must outlive it).
ChosenTree chosen_view(const BinaryTree &tree, const SubtreeChoices &choices);

} // namespace aacbvh
