// Ray cost, the AAC paper's measure of tree quality (Gu et al., HPG 2013, sec. 5):
// trace rays through a binary BVH and count, per ray, the traversal steps (nodes
// whose box is tested) plus the triangle intersection tests. The tracer works on
// the public aacbvh_node layout, so a tree from any builder (ours, or Embree's
// rtcBuildBVH converted to that layout) is measured by the same code.
//
// Counting rules (fixed, so numbers compare across builders):
//   - the root's box is tested first: 1 step; a miss ends the ray;
//   - at an inner node both children's boxes are tested: 2 steps; the children
//     hit are visited nearest entry distance first, the far one is pushed;
//   - a popped node whose entry distance lies beyond the closest hit found so far
//     is dropped without further counting (its box was counted when tested);
//   - at a leaf every primitive slot is one intersection test;
//   - an any-hit (shadow) ray stops at its first hit.
#pragma once

#include <aacbvh/aacbvh.h>

#include <cstdint>
#include <string>
#include <vector>

namespace bench {

/// A binary tree in the public layout: node 0 is the root; an inner node has
/// count 0 and children first, first + 1; a leaf holds prim_indices[first, first + count).
struct FlatTree {
    std::vector<aacbvh_node> nodes;
    std::vector<uint32_t> prim_indices;
};

/// Copies the tree of a built BVH. Returns false with a message on failure.
bool fetch_tree(const aacbvh_bvh *bvh, FlatTree &out, std::string &err);

/// Checks the tree's structure (children in range, every primitive slot used
/// once, children's boxes inside their parent's). Returns false with a message.
bool check_tree(const FlatTree &tree, size_t triangle_count, std::string &err);

/// SAH cost with the header's formula: (ct * sum A(inner) + ci * sum A(leaf) * N(leaf)) / A(root).
double sah_cost(const FlatTree &tree, double ct = 1.2, double ci = 1.0);

/// How much the two children of inner nodes overlap, two ways (issue 17).
/// SAH charges a node by its own area only, so two children that overlap
/// cost no more than two that do not; yet a ray through the overlap must enter
/// both, and a ray that starts inside it (a camera or a bounce inside the
/// scene) enters both at distance tmin, so only their exits can order them.
///  - area: sum over inner nodes of SA(left box ∩ right box) / SA(root), the
///    SAH-like expectation of how many inner nodes a random line through the
///    root crosses in both children at once (0 when no two siblings overlap);
///  - volume: sum over inner nodes of V(left ∩ right) / V(root), how many
///    inner nodes a uniformly random point of the root's box lies in both
///    children of: the chance that an origin inside the scene ties them.
/// NaN when the root's area (or volume) is 0. End-point overlap (Aila, Karras,
/// Laine, HPG 2013) would weigh the overlap by where rays end, on the
/// triangles; these are its cheap, geometry-only relatives.
struct Overlap {
    double area = 0.0;
    double volume = 0.0;
};
Overlap overlap_of(const FlatTree &tree);

/// Bytes the tree takes in the public layout (32 per node, 4 per primitive slot).
inline uint64_t flat_tree_bytes(const FlatTree &tree) {
    return tree.nodes.size() * sizeof(aacbvh_node) + tree.prim_indices.size() * sizeof(uint32_t);
}

/// Per-ray counts.
struct RayCount {
    uint64_t steps = 0;  ///< node boxes tested
    uint64_t tests = 0;  ///< triangle intersection tests
    uint64_t total() const { return steps + tests; }
};

/// Closest hit found by the counting tracer; prim_id AACBVH_INVALID_ID on a miss.
struct CountedHit {
    float t;
    uint32_t prim_id;
};

/// The counting tracer. Keeps references to the tree; copies the triangles.
class CostTracer {
public:
    /// vertices: x, y, z per vertex; indices: three per triangle.
    CostTracer(const FlatTree &tree, const float *vertices, const uint32_t *indices, size_t triangle_count);

    /// Closest hit of one ray, adding its counts to `count`.
    CountedHit closest(const aacbvh_ray &ray, RayCount &count) const;
    /// True if anything lies within [tmin, tmax] of the ray; adds its counts to `count`.
    bool any(const aacbvh_ray &ray, RayCount &count) const;

private:
    struct Tri {
        float v0[3], e1[3], e2[3];
    };
    template <bool AnyHit>
    CountedHit trace(const aacbvh_ray &ray, RayCount &count) const;

    const FlatTree &tree_;
    std::vector<Tri> tris_;  ///< by primitive id
};

/// Mean counts per ray of a ray set.
struct CostSummary {
    double steps = 0;
    double tests = 0;
    double total() const { return steps + tests; }
    uint64_t rays = 0;
    uint64_t hits = 0;  ///< rays that hit (closest) or were occluded (any)
};

/// Traces every ray and averages the counts.
CostSummary measure_closest(const CostTracer &tracer, const std::vector<aacbvh_ray> &rays,
                            std::vector<CountedHit> *hits_out = nullptr);
CostSummary measure_any(const CostTracer &tracer, const std::vector<aacbvh_ray> &rays,
                        std::vector<uint8_t> *occluded_out = nullptr);

}  // namespace bench
