#include "builder_table.h"

#include <cmath>

#include "build/reference/reference_builders.h"
#include "params.h"

namespace aacbvh {

namespace {

/// Where AAC-Fast takes AAC-HQ's counts: ranges of this many primitives and more.
constexpr uint32_t kFastTopFrom = 1024;
/// Levels of the root split top-down by SAH in both presets (issue 17): one.
/// Over 48 in-scene views per scene it cut AAC-HQ's boxes per ray on six of
/// seven scenes (sponza 13 %), SAH from 5 % lower (sponza) to 2.5 % higher
/// (conference); three levels helped the
/// scans more but cost AAC-Fast on stk_temple (docs/PERFORMANCE.md, change 50).
constexpr uint32_t kRootSplitLevels = 1;

/// The paper's presets: HQ delta 20, f(n) = (20^0.6 / 2) n^0.4;
/// Fast delta 4, f(n) = (4^0.7 / 2) n^0.3. These are the values the API
/// reports for c and alpha (and AACBVH_BUILDER_AAC builds with).
double paper_hq_c() { return std::pow(20.0, 0.6) / 2.0; }
double paper_fast_c() { return std::pow(4.0, 0.7) / 2.0; }

/// AAC-HQ's own counts, f(n) = ceil(2.3 n^0.4) at every size (issue 13): the
/// paper's c = 3.02 made combines of about 20-30 clusters, most of the build's
/// time, for SAH that c = 2.3 matched within 1 % on all eight scenes measured
/// (0.3 % lower on average; moving the paper's c by 7e-5 changed the
/// bunny's SAH by 0.8 %), with about 16 % fewer instructions a build
/// (docs/PERFORMANCE.md, change 121).
constexpr double kHqOwnC = 2.3;

/// Both presets build their top again by a full sweep over the sub-trees of
/// at most this many primitives and keep it where it is cheaper
/// (build/aac/top_rebuild.h; issues 14 and 17): on the scans and the
/// procedural scene SAH fell 4-6 % and ray cost 6-16 % (the dragon's SAH
/// 64.7 -> 60.9), the interiors kept AAC's own tops. 128 gained about three
/// quarters of that for half the work; 16 and 32 gained more for twice and
/// four times (docs/PERFORMANCE.md, row 203).
constexpr uint32_t kTopRebuildPrims = 64;

AacConfig hq_preset() { return AacConfig{20, paper_hq_c(), 0.4, 1, kHqOwnC, 0.4, kRootSplitLevels, kTopRebuildPrims}; }

/// Fast keeps the paper's f(n) below 1,024 primitives and takes HQ's counts
/// above (issue 17). Its small f(n) starved the top: on stk_temple the final
/// merges chose among 86 clusters of about 2,400 triangles (HQ: 612), the
/// root's children overlapped over half the scene's volume, and views standing
/// inside the level tested up to 140 boxes per ray (HQ: 57). Ranges of 1,024
/// and more are about 1 in 256 of Fast's combine steps, so the build costs
/// about the same (docs/PERFORMANCE.md, change 47).
AacConfig fast_preset() { return AacConfig{4, paper_fast_c(), 0.3, kFastTopFrom, kHqOwnC, 0.4, kRootSplitLevels, kTopRebuildPrims}; }

bool run_aac(BuildInput &input, const Params &params, const FlattenRule &rule, BuildContext &ctx, BinaryTree &tree,
             SubtreeChoices &choices) {
    build_aac(input, params.aac, rule, ctx, tree, choices);
    return true;
}

bool run_sweep(BuildInput &input, const Params &, const FlattenRule &, BuildContext &ctx, BinaryTree &tree,
               SubtreeChoices &) {
    build_sweep_sah(input, ctx, tree);
    return false;
}

bool run_binned(BuildInput &input, const Params &, const FlattenRule &, BuildContext &ctx, BinaryTree &tree,
                SubtreeChoices &) {
    build_binned_sah(input, ctx, tree);
    return false;
}

bool run_locally_ordered(BuildInput &input, const Params &, const FlattenRule &, BuildContext &ctx,
                         BinaryTree &tree, SubtreeChoices &) {
    build_locally_ordered(input, ctx, tree);
    return false;
}

bool run_ploc(BuildInput &input, const Params &params, const FlattenRule &, BuildContext &ctx, BinaryTree &tree,
              SubtreeChoices &) {
    build_ploc(input, params.ploc_radius, ctx, tree);
    return false;
}

constexpr BuilderInfo kBuilders[] = {
    {AACBVH_BUILDER_AAC_HQ, "aac-hq", "AAC, the paper's high-quality preset (delta 20, alpha 0.4) with f(n) = ceil(2.3 n^0.4), root split by SAH, top over sub-trees of 64 primitives rebuilt by full sweep where cheaper: the default",
     hq_preset, run_aac, InputRoom::Tree},
    {AACBVH_BUILDER_AAC_FAST, "aac-fast", "AAC, the paper's fast preset (delta 4, alpha 0.3), HQ's cluster counts from 1,024 primitives up, root split by SAH, top rebuilt as HQ's", fast_preset, run_aac, InputRoom::Tree},
    {AACBVH_BUILDER_AAC, "aac", "AAC with your own delta, c and alpha", nullptr, run_aac, InputRoom::Tree},
    {AACBVH_BUILDER_SWEEP_SAH, "sweep-sah", "top-down full-sweep SAH, the quality reference", nullptr, run_sweep},
    {AACBVH_BUILDER_BINNED_SAH, "binned-sah", "top-down binned SAH, 16 bins", nullptr, run_binned},
    {AACBVH_BUILDER_LOCALLY_ORDERED, "locally-ordered", "exact agglomerative clustering (slow; for comparison)",
     nullptr, run_locally_ordered},
    {AACBVH_BUILDER_PLOC, "ploc", "parallel locally-ordered clustering", nullptr, run_ploc},
};

constexpr size_t kBuilderCount = sizeof kBuilders / sizeof kBuilders[0];

// The table is indexed by value: entry i is builder i.
constexpr bool dense() {
    for (size_t i = 0; i < kBuilderCount; ++i)
        if (size_t(kBuilders[i].value) != i) return false;
    return true;
}
static_assert(dense(), "builder_table entries must be in aacbvh_builder order");

} // namespace

const BuilderInfo *builder_table(size_t &count) {
    count = kBuilderCount;
    return kBuilders;
}

const BuilderInfo *find_builder(int64_t value) {
    return value >= 0 && uint64_t(value) < kBuilderCount ? &kBuilders[value] : nullptr;
}

} // namespace aacbvh
