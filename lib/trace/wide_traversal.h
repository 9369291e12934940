// Ray queries over the 4-wide layout (bvh/wide_bvh.h).
#pragma once

#include "aacbvh/aacbvh.h"
#include "bvh/bvh.h"
#include "bvh/wide_bvh.h"
#include "core/geometry.h"
#include "trace/traversal.h"

namespace aacbvh {

/// Closest hit of one ray through the wide tree of `bvh` (same results as
/// intersect_ray() on the binary tree: same t, u, v; prim_id may differ only
/// between hits at exactly the same t). `triangles` as for intersect_ray();
/// counters, when not NULL, get the primitive tests added (nodes are not
/// counted).
void intersect_ray_wide(const WideBvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                        aacbvh_hit &hit, const float *triangles = nullptr, TraversalCounters *counters = nullptr);
/// Any hit of one ray through the wide tree (same results as occluded_ray()).
bool occluded_ray_wide(const WideBvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                       const float *triangles = nullptr);

} // namespace aacbvh
