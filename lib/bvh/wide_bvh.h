// The 4-wide traversal layout (AACBVH_LAYOUT_WIDE4): a tree collapsed from the
// finished binary Bvh, whose nodes hold their four children's boxes as a
// structure of arrays so that its traversal (trace/wide_traversal.h) tests one
// ray against all four at once (SSE on x86-64, a scalar loop elsewhere). This
// file makes the tree and refits it. Leaves stay the binary leaves:
// they point into the same primitive index array, and triangles are read
// from the caller's buffers or from the BVH's copy (AACBVH_TRIANGLES_COPIED).
//
// Collapsing (as for the BVH4 of Wald, Benthin, Boulos, "Getting Rid of
// Packets", RT 2008, and Embree): a wide node starts as its binary node's two
// children and repeatedly opens the inner child of largest surface area until
// it has four children or only leaves. The wide tree is extra memory; the
// binary nodes stay what aacbvh_bvh_get_nodes() reports.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "aacbvh/aacbvh.h"
#include "bvh/bvh.h"
#include "core/memory.h"
#include "core/scheduler.h"

namespace aacbvh {

/// One wide node, 128 bytes, 64-byte aligned (two cache lines):
///   bytes   0..95  box[6][4]: child k's lo x, hi x, lo y, hi y, lo z, hi z in
///                  box[0][k], box[1][k], ..., box[5][k];
///   bytes  96..111 child[4]: inner child: its wide node index; leaf child: its
///                  first slot in the primitive index array;
///   bytes 112..127 count[4]: 0 for an inner child, else the leaf's primitive
///                  count; an unused slot has count 0, child kEmptyChild and
///                  an empty box (lo +inf, hi -inf) that every ray misses.
struct alignas(64) WideNode {
    static constexpr uint32_t kEmptyChild = 0xFFFFFFFFu;
    float box[6][4];
    uint32_t child[4];
    uint32_t count[4];
};

static_assert(sizeof(WideNode) == 128, "WideNode must be 128 bytes");
static_assert(alignof(WideNode) == 64, "WideNode must be 64-byte aligned");

class WideBvh {
public:
    /// Whether build() has made a tree (possibly of zero nodes, for an empty scene).
    bool built() const { return built_; }
    size_t node_count() const { return node_count_; }
    const WideNode *nodes() const { return nodes_.data(); }

    /// Collapses `bvh` (which must outlive queries on this tree and keep its
    /// topology). Replaces the previous tree only on success; throws
    /// std::bad_alloc.
    void build(const Bvh &bvh, Scheduler &scheduler);
    /// Copies the boxes of `bvh` (same topology as at build(), refitted) into
    /// the wide nodes. Linear time, no allocation.
    void refit(const Bvh &bvh, Scheduler &scheduler);
    /// Frees everything; built() becomes false.
    void clear();

    size_t memory_bytes() const {
        return held_bytes(nodes_) + held_bytes(sources_);
    }

private:
    /// Build arrays (core/memory.h): counted in the build's peak, huge pages,
    /// reused with AACBVH_PARAM_KEEP_BUILD_MEMORY.
    Array<WideNode> nodes_;
    /// For refit: the binary node behind each child slot (4 per wide node,
    /// kEmptyChild for unused slots). Kept apart: traversal never reads it.
    Array<uint32_t> sources_;
    size_t node_count_ = 0;
    bool built_ = false;
};

} // namespace aacbvh
