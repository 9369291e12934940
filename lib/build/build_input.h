// The primitives a builder sees: one box per valid primitive, after the
// geometry was checked (build/build_input.cpp).
#pragma once

#include <cstdint>
#include <vector>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "core/box.h"
#include "core/geometry.h"
#include "core/memory.h"

namespace aacbvh {

struct BuildInput {
    Array<Box> boxes;                ///< boxes[box_offset + i] bounds primitive prim_ids[i]
    Array<uint32_t> prim_ids;        ///< the caller's primitive index of entry i
    /// 0, or with room for the builder's tree (InputRoom::Tree) the
    /// primitive count: the boxes then lie in the upper half of an array of
    /// twice the count, which becomes the tree's boxes (its leaves gathered
    /// into the lower half) instead of a second array.
    size_t box_offset = 0;
    Box bounds = Box::empty();       ///< union of all boxes
    Box centroid_bounds = Box::empty(); ///< bounds of the boxes' centres
    uint64_t invalid_count = 0;      ///< primitives left out as invalid
    /// prim_ids[i] == i for every entry (compute_build_input() with no
    /// primitive left out): gather_leaves() then reads the order alone.
    bool identity_ids = false;

    size_t size() const { return prim_ids.size(); }
    const Box &box(size_t i) const { return boxes[box_offset + i]; }
};

/// Whether the input's box array leaves room for a BinaryTree's boxes
/// (BuildInput::box_offset): for builders that gather their leaves into it
/// (AAC). A build that keeps the input's boxes beside the tree (the SAH
/// builders, PLOC) would only hold more memory. AAC's Morton sort works in
/// that room before the tree takes it (build/morton.h). Every input size gets
/// it: the sort's 24 bytes a primitive in memory already mapped paid for the
/// fresh block that cost scenes of 66-75 K triangles 4-11 % before
/// (docs/PERFORMANCE.md, rows 176 and 214).
enum class InputRoom { None, Tree };

/// Why primitive i of the geometry is invalid (NaN or infinite coordinates,
/// vertex index out of range, box min > max), or nullptr if it is fine.
const char *primitive_problem(const Geometry &geometry, size_t i);

/// How the input pass reads triangles: Fastest takes the SSE path where
/// there is one (build_input.cpp, triangle_chunk); General sends every
/// primitive through primitive_problem() and primitive_box(), the reference
/// the tests hold the fast path to (the same bits).
enum class InputPath { Fastest, General };

/// Checks the geometry and fills `input`. Throws Error(AACBVH_ERROR_INVALID_GEOMETRY)
/// naming the first bad primitive, unless skip_invalid leaves bad ones out.
void compute_build_input(const Geometry &geometry, bool skip_invalid, BuildContext &ctx, BuildInput &input,
                         InputPath path = InputPath::Fastest, InputRoom room = InputRoom::None);

/// The leaves of a builder's tree in the builder's order: leaf i of `out`
/// (sized already) takes input entry order[i], its box and the caller's
/// primitive index. Runs in parallel.
void gather_leaves(const BuildInput &input, const uint32_t *order, Scheduler &scheduler, BinaryTree &out);
/// The same from `boxes` and `prim_ids` in input order; `boxes` may lie in
/// out.boxes beyond the leaves (InputRoom::Tree), and `order` may be
/// out.prim_ids itself (each entry is read before the leaf's index
/// replaces it). `prim_ids` nullptr: entry i is primitive i (input_prim_ids()),
/// so the leaves' indices are the order's, without a scattered read each
/// (docs/PERFORMANCE.md, row 225).
void gather_leaves(const Box *boxes, const uint32_t *prim_ids, const uint32_t *order, Scheduler &scheduler,
                   BinaryTree &out);
/// input.prim_ids for gather_leaves(), or nullptr where it is the identity
/// (BuildInput::identity_ids).
const uint32_t *input_prim_ids(const BuildInput &input);

} // namespace aacbvh
