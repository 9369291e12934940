// Approximate Agglomerative Clustering (Gu, He, Fatahalian, Blelloch, HPG 2013).
//
// 1. Morton codes of the primitives' centroids, radix sorted; the recursion
//    keeps only the common prefix lengths of neighbouring codes
//    (build/radix_split.h).
// 2. Downward phase: split the sorted range at the highest bit on which its
//    codes differ (the middle when all are equal) until fewer than delta remain.
// 3. Upward phase: each range greedily combines the clusters its two halves
//    handed up (contiguous in one list, as the paper's "reduce data
//    movement" asks) down to f(n) = ceil(c n^alpha); the root down to one
//    (the presets first split the root's clusters by SAH: top_split.h).
// 4. The presets only: the top above the finished tree's sub-trees of at most
//    64 primitives built again by a full-sweep SAH, and kept where it is
//    cheaper (top_rebuild.h; ours).
//
// Node ids are deterministic whatever the thread count: the range [b, e) owns
// the inner ids n + b .. n + e - 1 and uses fewer than e - b of them; the ids a
// range leaves unused travel up beside its clusters (ClusterList::free).
#include <algorithm>
#include <cmath>

#include "build/aac/aac_builder.h"
#include "build/aac/cluster_combine.h"
#include "build/aac/top_rebuild.h"
#include "build/aac/top_split.h"
#include "build/morton.h"
#include "build/radix_split.h"

namespace aacbvh {

uint32_t aac_cluster_target(const AacConfig &config, uint32_t n) {
    // The paper's presets make f(delta) an integer (delta / 2); pow() lands a
    // hair above it (10.000000000000002 for HQ), so round off that noise
    // before the ceil.
    const bool own = config.own_from != 0 && n >= config.own_from;
    const double c = own ? config.own_c : config.c, alpha = own ? config.own_alpha : config.alpha;
    const double f = std::ceil(c * std::pow(double(n), alpha) * (1.0 - 1e-12));
    if (!(f >= 1.0)) return 1;
    return f >= double(n) ? n : uint32_t(f);
}

namespace {

/// aac_cluster_targets() over [lo, hi), where one (c, alpha) with c > 0 and
/// alpha > 0 applies: f is then non-decreasing (min(n, ceil(c n^alpha)),
/// each rounding monotone), so each value holds on one run of n. The run's
/// end is guessed from the inverse, n = (v / c)^(1 / alpha), and then moved
/// by the exact f until f(end - 1) <= v < f(end): about four pow() calls a
/// value instead of one an n (AAC-HQ's f takes 65 values up to 4,096).
void fill_monotone_targets(const AacConfig &config, double c, double alpha, uint32_t lo, uint32_t hi,
                           uint32_t *out) {
    uint32_t i = lo;
    while (i < hi) {
        const uint32_t v = aac_cluster_target(config, i);
        uint32_t end = i + 1;
        if (v < i) { // not clamped to n: the run ends past the inverse
            const double guess = std::floor(std::pow(double(v) / (c * (1.0 - 1e-12)), 1.0 / alpha)) + 1.0;
            if (guess > double(end)) end = guess < double(hi) ? uint32_t(guess) : hi;
            while (end > i + 1 && aac_cluster_target(config, end - 1) > v) --end;
        }
        while (end < hi && aac_cluster_target(config, end) <= v) ++end;
        std::fill(out + i, out + end, v);
        i = end;
    }
}

} // namespace

void aac_cluster_targets(const AacConfig &config, uint32_t count, uint32_t *out) {
    const auto monotone = [](double c, double alpha) {
        return std::isfinite(c) && std::isfinite(alpha) && c > 0.0 && alpha > 0.0;
    };
    const uint32_t own_from = config.own_from == 0 ? count : std::min(config.own_from, count);
    if (!monotone(config.c, config.alpha) || (own_from < count && !monotone(config.own_c, config.own_alpha))) {
        for (uint32_t n = 0; n < count; ++n) out[n] = aac_cluster_target(config, n); // no runs to rely on
        return;
    }
    fill_monotone_targets(config, config.c, config.alpha, 0, own_from, out);
    fill_monotone_targets(config, config.own_c, config.own_alpha, own_from, count, out);
}

namespace {

/// Ranges at least this long are split into two parallel tasks...
constexpr uint32_t kParallelGrain = 1u << 12;
/// ...and in scenes of fewer than 4 kParallelGrain primitives, ranges of a
/// quarter of the scene, down to this: otherwise a scene of under 4,096
/// primitives never forks, and a two-thread build of bunny_npm_lowres (3,674
/// triangles) took the one-thread time, 0.60 ms against 0.45-0.48 with
/// the forks (docs/PERFORMANCE.md, row 205). The tree is the same either way.
constexpr uint32_t kSmallSceneGrain = 1u << 10;

/// The fork threshold of AAC's recursion over a scene of n primitives.
constexpr uint32_t parallel_grain(uint32_t n) {
    return std::min(kParallelGrain, std::max(kSmallSceneGrain, n / 4));
}
/// Ranges at least this long whose Morton codes are all equal get codes of
/// their own (AacRecursion::refine_codes()); shorter ones split in the middle.
constexpr uint32_t kRefineFrom = 64;

class AacRecursion {
public:
    AacRecursion(const AacConfig &config, const FlattenRule &rule, BuildContext &ctx, BinaryTree &tree,
                 SubtreeChoices &choices, uint8_t *prefix, float scale)
        : config_(config), rule_(rule), ctx_(ctx), tree_(tree), choices_(choices.table()), prefix_(prefix), scale_(scale),
          n_(tree.leaf_count()), grain_(parallel_grain(n_)), meter_(MemoryMeter::current()), scratch_(meter_) {
        // f(n) of the many small nodes comes from a table instead of pow().
        small_targets_.resize(std::min<uint32_t>(n_, kTargetTableSize) + 1);
        aac_cluster_targets(config_, uint32_t(small_targets_.size()), small_targets_.data());
    }

