// What an aacbvh_bvh handle holds: parameters, a view of the caller's
// geometry, and the finished tree; builds into temporaries and swaps them in
// only on success, so a failed build keeps the previous tree.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>

#include "aacbvh/aacbvh.h"
#include "build/flatten.h"
#include "bvh/bvh.h"
#include "bvh/bvh_stats.h"
#include "bvh/compact_topology.h"
#include "bvh/wide_bvh.h"
#include "bvh/wide8_bvh.h"
#include "core/block_cache.h"
#include "core/geometry.h"
#include "core/scheduler.h"
#include "params.h"

namespace aacbvh {

namespace testing {
/// Whether builds may make the default layout straight from the builder's
/// tree (BvhObject::straight_to_compact(); on by default). Tests turn it off
/// to compare with the layout made from the emitted binary nodes.
extern std::atomic<bool> straight_layouts;
} // namespace testing

class BvhObject {
public:
    explicit BvhObject(Scheduler &scheduler) : scheduler_(scheduler) {}

    /// Read freely; changed through set_param_int/float, which apply side
    /// effects (setting AACBVH_PARAM_KEEP_BUILD_MEMORY to 0 frees the kept blocks).
    Params params;
    void set_param_int(int32_t key, int64_t value);
    void set_param_float(int32_t key, double value) {
        require_idle();
        params.set_float(key, value);
    }
    /// Bytes kept for the next build (AACBVH_PARAM_KEEP_BUILD_MEMORY).
    size_t kept_build_bytes() const { return kept_blocks_ ? kept_blocks_->bytes() : 0; }

    /// Argument checks only; contents are checked by build(). Throws Error.
    void set_triangles(const float *vertices, size_t vertex_count, size_t vertex_stride, const uint32_t *indices,
                       size_t triangle_count);
    void set_boxes(const float *boxes, size_t box_count, size_t stride);
    void set_progress(aacbvh_progress_fn fn, void *user) { progress_ = fn; progress_user_ = user; }

    void build();
    void refit();
    /// Treelet restructuring of the current tree (optimize/treelet_optimizer.h),
    /// then the layout and triangle copy made again from it. Needs a valid tree;
    /// leaves the handle as it was on any throw (cancel, out of memory).
    void optimize(uint32_t passes);
    static constexpr uint32_t kMaxOptimizePasses = AACBVH_MAX_OPTIMIZE_PASSES;

    /// Throws Error(AACBVH_ERROR_INVALID_OPERATION) unless a valid tree exists.
    void require_tree() const;
    /// The binary tree as aacbvh_bvh_get_nodes reports it: the nodes kept,
    /// or, where only their shape is kept (compact()), nodes made again with
    /// the boxes of the last build or refit. f(const Bvh &) runs on it.
    template <class F> void with_tree(F &&f) const {
        if (!compact()) {
            f(bvh_);
            return;
        }
        Bvh tree;
        remake_tree(tree);
        f(tree);
    }
    /// Nodes [first, first + count) of that tree into `out` (32-byte
    /// aacbvh_node / Node records; the range is the caller's to check). Where the nodes are made again, a partial
    /// range keeps them, counted in memory_bytes, until the tree next
    /// changes: a caller reading node by node pays for one making, not one
    /// per node; a whole-tree copy keeps nothing.
    void copy_nodes(size_t first, size_t count, void *out) const;
    /// A copy of that tree (for tests).
    Bvh binary_tree() const {
        Bvh out;
        with_tree([&](const Bvh &t) { out = Bvh{Array<Node>(t.nodes), Array<uint32_t>(t.prim_ids)}; });
        return out;
    }
    /// The binary tree's node count (kept or made again alike).
    size_t node_count() const { return compact() ? topology_.node_count() : bvh_.nodes.size(); }
    /// Leaf slots -> the caller's primitive indices (kept in every mode).
    const Array<uint32_t> &primitive_indices() const { return bvh_.prim_ids; }
    /// Whether the handle keeps the binary tree's shape only
    /// (bvh/compact_topology.h): the default 8-wide layout with packets.
    bool compact() const { return !topology_.empty(); }
    const Geometry &geometry() const { return geometry_; }
    /// The layouts as they are (for tests).
    const Wide8Bvh &wide8() const { return wide8_; }
    /// The 8-wide collapse's rule (bvh/wide8_bvh.h): by the SAH, but for
    /// AAC-Fast, whose preset is its build time.
    CollapseRule collapse_rule() const;
    const CompactTopology &topology() const { return topology_; }
    Scheduler &scheduler() const { return scheduler_; }

