// Figures of a finished tree: SAH area sums, leaf count, depth.
#pragma once

#include <cstdint>

#include "bvh/bvh.h"
#include "core/scheduler.h"

namespace aacbvh {

/// The area sums of the SAH cost, kept apart so that the cost can be given for
/// whatever Ct and Ci are in force: (Ct * inner_area + Ci * leaf_area_prims) / root_area.
struct AreaSums {
    double inner_area = 0.0;      ///< sum of inner nodes' surface areas
    double leaf_area_prims = 0.0; ///< sum of leaves' surface area times primitive count
    double root_area = 0.0;

    double sah_cost(double traversal_cost, double intersection_cost) const {
        return root_area > 0.0 ? (traversal_cost * inner_area + intersection_cost * leaf_area_prims) / root_area : 0.0;
    }
};

struct TreeFigures {
    uint64_t leaf_count = 0;
    uint32_t max_depth = 0;
    AreaSums areas;
};

/// The SAH area sums, added up in a fixed order (so the same tree always gives
/// the same bits, whatever the thread count or the caller).
AreaSums sum_areas(const Bvh &bvh, Scheduler &scheduler);

/// Leaf count, depth and SAH area sums of a tree.
TreeFigures measure_tree(const Bvh &bvh, Scheduler &scheduler);

} // namespace aacbvh