    void run() {
        const ClusterList top = build_task(0, n_, scale_, true);
        tree_.root = top.ids[0];
    }

private:
    /// The clusters a range hands up, and beside each an inner id it left
    /// unused (a range of n primitives owns n inner ids and leaves unused as
    /// many as it hands up clusters): ids[0, count) and free[0, count).
    struct ClusterList {
        Array<uint32_t> ids, free;
        uint32_t count = 0;
        explicit ClusterList(uint32_t room) : ids(room), free(room) {}
    };

    /// Builds range [b, e) into a list of its own. Only the clusters that are
    /// alive take memory: a range of fewer than grain_ primitives works in
    /// arrays of its own length, at most one per thread at a time, and a
    /// longer one forks its halves and merges what they hand up (f(n) of
    /// each), instead of arrays of n ids and n free ids for the whole build
    /// (8 bytes a primitive at the build's peak; docs/PERFORMANCE.md, row 213).
    ClusterList build_task(uint32_t b, uint32_t e, float scale, bool root = false) {
        const uint32_t n = e - b;
        const MemoryMeter::Scope metered(meter_); // counted on any thread
        if (n < grain_) {
            ClusterList work(n);
            const uint32_t count = build(b, e, scale, work.ids.data(), work.free.data(), root);
            // What waits for the other half is the f(n) clusters only, not
            // the range's working arrays (on a scene of 3,674 triangles
            // those cost 2.6 bytes a triangle at the peak).
            ClusterList list(count);
            std::copy_n(work.ids.data(), count, list.ids.data());
            std::copy_n(work.free.data(), count, list.free.data());
            list.count = count;
            return list;
        }
        ctx_.poll();
        const uint32_t m = split_at(b, e, scale);
        ClusterList left(0), right(0);
        ctx_.scheduler().fork_join([&] { left = build_task(b, m, scale); }, [&] { right = build_task(m, e, scale); });
        ctx_.check_cancelled();
        ClusterList both(left.count + right.count);
        std::copy_n(left.ids.data(), left.count, both.ids.data());
        std::copy_n(right.ids.data(), right.count, both.ids.data() + left.count);
        std::copy_n(left.free.data(), left.count, both.free.data());
        std::copy_n(right.free.data(), right.count, both.free.data() + left.count);
        both.count = reduce(both.ids.data(), both.free.data(), left.count, right.count, n, scale, root);
        return both;
    }

    /// Builds range [b, e) on this thread, in ids[0, e - b) and free[0, e - b)
    /// (position b + i of the range at i); returns how many clusters it
    /// leaves in ids[0, count). The root range combines down to one cluster.
    /// `scale` is the clustering distances' (distance_scale()): the scene's,
    /// or a refined range's own (refine_codes()).
    uint32_t build(uint32_t b, uint32_t e, float scale, uint32_t *ids, uint32_t *free, bool root = false) {
        const uint32_t n = e - b;
        if (n < config_.delta) {
            for (uint32_t i = 0; i < n; ++i) {
                ids[i] = b + i;
                free[i] = n_ + b + i;
            }
            const uint32_t t = root ? 1 : target(config_.delta);
            if (n <= t) return n; // nothing to merge (combine_clusters' own first test, without the call)
            return combine_clusters(tree_, ids, free, n, t, scale, rule_, choices_, scratch_, ctx_);
        }
        if (n >= 256) ctx_.poll();
        const uint32_t m = split_at(b, e, scale);
        const uint32_t left = build(b, m, scale, ids, free);
        const uint32_t right = build(m, e, scale, ids + (m - b), free + (m - b));
        // The right half's clusters and free ids move next to the left half's.
        std::copy(ids + (m - b), ids + (m - b) + right, ids + left);
        std::copy(free + (m - b), free + (m - b) + right, free + left);
        return reduce(ids, free, left, right, n, scale, root);
    }

