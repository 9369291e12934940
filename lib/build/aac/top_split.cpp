#include "build/aac/top_split.h"

#include <algorithm>
#include <vector>

namespace aacbvh {

namespace {

void sort_on(const BinaryTree &tree, uint32_t *ids, uint32_t count, int axis) {
    std::sort(ids, ids + count, [&](uint32_t x, uint32_t y) {
        const float cx = tree.boxes[x].centroid(axis), cy = tree.boxes[y].centroid(axis);
        return cx < cy || (cx == cy && x < y);
    });
}

} // namespace

uint32_t sah_partition(const BinaryTree &tree, ChoiceTable choices, uint32_t *ids, uint32_t count) {
    if (count < 2) return count;
    const uint32_t n = tree.leaf_count();
    auto prims = [&](uint32_t id) { return id < n ? 1.0 : double(choices.prims(id - n)); };
    // Areas on extents scaled to the clusters' union (core/box.h): unscaled,
    // those of a scene with coordinates near 1e20 overflowed single precision.
    Box all = Box::empty();
    for (uint32_t i = 0; i < count; ++i) all.extend(tree.boxes[ids[i]]);
    const float scale = extent_scale_of(all);
    std::vector<double> right_cost(count);
    double best_cost = 0.0;
    int best_axis = -1;
    uint32_t best_split = count / 2;
    for (int axis = 0; axis < 3; ++axis) {
        sort_on(tree, ids, count, axis);
        // Costs of every right part, then one sweep of the left parts.
        Box acc = Box::empty();
        double acc_prims = 0.0;
        for (uint32_t i = count; i-- > 1;) {
            acc.extend(tree.boxes[ids[i]]);
            acc_prims += prims(ids[i]);
            right_cost[i] = double(scaled_half_area(acc, scale)) * acc_prims;
        }
        acc = Box::empty();
        acc_prims = 0.0;
        for (uint32_t i = 0; i + 1 < count; ++i) {
            acc.extend(tree.boxes[ids[i]]);
            acc_prims += prims(ids[i]);
            const double cost = double(scaled_half_area(acc, scale)) * acc_prims + right_cost[i + 1];
            if (best_axis < 0 || cost < best_cost) {
                best_cost = cost;
                best_axis = axis;
                best_split = i + 1;
            }
        }
    }
    if (best_axis != 2) sort_on(tree, ids, count, best_axis);
    return best_split;
}

} // namespace aacbvh
