// Ray queries over a finished Bvh: closest hit and any hit, on triangles
// (watertight test) or boxes (robust slab test).
#pragma once

#include <cstddef>
#include <cstdint>

#include "aacbvh/aacbvh.h"
#include "bvh.h"
#include "geometry.h"

namespace aacbvh {

/// Work one query did: inner and leaf nodes visited, primitive tests made.
struct TraversalCounters {
    uint64_t nodes_visited = 0;
    uint64_t primitive_tests = 0;
};

/// Closest hit of one ray; counters may be NULL.
void intersect_ray(const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray, aacbvh_hit &hit,
                   TraversalCounters *counters = nullptr);
/// Any hit of one ray: true if something lies in [tmin, tmax]; counters may be NULL.
bool occluded_ray(const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                  TraversalCounters *counters = nullptr);

} // namespace aacbvh
