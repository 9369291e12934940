// The 8-wide traversal layout (AACBVH_LAYOUT_WIDE8, the default): a tree
// collapsed from the finished binary Bvh (or, in a build of the default
// layout, from the builder's binary tree before any Bvh exists:
// bvh/chosen_tree.h; the same tree) whose nodes hold their eight
// children's boxes as a structure of arrays, tested against one ray at once
// (trace/wide8_traversal.h), and, for triangles stored in the BVH
// (AACBVH_TRIANGLES_COPIED, the default), leaves made of triangle packets:
// four triangles side by side, tested together.
//
// Collapsing: a wide node starts as its binary node's two children and
// repeatedly opens the child of largest surface area (the one a random ray
// is most likely to enter, the SAH's weight) until it has eight children or
// only leaves. With packets, a binary subtree of at most kPacketLeaf
// primitives becomes one leaf (one packet test instead of its inner nodes),
// and, by CollapseRule::Planned, the subtrees of fewer than 4,096 primitives
// below the top are collapsed by the SAH instead, their wide nodes and
// packet leaves chosen together (bvh/collapse_plan.h).
// Without packets the binary tree stays: aacbvh_bvh_get_nodes() reports it
// and refit runs on it, then copies its boxes here (through sources_). With
// packets the handle keeps only the binary tree's shape
// (bvh/compact_topology.h) and this tree refits from its own packets
// (refit_from_packets), which hold the triangles of the last build or refit.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>

#include "bvh/bvh.h"
#include "bvh/chosen_tree.h"
#include "bvh/packet_leaf_sweep.h"
#include "core/box.h"
#include "core/geometry.h"
#include "core/memory.h"
#include "core/scheduler.h"

namespace aacbvh {

/// How the collapse below the top of the tree chooses the wide nodes and
/// packet leaves of the subtrees its tasks take (subtrees of fewer than
/// 4,096 primitives, with packets only). Planned: by the SAH over each whole
/// subtree (bvh/collapse_plan.h): rays up to 9 % faster (diffuse rays 3-7 %
/// on most scenes) than LargestFirst, for AAC-HQ builds about 7 % longer
/// (docs/PERFORMANCE.md, row 263).
/// LargestFirst: the child of largest area opened first, as at the top,
/// over the packet leaves the flattening chose; the handle picks it for
/// AAC-Fast's builds, whose preset is its build time.
enum class CollapseRule { Planned, LargestFirst };

namespace testing {
/// The most bytes one task thread's plan held (SubtreePlan::held_bytes(),
/// counted in the build's memory meter) since a test last set it to 0: the
/// scratch a build's peak may include beside its arrays.
extern std::atomic<uint64_t> largest_plan_bytes;
} // namespace testing

/// One wide node, 256 bytes, 64-byte aligned (four cache lines):
///   bytes   0..191 box[6][8]: child k's lo x, hi x, lo y, hi y, lo z, hi z in
///                  box[0][k], box[1][k], ..., box[5][k];
///   bytes 192..223 child[8]: inner child: its node index; leaf child: its
///                  first packet (packet leaves) or first primitive slot;
///   bytes 224..255 count[8]: 0 for an inner child, else the leaf's packet
///                  count (packet leaves) or primitive count; an unused slot
///                  has count 0, child kEmptyChild and an empty box (lo +inf,
///                  hi -inf) that every ray misses.
struct alignas(64) Wide8Node {
    static constexpr uint32_t kEmptyChild = 0xFFFFFFFFu;
    float box[6][8];
    uint32_t child[8];
    uint32_t count[8];

    /// Child k's box (an unused slot's is empty: lo +inf, hi -inf).
    Box slot_box(int k) const {
        Box b;
        for (int a = 0; a < 3; ++a) {
            b.lo[a] = box[2 * a][k];
            b.hi[a] = box[2 * a + 1][k];
        }
        return b;
    }
};

static_assert(sizeof(Wide8Node) == 256, "Wide8Node must be 256 bytes");

/// Four triangles side by side: v[i][a][lane] is coordinate a of vertex i
/// of the lane's triangle; prim[lane] the caller's primitive index. A leaf
/// whose primitive count is not a multiple of four repeats its last
/// triangle in the spare lanes (the same hit twice changes nothing).
struct alignas(16) TrianglePacket {
    float v[3][3][4];
    uint32_t prim[4];
};

static_assert(sizeof(TrianglePacket) == 160, "TrianglePacket must be 160 bytes");

/// One lane's triangle of a packet, read where it lies: the vertex source of
/// the exact finish (trace/triangle_intersect.h, VertexPointers). Defined
/// here, outside the kernels' target regions, so that the shared templates
/// instantiated over it stay baseline code and inline it.
struct PacketLane {
    const TrianglePacket *packet;
    unsigned k;
    float at(int i, int a) const { return packet->v[i][a][k]; }
};

/// A packet test's single-precision edge functions per lane (see
/// finish_triangle_edges() in trace/triangle_intersect.h), for up to two
/// packets tested together (lanes 4-7: the second).
struct alignas(32) PacketEdges {
    float eu[8], ev[8], ew[8], mag[8];
};

class Wide8Bvh {
public:
    /// Subtrees of at most this many primitives become one packet leaf.
    static constexpr uint32_t kPacketLeaf = kMaxPacketLeaf;

