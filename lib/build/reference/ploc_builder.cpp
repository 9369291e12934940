// PLOC: Meister and Bittner, "Parallel Locally-Ordered Clustering for Bounding
// Volume Hierarchy Construction", IEEE TVCG 24(3), 2018.
//
// Clusters are kept in Morton order of their centroids. Each iteration every
// cluster finds its nearest neighbour (d = surface area of the union box)
// among the `radius` clusters on either side; mutual nearest neighbours merge
// into the lower position, the other position is dropped, and the list is
// compacted. O(n * radius) work per iteration; the cluster count shrinks by a
// roughly constant factor per iteration, so the total is near O(n * radius).
//
// Ties: candidate pairs are ordered by (distance, gap in positions, a hash of
// the pair, lower position). The order is a property of the pair, so the least
// pair is always mutual and every iteration merges at least once; the gap and
// the hash make equal distances (identical or nested boxes) still pair up many
// clusters per iteration, where plain "lower position wins" would merge only
// one pair per iteration and take O(n^2). Every step is a function of
// positions only, and new node ids come from a prefix sum over positions, so
// the tree does not depend on the thread count.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "build/morton.h"
#include "build/reference/reference_builders.h"
#include "core/memory.h"

namespace aacbvh {
namespace {

/// Clusters per parallel chunk.
constexpr size_t kGrain = 1 << 14;
/// Runs of equal Morton codes at least this long are sorted again on a grid
/// of their own (refine_equal_code_runs()), as AAC's ranges are.
constexpr size_t kRefineFrom = 64;

/// Tie-break between candidate pairs (i, j), i < j, of equal distance and gap.
inline uint32_t pair_hash(uint32_t i, uint32_t j) {
    uint64_t x = uint64_t(i) << 32 | j;
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdull;
    x ^= x >> 33;
    x *= 0xc4ceb3f99f6b5ee5ull;
    x ^= x >> 33;
    return uint32_t(x);
}

} // namespace

void build_ploc(const BuildInput &input, uint32_t radius, BuildContext &ctx, BinaryTree &out) {
    const uint32_t n = uint32_t(input.size());
    const size_t r = std::max<uint32_t>(radius, 1);
    // Distances on extents scaled as AAC's (distance_scale()): finite and
    // distinct for scenes at 1e30 or 1e-30, never NaN.
    const float scale = distance_scale(input.bounds);
    Scheduler &scheduler = ctx.scheduler();
    out.resize(n);
    Array<uint32_t> order;
    {
        Array<uint64_t> codes;
        sort_by_morton_code(input, scheduler, codes, order);
        // A cluster that shares one cell of the scene's grid (small
        // primitives far from an outlier) would stay in input order, and the
        // windows would pair primitives from across it: AAC's fix, for the
        // whole order (docs/PERFORMANCE.md, change 147).
        refine_equal_code_runs(input, codes, order, kRefineFrom);
    }

    // The current clusters in Morton order: node id and box; next_* is the
    // compacted list being written.
    Array<uint32_t> ids(n), next_ids(n), neighbour(n);
    Array<Box> boxes(n), next_boxes(n);
    gather_leaves(input, order.data(), scheduler, out);
    scheduler.parallel_for(0, n, kGrain, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
            boxes[i] = out.boxes[i];
            ids[i] = uint32_t(i);
        }
    });

    Array<uint32_t> chunk_merges, chunk_survivors;
    size_t count = n;
    uint32_t next_id = n;
    while (count > 1) {
        ctx.poll();
        scheduler.parallel_for(0, count, kGrain, [&](size_t begin, size_t end) {
            PollingCounter work(ctx); // a chunk is up to 2^14 windows of 2049 (radius 1024)
            for (size_t i = begin; i < end; ++i) {
                const size_t lo = i > r ? i - r : 0;
                const size_t hi = std::min(count, i + r + 1);
                testing::count_distances(hi - lo - 1);
                work.add(hi - lo);
                float best = INFINITY;
                size_t best_j = i;
                // j ascending: of two candidates with equal distance, gap and
                // hash the lower position comes first and stays.
                for (size_t j = lo; j < hi; ++j) {
                    if (j == i) continue;
                    const float d = scaled_union_half_area(boxes[i], boxes[j], scale);
                    if (d > best) continue;
                    if (best_j != i && d == best) {
                        const size_t gap = j > i ? j - i : i - j;
                        const size_t best_gap = best_j > i ? best_j - i : i - best_j;
                        if (gap > best_gap) continue;
                        if (gap == best_gap) {
                            // best_j = i - gap < i < j = i + gap
                            if (pair_hash(uint32_t(i), uint32_t(j)) >= pair_hash(uint32_t(best_j), uint32_t(i))) continue;
                        }
                    }
                    best = d;
                    best_j = j;
                }
                neighbour[i] = uint32_t(best_j);
            }
        });

        // Position i merges when it and its neighbour point at each other; the
        // lower one keeps the merged cluster and the higher one is dropped.
        const size_t chunks = (count + kGrain - 1) / kGrain;
        chunk_merges.assign(chunks + 1, 0);
        chunk_survivors.assign(chunks + 1, 0);
        scheduler.parallel_for(0, chunks, 1, [&](size_t cbegin, size_t cend) {
            for (size_t c = cbegin; c < cend; ++c) {
                uint32_t merges = 0, survivors = 0;
                for (size_t i = c * kGrain, end = std::min(count, (c + 1) * kGrain); i < end; ++i) {
                    const uint32_t j = neighbour[i];
                    const bool mutual = neighbour[j] == i;
                    merges += mutual && i < j;
                    survivors += !mutual || i < j;
                }
                chunk_merges[c + 1] = merges;
                chunk_survivors[c + 1] = survivors;
            }
        });
        for (size_t c = 0; c < chunks; ++c) {
            chunk_merges[c + 1] += chunk_merges[c];
            chunk_survivors[c + 1] += chunk_survivors[c];
        }
        scheduler.parallel_for(0, chunks, 1, [&](size_t cbegin, size_t cend) {
            for (size_t c = cbegin; c < cend; ++c) {
                uint32_t id = next_id + chunk_merges[c];
                uint32_t at = chunk_survivors[c];
                for (size_t i = c * kGrain, end = std::min(count, (c + 1) * kGrain); i < end; ++i) {
                    const uint32_t j = neighbour[i];
                    const bool mutual = neighbour[j] == i;
                    if (!mutual) {
                        next_ids[at] = ids[i];
                        next_boxes[at++] = boxes[i];
                    } else if (i < j) {
                        const Box merged = unite(boxes[i], boxes[j]);
                        out.set_children(id, ids[i], ids[j]);
                        out.boxes[id] = merged;
                        next_ids[at] = id++;
                        next_boxes[at++] = merged;
                    }
                }
            }
        });
        next_id += chunk_merges[chunks];
        count = chunk_survivors[chunks];
        ids.swap(next_ids);
        boxes.swap(next_boxes);
    }
    out.root = ids[0];
}

} // namespace aacbvh
