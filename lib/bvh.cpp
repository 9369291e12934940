#include "bvh.h"

#include <algorithm>
#include <utility>

namespace aacbvh {

TreeFigures measure_tree(const Bvh &bvh, double traversal_cost, double intersection_cost) {
    TreeFigures f;
    if (bvh.empty()) return f;
    double inner_area = 0.0, leaf_cost = 0.0;
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}}; // node, depth
    while (!stack.empty()) {
        const auto [i, depth] = stack.back();
        stack.pop_back();
        const Node &node = bvh.nodes[i];
        if (node.is_leaf()) {
            ++f.leaf_count;
            f.max_depth = std::max(f.max_depth, depth);
            leaf_cost += node.box.area() * node.count;
        } else {
            inner_area += node.box.area();
            stack.push_back({node.first, depth + 1});
            stack.push_back({node.first + 1, depth + 1});
        }
    }
    const double root_area = bvh.nodes[0].box.area();
    f.sah_cost = root_area > 0.0 ? (traversal_cost * inner_area + intersection_cost * leaf_cost) / root_area : 0.0;
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