    /// Where range [b, e) splits: at the highest bit on which its codes
    /// differ, after giving it codes of its own when they are all equal
    /// (refine_codes(), which may set `scale`).
    uint32_t split_at(uint32_t b, uint32_t e, float &scale) {
        RadixSplit split = radix_split(prefix_, b, e);
        if (split.equal && e - b >= kRefineFrom && refine_codes(b, e, scale)) split = radix_split(prefix_, b, e);
        return split.at;
    }

    /// Merges the left + right clusters a range of n primitives' halves handed
    /// up, side by side in ids and free, down to f(n) (the root: to one);
    /// returns how many are left.
    uint32_t reduce(uint32_t *ids, uint32_t *free, uint32_t left, uint32_t right, uint32_t n, float scale, bool root) {
        if (root && config_.root_split_levels > 0) {
            ids[0] = split_root(ids, free, left + right, config_.root_split_levels);
            return 1;
        }
        return combine_clusters(tree_, ids, free, left + right, root ? 1 : target(n), scale, rule_, choices_, scratch_,
                                ctx_);
    }

    SubtreeChoice choice(uint32_t id) const { return id < n_ ? rule_.leaf(tree_.boxes[id]) : choices_.get(id - n_); }

    /// The root range: its top `levels` levels split top-down by SAH over the
    /// clusters' centroids (build/aac/top_split.h), each side below them merged
    /// greedily as usual. One tree over ids[0, count) with count - 1 ids from
    /// free[0, count); returns its root and leaves the unused free id in free[0].
    uint32_t split_root(uint32_t *ids, uint32_t *free, uint32_t count, uint32_t levels) {
        if (levels == 0 || count <= 2) {
            combine_clusters(tree_, ids, free, count, 1, side_scale(ids, count), rule_, choices_, scratch_, ctx_);
            return ids[0];
        }
        const uint32_t m = sah_partition(tree_, choices_, ids, count);
        const uint32_t l = split_root(ids, free, m, levels - 1);
        const uint32_t r = split_root(ids + m, free + m, count - m, levels - 1);
        const uint32_t node = free[0];
        free[0] = free[m];
        Box merged = tree_.boxes[l];
        merged.extend(tree_.boxes[r]);
        tree_.boxes[node] = merged;
        tree_.set_children(node, l, r);
        choices_.set(node - n_, rule_.inner(merged, choice(l), choice(r)));
        return node;
    }

    /// The distance scale for merging clusters ids[0, count) below the root
    /// split: the scene's, unless their union is more than 2^20 times
    /// smaller than the scene (the far side of a split from an outlier, as
    /// in refine_codes()): then its own, so that their distances do not
    /// underflow. The scene's everywhere else, so ordinary scenes build the
    /// same trees.
    float side_scale(const uint32_t *ids, uint32_t count) const {
        Box bounds = Box::empty();
        for (uint32_t i = 0; i < count; ++i) bounds.extend(tree_.boxes[ids[i]]);
        const float own = distance_scale(bounds);
        return own > scale_ * 0x1p20f ? own : scale_;
    }

    /// Primitives whose centroids share one cell of the scene's grid (a cluster
    /// of small triangles far from the rest of the scene: one triangle at
    /// 1e30 puts 100 K others in [0, 1]^2 in one cell) would be split by
    /// position alone, in input order, and clustered across space, with
    /// distances scaled by the scene's extent that underflow to 0: such a
    /// scene traced up to thousands of times slower than a SAH tree
    /// (docs/PERFORMANCE.md, change 146). Instead the range gets codes on a
    /// grid over its own centroids, its leaves (boxes, primitive ids) are
    /// sorted by them, ties in their present order, the prefix lengths
    /// within the range are made from them, and its clustering distances
    /// are scaled by its own extent (`scale` is set). Nothing in the
    /// range is built yet, and ranges are disjoint, so tasks never meet here.
    /// Nothing is done, and false returned, when the centroids are all one
    /// point: no grid separates them.
    [[gnu::noinline, gnu::cold]] bool refine_codes(uint32_t b, uint32_t e, float &scale) {
        const uint32_t n = e - b;
        Array<uint64_t> local;
        Array<uint32_t> rank;
        if (!local_morton_order(n, [&](size_t i) -> const Box & { return tree_.boxes[b + i]; }, local, rank))
            return false;
        Box extent = Box::empty();
        Array<Box> boxes(n);
        Array<uint32_t> prims(n);
        for (uint32_t i = 0; i < n; ++i) {
            boxes[i] = tree_.boxes[b + rank[i]];
            prims[i] = tree_.prim_ids[b + rank[i]];
            extent.extend(boxes[i]);
        }
        for (uint32_t i = 0; i < n; ++i) {
            tree_.boxes[b + i] = boxes[i];
            tree_.prim_ids[b + i] = prims[i];
        }
        // The pairs inside the range; those across its ends stay (a range
        // never reads them).
        for (uint32_t i = 0; i + 1 < n; ++i) prefix_[b + i] = common_prefix(local[rank[i]], local[rank[i + 1]]);
        scale = distance_scale(extent);
        return true;
    }

