#include "bvh.h"

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

void refit_tree(Bvh &bvh, const Geometry &geometry, Scheduler &scheduler) {
    // Leaves read the geometry: that is the expensive part, and independent.
    scheduler.parallel_for(0, bvh.nodes.size(), 1u << 13, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            Node &node = bvh.nodes[i];
            if (!node.is_leaf()) continue;
            Box box = Box::empty();
            for (uint32_t k = 0; k < node.count; ++k) box.extend(geometry.primitive_box(bvh.prim_ids[node.first + k]));
            node.box = box;
        }
    });
    // Children always sit after their parent, so a reverse sweep is bottom-up.
    for (size_t i = bvh.nodes.size(); i-- > 0;) {
        Node &node = bvh.nodes[i];
        if (!node.is_leaf()) node.box = unite(bvh.nodes[node.first].box, bvh.nodes[node.first + 1].box);
    }
}

} // namespace aacbvh
