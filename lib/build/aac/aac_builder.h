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
/// `c` and `alpha` are the values the API reports (AACBVH_PARAM_AAC_C,
/// AACBVH_PARAM_AAC_ALPHA): the paper's, for the presets.
///
/// A preset's own counts (ours, not the paper's): ranges of at least
/// `own_from` primitives hand up ceil(own_c * n^own_alpha) instead.
/// - AAC-HQ builds with its own counts at every size (own_from = 1): c = 2.3
///   instead of the paper's 20^0.6 / 2 = 3.02 makes the combines about a
///   quarter smaller, its builds run about a sixth fewer instructions, and
///   SAH stayed within 1 % of the paper's c on every scene measured (issue
///   13; docs/PERFORMANCE.md, change 121).
/// - AAC-Fast keeps the paper's f(n) where its work is (the many small
///   ranges) and takes AAC-HQ's counts from 1,024 primitives up, so the few
///   big clusters at the top merge from more candidates. The top merges
///   decide how much the root's children overlap, which rays that start
///   inside the scene pay for and SAH does not see (issue 17).
/// own_from = 0: the paper's single f(n) (AACBVH_BUILDER_AAC always builds
/// that way).
struct AacConfig {
    uint32_t delta = 20;
    double c = 0.0;
    double alpha = 0.4;
    uint32_t own_from = 0;
    double own_c = 0.0;
    double own_alpha = 0.4;
    /// The root range splits the clusters it receives top-down by SAH for this
    /// many levels (build/aac/top_split.h) and merges each part greedily; 0:
    /// the paper's greedy merge down to one cluster. Ours (issue 17).
    uint32_t root_split_levels = 0;
    /// After the clustering, the top above the maximal sub-trees of at most
    /// this many primitives is built again by a full-sweep SAH over them and
    /// kept where its flattened cost is lower (build/aac/top_rebuild.h); 0:
    /// the paper's tree as clustered. Ours (issues 14 and 17).
    uint32_t top_rebuild_prims = 0;

    /// The paper's AAC with the delta, c and alpha in force: none of the
    /// presets' own rules (AACBVH_BUILDER_AAC, or a preset whose AAC value the
    /// user set).
    void use_paper_rules() {
        own_from = 0;
        root_split_levels = 0;
        top_rebuild_prims = 0;
    }
};

/// f(n) = ceil(c * n^alpha), or ceil(own_c * n^own_alpha) when own_from != 0
/// and n >= own_from; never below 1 nor above n.
uint32_t aac_cluster_target(const AacConfig &config, uint32_t n);

/// out[n] = aac_cluster_target(config, n) for n in [0, count), by a few
/// pow() calls per distinct value instead of one per n (a build's table of
/// up to 4,097 values cost a tenth of a 3.7 K-triangle build;
/// docs/PERFORMANCE.md, row 197).
void aac_cluster_targets(const AacConfig &config, uint32_t count, uint32_t *out);

/// Also makes every node's flattening decision as it is created (into
/// `choices`), and releases input.boxes once they are gathered into the tree
/// (the tree takes the array over when the input has room for it,
/// InputRoom::Tree in build/build_input.h).
void build_aac(BuildInput &input, const AacConfig &config, const FlattenRule &rule, BuildContext &ctx,
               BinaryTree &out, SubtreeChoices &choices);

} // namespace aacbvh
