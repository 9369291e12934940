#include "bvh/bvh_refit.h"

namespace aacbvh {

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
