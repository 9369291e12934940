// Our rays as Embree 3's: the one conversion both benchmark programs use
// (include only where AACBVH_BENCH_HAVE_EMBREE, after <embree3/rtcore.h>).
#pragma once

#include <aacbvh/aacbvh.h>
#include <embree3/rtcore.h>

namespace bench {

inline RTCRay embree_ray(const aacbvh_ray &r) {
    RTCRay ray;
    ray.org_x = r.org[0];
    ray.org_y = r.org[1];
    ray.org_z = r.org[2];
    ray.dir_x = r.dir[0];
    ray.dir_y = r.dir[1];
    ray.dir_z = r.dir[2];
    ray.tnear = r.tmin;
    ray.tfar = r.tmax;
    ray.time = 0.0f;
    ray.mask = 0xFFFFFFFFu;
    ray.id = 0;
    ray.flags = 0;
    return ray;
}

/// A ray for rtcIntersect1, with the hit marked "none".
inline RTCRayHit embree_ray_hit(const aacbvh_ray &r) {
    RTCRayHit rh;
    rh.ray = embree_ray(r);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

} // namespace bench
