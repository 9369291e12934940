// The builders AAC is measured against (Gu et al. 2013, section 6). Each turns
// a BuildInput into a BinaryTree with one primitive per leaf (leaf i holds
// input.prim_ids[i] unless the builder reorders prim_ids); build/flatten.h
// then collapses it into leaves by the SAH. The top-down ones split every
// range down to single primitives, so the SAH costs matter only to flattening.
#pragma once

#include <cstdint>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "build/build_input.h"

namespace aacbvh {

/// Top-down full-sweep SAH (MacDonald and Booth 1990).
void build_sweep_sah(const BuildInput &input, BuildContext &ctx, BinaryTree &out);
/// Top-down binned SAH, 16 bins on the longest centroid axis (Wald 2007).
void build_binned_sah(const BuildInput &input, BuildContext &ctx, BinaryTree &out);
/// Exact agglomerative clustering, locally ordered (Walter et al. 2008).
void build_locally_ordered(const BuildInput &input, BuildContext &ctx, BinaryTree &out);
/// Parallel locally-ordered clustering (Meister and Bittner 2018).
void build_ploc(const BuildInput &input, uint32_t radius, BuildContext &ctx, BinaryTree &out);

} // namespace aacbvh