    void stats(aacbvh_stats &out) const;
    /// Leaf count, depth and SAH area sums, measured once per build and kept
    /// current by refit, so that stats are O(1) in a refit loop.
    TreeFigures figures() const;
    void intersect(const aacbvh_ray *rays, aacbvh_hit *hits, size_t count) const;
    void occluded(const aacbvh_ray *rays, uint8_t *out, size_t count) const;

private:
    void replace_geometry(const Geometry &g);
    /// Writes nine floats per leaf slot: the vertices of triangle
    /// bvh.prim_ids[i] at out[9 i] (out holds 9 * bvh.prim_ids.size()).
    /// Geometry must be triangles with valid indices.
    void copy_triangles(const Bvh &bvh, float *out) const;
    /// Whether the last build or refit keeps triangles in leaf order as
    /// triangles_ (copied storage, a layout other than WIDE8, whose packets
    /// hold them instead).
    bool flat_copy_wanted() const;
    bool packets_wanted() const;
    /// What queries traverse besides the binary tree, made from a new tree
    /// (by build and optimize) before the handle changes, then installed.
    struct Layouts {
        WideBvh wide;
        Wide8Bvh wide8;
        Array<float> triangles;
        /// Set when the binary nodes need not stay (the 8-wide layout with
        /// packets, a tree in the emitted layout): install() drops them.
        CompactTopology topology;
    };
    void make_layouts(const Bvh &tree, Layouts &out) const;
    /// Whether a build of `primitives` makes the default layout (the 8-wide
    /// tree with packets, the binary tree's shape kept) straight from the
    /// builder's tree, without the binary nodes (docs/PERFORMANCE.md, 148).
    bool straight_to_compact(size_t primitives) const;
    /// That: result gets the primitive indices only (no nodes); the tree and
    /// the choices are freed as soon as they are read no more.
    void make_compact_layouts(BinaryTree &tree, const FlattenRule &rule, SubtreeChoices &choices,
                              Bvh &result, Layouts &out) const;
    void install(Layouts &layouts) noexcept;
    /// Into `out`: the binary nodes from the kept shape, with boxes from the
    /// packets' vertices (those of the last build or refit), united as
    /// refit_tree() unites them; and the primitive indices. compact() only.
    void remake_tree(Bvh &out) const;
    void remake_nodes(Array<Node> &out) const;
    /// A leaf's box from the packets' triangles: slots [first, first + count),
    /// `where` from Wide8Bvh::index_packets().
    Box packet_leaf_box(const uint32_t *where, uint32_t first, uint32_t count) const;
    /// Frees the nodes copy_nodes() kept (the tree changed).
    void drop_made_nodes() noexcept;
    /// compact() only: leaf count, depth and areas by the shape's walk, with
    /// the packets' vertices.
    TreeFigures compact_figures() const;
    /// compact() only: back to keeping the binary nodes (and no 8-wide tree,
    /// which needs them to be made again).
    void expand();
    /// refit() of a compact() handle that keeps its layout.
    void refit_compact();
    /// The smallest index of a primitive of the tree that primitive_problem()
    /// refuses (refit's check), SIZE_MAX when there is none.
    size_t first_problem_in_tree() const;
    /// The copy the traversals read, or NULL to read the caller's buffers.
    const float *triangle_copy() const { return triangles_.empty() ? nullptr : triangles_.data(); }

    Scheduler &scheduler_;
    /// AACBVH_PARAM_KEEP_BUILD_MEMORY's blocks, made when the setting is first
    /// used (handles without it pay nothing); first, so it outlives the arrays below.
    std::unique_ptr<BlockCache> kept_blocks_;
    Geometry geometry_;
    bool geometry_set_ = false;
    Bvh bvh_; ///< its nodes are empty while compact(): topology_ holds their shape
    CompactTopology topology_;
    mutable std::mutex made_nodes_mutex_;
    mutable Array<Node> made_nodes_; ///< see copy_nodes(); empty unless compact()
    WideBvh wide_; ///< built when params.layout was AACBVH_LAYOUT_WIDE4 at the last build or refit
    /// Built when params.layout was AACBVH_LAYOUT_WIDE8 at the last build or
    /// refit; with copied triangles its packets are the copy (triangles_ stays empty).
    Wide8Bvh wide8_;
    /// Triangles in leaf order (9 floats per slot), kept when
    /// params.triangle_storage was AACBVH_TRIANGLES_COPIED at the last build or refit.
    Array<float> triangles_;
    bool valid_ = false;        ///< bvh_ matches geometry_ (built or refitted since the last set)
    bool has_topology_ = false; ///< bvh_ holds a tree (possibly stale)
    GeometryKind built_kind_ = GeometryKind::None;
    size_t built_primitive_count_ = 0; ///< geometry's primitive count at the last build
    uint64_t invalid_count_ = 0;
    uint64_t build_peak_bytes_ = 0;
    double build_seconds_ = 0.0;
    mutable std::mutex figures_mutex_; // stats may be read from several threads
    mutable bool figures_known_ = false;
    mutable TreeFigures figures_;
    mutable bool built_areas_known_ = false; ///< set by the first refit after a build
    mutable AreaSums built_areas_;           ///< the built tree's, for built_sah_cost
    aacbvh_progress_fn progress_ = nullptr;
    void *progress_user_ = nullptr;
    /// A build is running (so a call from its own progress callback that would
    /// change the handle is refused: require_idle()).
    bool building_ = false;
    void require_idle() const;
    class KeptMemory;
};

} // namespace aacbvh
