#include "cluster_combine.h"

#include <algorithm>
#include <cmath>

namespace aacbvh {

namespace {

/// d(A, B) of the paper: surface area (here half of it) of the union box.
inline float distance(const Box &a, const Box &b, float scale) {
    const float dx = (std::max(a.hi[0], b.hi[0]) - std::min(a.lo[0], b.lo[0])) * scale;
    const float dy = (std::max(a.hi[1], b.hi[1]) - std::min(a.lo[1], b.lo[1])) * scale;
    const float dz = (std::max(a.hi[2], b.hi[2]) - std::min(a.lo[2], b.lo[2])) * scale;
    return dx * dy + dy * dz + dz * dx;
}

/// Above this many clusters the pairwise matrix (count^2 floats) is not kept;
/// rows are recomputed instead (exact-clustering settings reach this).
constexpr uint32_t kMatrixLimit = 2048;

/// The greedy loop. With a matrix, d(i, j) of live clusters is cached
/// (updating only the merged cluster's row, as the paper suggests); without,
/// each distance is computed when needed.
template <bool kMatrix>
uint32_t combine(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target, float scale,
                 CombineScratch &s, BuildContext &ctx) {
    const uint32_t stride = count;
    Box *box = s.boxes.data();
    float *dist = kMatrix ? s.distances.data() : nullptr;
    float *nd = s.nearest_distance.data();
    uint32_t *nn = s.nearest.data();

    auto d = [&](uint32_t i, uint32_t j) -> float {
        if (kMatrix) return dist[size_t(i) * stride + j];
        return distance(box[i], box[j], scale);
    };
    auto find_nearest = [&](uint32_t i, uint32_t live) {
        float best = INFINITY;
        uint32_t arg = i == 0 ? 1 : 0;
        for (uint32_t j = 0; j < live; ++j) {
            if (j == i) continue;
            const float dij = d(i, j);
            if (dij < best) { best = dij; arg = j; }
        }
        nd[i] = best;
        nn[i] = arg;
    };

    for (uint32_t i = 0; i < count; ++i) box[i] = tree.boxes[ids[i]];
    if (kMatrix) {
        for (uint32_t i = 0; i < count; ++i) {
            dist[size_t(i) * stride + i] = INFINITY;
            for (uint32_t j = i + 1; j < count; ++j) {
                const float dij = distance(box[i], box[j], scale);
                dist[size_t(i) * stride + j] = dij;
                dist[size_t(j) * stride + i] = dij;
            }
        }
    }
    for (uint32_t i = 0; i < count; ++i) find_nearest(i, count);

    uint32_t live = count;
    uint32_t used = 0;
    while (live > target) {
        if ((live & 1023) == 0) ctx.poll();
        uint32_t a = 0;
        for (uint32_t i = 1; i < live; ++i)
            if (nd[i] < nd[a]) a = i;
        uint32_t b = nn[a];
        if (a > b) std::swap(a, b); // the merged cluster takes the lower slot

        const uint32_t node = free_ids[used++];
        const Box merged = unite(box[a], box[b]);
        tree.boxes[node] = merged;
        tree.set_children(node, ids[a], ids[b]);

        // Slot b is freed by moving the last live cluster into it.
        const uint32_t last = live - 1;
        if (b != last) {
            box[b] = box[last];
            ids[b] = ids[last];
            nd[b] = nd[last];
            nn[b] = nn[last];
            if (kMatrix) {
                for (uint32_t j = 0; j < live; ++j) {
                    dist[size_t(b) * stride + j] = dist[size_t(last) * stride + j];
                    dist[size_t(j) * stride + b] = dist[size_t(j) * stride + last];
                }
                dist[size_t(b) * stride + b] = INFINITY;
            }
        }
        live = last;
        box[a] = merged;
        ids[a] = node;
        if (kMatrix) {
            for (uint32_t j = 0; j < live; ++j) {
                const float daj = j == a ? INFINITY : distance(merged, box[j], scale);
                dist[size_t(a) * stride + j] = daj;
                dist[size_t(j) * stride + a] = daj;
            }
        }

        // Clusters whose nearest neighbour was merged look again; the others
        // only compare with the new cluster.
        for (uint32_t j = 0; j < live; ++j) {
            if (j == a) continue;
            uint32_t &p = nn[j];
            if (p == a || p == b) {
                find_nearest(j, live);
                continue;
            }
            if (p == last) p = b; // its partner moved slots
            const float daj = d(j, a);
            if (daj < nd[j] || (daj == nd[j] && a < p)) { nd[j] = daj; p = a; }
        }
        find_nearest(a, live);
    }

    // Unused ids move to the front of free_ids for the caller.
    for (uint32_t i = 0; i < live; ++i) free_ids[i] = free_ids[used + i];
    return live;
}

} // namespace

uint32_t combine_clusters(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                          float scale, CombineScratch &scratch, BuildContext &ctx) {
    if (target < 1) target = 1;
    if (count <= target) return count;
    if (scratch.boxes.size() < count) {
        scratch.boxes.resize(count);
        scratch.nearest_distance.resize(count);
        scratch.nearest.resize(count);
    }
    if (count <= kMatrixLimit) {
        if (scratch.distances.size() < size_t(count) * count) scratch.distances.resize(size_t(count) * count);
        return combine<true>(tree, ids, free_ids, count, target, scale, scratch, ctx);
    }
    return combine<false>(tree, ids, free_ids, count, target, scale, scratch, ctx);
}

} // namespace aacbvh
