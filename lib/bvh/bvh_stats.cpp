#include "bvh/bvh_stats.h"

#include <algorithm>
#include <utility>

namespace aacbvh {

AreaSums sum_areas(const Bvh &bvh, Scheduler &scheduler) {
    struct Pair {
        double inner = 0.0, leaf = 0.0;
    };
    AreaSums sums;
    if (bvh.empty()) return sums;
    const Pair p = scheduler.parallel_reduce(
        size_t(0), bvh.nodes.size(), size_t(1) << 14, Pair{},
        [&](size_t b, size_t e) {
            Pair s;
            for (size_t i = b; i < e; ++i) {
                const Node &node = bvh.nodes[i];
                if (node.is_leaf())
                    s.leaf += node.box.area() * node.count;
                else
                    s.inner += node.box.area();
            }
            return s;
        },
        [](const Pair &a, const Pair &b) { return Pair{a.inner + b.inner, a.leaf + b.leaf}; });
    sums.inner_area = p.inner;
    sums.leaf_area_prims = p.leaf;
    sums.root_area = bvh.nodes[0].box.area();
    return sums;
}

TreeFigures measure_tree(const Bvh &bvh, Scheduler &scheduler) {
    TreeFigures f;
    if (bvh.empty()) return f;
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}}; // node, depth
    while (!stack.empty()) {
        const auto [i, depth] = stack.back();
        stack.pop_back();
        const Node &node = bvh.nodes[i];
        if (node.is_leaf()) {
            ++f.leaf_count;
            f.max_depth = std::max(f.max_depth, depth);
        } else {
            stack.push_back({node.first, depth + 1});
            stack.push_back({node.first + 1, depth + 1});
        }
    }
    f.areas = sum_areas(bvh, scheduler);
    return f;
}

} // namespace aacbvh