    const AacConfig &config_;
    const FlattenRule &rule_;
    BuildContext &ctx_;
    BinaryTree &tree_;
    ChoiceTable choices_;
    uint32_t target(uint32_t n) const {
        return n < small_targets_.size() ? small_targets_[n] : aac_cluster_target(config_, n);
    }

    static constexpr uint32_t kTargetTableSize = 4096;
    uint8_t *prefix_; ///< common prefix lengths of neighbouring codes; refine_codes() rewrites a range's
    float scale_;
    uint32_t n_;
    uint32_t grain_; ///< parallel_grain(n_)
    MemoryMeter *meter_; ///< the build's, installed on the threads that run its tasks
    std::vector<uint32_t> small_targets_;
    CombineScratchPool scratch_;
};

} // namespace

void build_aac(BuildInput &input, const AacConfig &config, const FlattenRule &rule, BuildContext &ctx,
               BinaryTree &out, SubtreeChoices &choices) {
    const uint32_t n = uint32_t(input.size());
    Array<uint32_t> order;
    // The splits need only the prefix lengths: one byte a primitive instead
    // of eight through the rest of the build (docs/PERFORMANCE.md, row 175),
    // made by the sort without the codes (row 216). The sort works in the
    // room the input keeps for the tree's inner boxes (InputRoom::Tree: 24
    // bytes a primitive, as many as the sort needs; row 214).
    Array<uint8_t> prefix(n + kPrefixPadding, 0);
    static_assert(kMortonSortWords * sizeof(uint64_t) <= sizeof(Box));
    const bool roomy = input.box_offset >= n && reinterpret_cast<uintptr_t>(input.boxes.data()) % alignof(uint64_t) == 0;
    uint64_t *room = roomy ? reinterpret_cast<uint64_t *>(input.boxes.data()) : nullptr;
    sort_by_morton_prefixes(input, ctx.scheduler(), order, prefix.data(), room);
    ctx.report(0.3);

    // The leaves in Morton order. With room in the input's array
    // (InputRoom::Tree) they are gathered into its lower half, which the
    // boxes (above it) do not overlap, and the array becomes the tree's,
    // instead of a second array beside the input's (docs/PERFORMANCE.md,
    // row 176). The leaves' primitive indices overwrite the order, entry by
    // entry. The children come after the input is freed (row 149).
    out.prim_ids.swap(order);
    const Box *boxes = input.boxes.data() + input.box_offset;
    if (input.box_offset >= n)
        out.boxes.swap(input.boxes);
    else
        out.boxes.resize(2 * size_t(n));
    gather_leaves(boxes, input_prim_ids(input), out.prim_ids.data(), ctx.scheduler(), out);
    out.boxes.resize(2 * size_t(n)); // taken over: never grows (it holds box_offset + n >= 2n)
    Array<Box>().swap(input.boxes); // the leaves hold them now, in Morton order
    Array<uint32_t>().swap(input.prim_ids); // and the primitives' indices
    out.children.resize(2 * size_t(n));
    if (n == 1) {
        out.root = 0;
        return;
    }
    choices.resize(n, rule.packets);
    AacRecursion(config, rule, ctx, out, choices, prefix.data(), distance_scale(input.bounds)).run();
    Array<uint8_t>().swap(prefix);
    // The top rebuilt over the sub-trees of at most top_rebuild_prims
    // primitives, tried first over sub-trees four times that size (about a
    // quarter of the work): where that coarse top does not beat AAC's, the
    // finer one did not either on any scene measured of more than
    // kTryCoarseFrom primitives (the interiors), which then pay only the
    // quarter (docs/PERFORMANCE.md, row 203). Smaller scenes, whose whole
    // step is a few dozen microseconds, go straight to the fine cut: the
    // coarse one threw away bunny_npm_lowres's gain.
    constexpr uint32_t kTryCoarseFrom = 1u << 14;
    const uint32_t cut = config.top_rebuild_prims;
    if (cut != 0 && (n < kTryCoarseFrom ||
                     rebuild_top(out, choices.table(), rule, cut > UINT32_MAX / 4 ? cut : 4 * cut, ctx)))
        rebuild_top(out, choices.table(), rule, cut, ctx);
}

} // namespace aacbvh
