// Approximate Agglomerative Clustering (Gu, He, Fatahalian, Blelloch, HPG 2013):
// the library's own builder. Like every builder it turns a BuildInput into a
// BinaryTree with one primitive per leaf; unlike the others it also makes the
// flattening decisions (build/flatten.h) as it merges.
#pragma once

#include <cstdint>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "build/build_input.h"
#include "build/flatten.h"

namespace aacbvh {

/// AAC parameters (Gu et al. 2013): ranges under `delta` primitives stay
/// unsplit; a node over n primitives hands f(n) = ceil(c * n^alpha) clusters up.
///
/// A top stage (ours, not the paper's; issue 17): ranges of at least
/// `top_from` primitives hand up ceil(top_c * n^top_alpha) instead, so a
/// preset can keep its cheap f(n) where the work is (the many small ranges)
/// and still merge the few big clusters at the top from more candidates. The
/// top merges decide how much the root's children overlap, which rays that
/// start inside the scene pay for and SAH does not see. top_from = 0: the
/// paper's single f(n) (AACBVH_BUILDER_AAC always builds that way).
struct AacConfig {
    uint32_t delta = 20;
    double c = 0.0;
    double alpha = 0.4;
    uint32_t top_from = 0;
    double top_c = 0.0;
    double top_alpha = 0.4;
    /// The root range splits the clusters it receives top-down by SAH for this
    /// many levels (build/aac/top_split.h) and merges each part greedily; 0:
    /// the paper's greedy merge down to one cluster. Ours (issue 17).
    uint32_t root_split_levels = 0;
};

/// f(n) = ceil(c * n^alpha), or ceil(top_c * n^top_alpha) when top_from != 0
/// and n >= top_from; never below 1 nor above n.
uint32_t aac_cluster_target(const AacConfig &config, uint32_t n);

/// Also makes every node's flattening decision as it is created (into
/// `choices`), and releases input.boxes once they are gathered into the tree.
void build_aac(BuildInput &input, const AacConfig &config, const FlattenRule &rule, BuildContext &ctx,
               BinaryTree &out, SubtreeChoices &choices);

} // namespace aacbvh
