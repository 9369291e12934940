// Every builder turns a BuildInput into a BinaryTree with one primitive per
// leaf (leaf i holds input.prim_ids[i] unless the builder reorders prim_ids);
// flatten.h then collapses it into leaves by the SAH.
#pragma once

#include <cstdint>

#include "binary_tree.h"
#include "build_context.h"
#include "build_input.h"
#include "flatten.h"

namespace aacbvh {

/// AAC parameters (Gu et al. 2013): ranges under `delta` primitives stay
/// unsplit; a node over n primitives hands f(n) = ceil(c * n^alpha) clusters up.
struct AacConfig {
    uint32_t delta = 20;
    double c = 0.0;
    double alpha = 0.4;
};

/// f(n) = ceil(c * n^alpha), never below 1.
uint32_t aac_cluster_target(const AacConfig &config, uint32_t n);

/// Also makes every node's flattening decision as it is created (into
/// `choices`), and releases input.boxes once they are gathered into the tree.
void build_aac(BuildInput &input, const AacConfig &config, const FlattenRule &rule, BuildContext &ctx,
               BinaryTree &out, SubtreeChoices &choices);

/// Top-down full-sweep SAH (MacDonald and Booth 1990).
void build_sweep_sah(const BuildInput &input, double traversal_cost, double intersection_cost,
                     BuildContext &ctx, BinaryTree &out);
/// Top-down binned SAH, 16 bins on the longest centroid axis (Wald 2007).
void build_binned_sah(const BuildInput &input, double traversal_cost, double intersection_cost,
                      BuildContext &ctx, BinaryTree &out);
/// Exact agglomerative clustering, locally ordered (Walter et al. 2008).
void build_locally_ordered(const BuildInput &input, BuildContext &ctx, BinaryTree &out);
/// Parallel locally-ordered clustering (Meister and Bittner 2018).
void build_ploc(const BuildInput &input, uint32_t radius, BuildContext &ctx, BinaryTree &out);

} // namespace aacbvh