    bool built() const { return built_; }
    bool has_packets() const { return packets_.size() > 0; }
    size_t node_count() const { return node_count_; }
    const Wide8Node *nodes() const { return nodes_.data(); }
    const TrianglePacket *packets() const { return packets_.data(); }

    /// Collapses `bvh` (which must outlive queries on this tree and keep its
    /// topology). With `triangles` (triangle geometry whose indices were
    /// checked by the build), leaves are packets copied from it; without,
    /// leaves are the binary leaves' slot ranges. Replaces the previous tree
    /// only on success; throws std::bad_alloc.
    void build(const Bvh &bvh, const Geometry *triangles, Scheduler &scheduler,
               CollapseRule rule = CollapseRule::Planned);
    /// The same tree with packets, collapsed straight from a builder's tree
    /// (bvh/chosen_tree.h) instead of its emitted binary nodes (which need
    /// not exist). The collapse writes the emitted layout's shape and
    /// primitive order into `order` (sized by prepare_shape(),
    /// build/flatten.h) as it goes; the packets are filled from that order.
    /// Calls `shape_done` once the tree's children, counts and leaf
    /// primitives are read no more (after the collapse, before the wide nodes
    /// are allocated) and `tree_done` once its boxes are read no more (before
    /// the packets are made). Keeps no sources (refit from the packets).
    /// Throws std::bad_alloc, keeping the previous tree.
    void build(const ChosenTree &tree, const Geometry &triangles, const EmittedOrder &order, Scheduler &scheduler,
               CollapseRule rule, const std::function<void()> &shape_done, const std::function<void()> &tree_done);
    /// After a refit of `bvh`: copies its boxes into the wide nodes and, with
    /// packets, the triangles' new vertices from `geometry`. No allocation.
    void refit(const Bvh &bvh, const Geometry &geometry, Scheduler &scheduler);
    void clear();

    /// For a handle that keeps the binary tree's shape only
    /// (bvh/compact_topology.h): the binary node behind each child slot
    /// (8 per node, kEmptyChild for unused slots), dropped when the handle
    /// keeps the shape only; refit() needs them, the calls below do not.
    const Array<uint32_t> &sources() const { return sources_; }
    void release_sources() { Array<uint32_t>().swap(sources_); }
    /// Refit of a tree with packets, from its own packets: re-reads their
    /// vertices from `geometry`, then boxes each leaf child by its packets'
    /// triangles and each inner child by its node's children, bottom-up.
    /// The boxes are the binary nodes' own (unions of the same triangles'
    /// boxes; only the sign of a zero may differ). No allocation.
    void refit_from_packets(const Geometry &geometry, Scheduler &scheduler);
    /// Where each primitive's triangle sits in the packets: out[prim] =
    /// 4 * packet + lane, for prim < primitive_count (out is resized; a
    /// primitive in no packet keeps an unspecified value).
    void index_packets(size_t primitive_count, Array<uint32_t> &out, Scheduler &scheduler) const;
    /// The box of the triangle at 4 * packet + lane (as Geometry::primitive_box
    /// makes it: vertex 0, 1, then 2).
    Box packet_triangle_box(uint32_t where) const {
        const TrianglePacket &p = packets_[where >> 2];
        const uint32_t lane = where & 3;
        Box b = Box::empty();
        for (int i = 0; i < 3; ++i) {
            const float v[3] = {p.v[i][0][lane], p.v[i][1][lane], p.v[i][2][lane]};
            b.extend(v);
        }
        return b;
    }

    /// The union of the root's children's boxes: lo x, y, z, 0, then hi x, y,
    /// z, 0 (16-byte aligned halves; empty, lo +inf and hi -inf, without
    /// nodes), for the traversals' check of a ray against the whole tree
    /// before their set-up (misses_root(), trace/wide8_kernel.inl).
    const float *bounds() const { return bounds_; }
    /// The packets' owners: 8 * node + slot of each packet's leaf child.
    const Array<uint32_t> &packet_owners() const { return packet_owner_; }

    size_t memory_bytes() const {
        return held_bytes(nodes_) + held_bytes(sources_) + held_bytes(packets_) + held_bytes(packet_owner_);
    }

private:
    /// Both builds: the collapse of `source` (wide8_bvh.cpp) from `root`.
    template <class Source>
    void build_from(const Source &source, typename Source::Handle root, const Geometry *triangles,
                    const uint32_t *prim_ids, Scheduler &scheduler, CollapseRule rule,
                    const std::function<void()> &shape_done, const std::function<void()> &source_done);
    /// Re-reads every packet's vertices from `geometry`.
    void refill_packets(const Geometry &geometry, Scheduler &scheduler);
    /// bounds_ from the root's boxes, after every change of them.
    void update_bounds();

    Array<Wide8Node> nodes_;
    /// For refit: the binary node behind each child slot (8 per wide node,
    /// kEmptyChild for unused slots). Kept apart: traversal never reads it.
    Array<uint32_t> sources_;
    Array<TrianglePacket> packets_;
    /// For refit_from_packets: each packet's leaf child slot (8 * node + k).
    Array<uint32_t> packet_owner_;
    alignas(16) float bounds_[8] = {INFINITY, INFINITY, INFINITY, 0.0f, -INFINITY, -INFINITY, -INFINITY, 0.0f};
    size_t node_count_ = 0;
    bool built_ = false;
};

} // namespace aacbvh
