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
    Array<Box> boxes;                ///< boxes[i] bounds primitive prim_ids[i]
    Array<uint32_t> prim_ids;        ///< the caller's primitive index of entry i
    Box bounds = Box::empty();       ///< union of all boxes
    Box centroid_bounds = Box::empty(); ///< bounds of the boxes' centres
    uint64_t invalid_count = 0;      ///< primitives left out as invalid

    size_t size() const { return boxes.size(); }
};

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
                         InputPath path = InputPath::Fastest);

/// The leaves of a builder's tree in the builder's order: leaf i of `out`
/// (sized already) takes input entry order[i], its box and the caller's
/// primitive index. Runs in parallel.
void gather_leaves(const BuildInput &input, const uint32_t *order, Scheduler &scheduler, BinaryTree &out);

} // namespace aacbvh
