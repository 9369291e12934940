// Ray queries over a finished Bvh: closest hit and any hit, on triangles
// (watertight test) or boxes (robust slab test).
#pragma once

#include <cstddef>
#include <cstdint>

#include "aacbvh/aacbvh.h"
#include "bvh/bvh.h"
#include "core/geometry.h"

namespace aacbvh {

/// Work one query did: inner and leaf nodes visited, primitive tests made.
struct TraversalCounters {
    uint64_t nodes_visited = 0;
    uint64_t primitive_tests = 0;
};

/// Closest hit of one ray; counters may be NULL. `triangles`, when not NULL,
/// is the BVH's copy of triangle geometry (9 floats per leaf slot, in
/// Bvh::prim_ids order) and is read instead of the caller's buffers, with the
/// same results.
void intersect_ray(const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray, aacbvh_hit &hit,
                   TraversalCounters *counters = nullptr, const float *triangles = nullptr);
/// Any hit of one ray: true if something lies in [tmin, tmax]; counters and
/// triangles as for intersect_ray().
bool occluded_ray(const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                  TraversalCounters *counters = nullptr, const float *triangles = nullptr);

} // namespace aacbvh
