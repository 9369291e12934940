// Embree 3 beside libaacbvh in the same run (optional: compiled in when CMake
// found <embree3/rtcore.h> and defined AACBVH_BENCH_HAVE_EMBREE; otherwise every
// call reports that Embree is not available).
//
// Two comparisons:
//   - rtcBuildBVH, Embree's generic BVH builder, at RTC_BUILD_QUALITY_LOW
//     (Morton) and RTC_BUILD_QUALITY_MEDIUM (binned SAH), binary, leaves of at
//     most the same size as ours; its tree is converted to the aacbvh_node layout
//     so SAH and ray cost come from the same code as ours;
//   - Embree's own scene (rtcNewScene + a triangle geometry on shared buffers +
//     rtcCommitScene, default flags) and rtcIntersect1 / rtcOccluded1 throughput.
#pragma once

#include "ray_cost.h"
#include "rays.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace bench {

/// True when the benchmark was compiled with Embree.
bool embree_compiled();
/// "3.13.5" or "not compiled in".
std::string embree_version();

enum class EmbreeQuality { kLow, kMedium };

/// Builds a binary BVH with rtcBuildBVH `runs` times on a device of `threads`
/// threads ("threads=N"), timing rtcBuildBVH alone (seconds per run appended to
/// `seconds`). The last run's tree is converted into *tree when tree is not NULL.
/// With reuse_bvh, every run rebuilds into one RTCBVH, which keeps its memory
/// between builds (our --keep-build-memory counterpart).
/// Returns false with a message on failure.
bool embree_build_bvh(const std::vector<float> &vertices, const std::vector<uint32_t> &indices,
                      EmbreeQuality quality, uint32_t threads, int runs, uint32_t max_leaf_size, bool reuse_bvh,
                      std::vector<double> &seconds, FlatTree *tree, std::string &err);

/// One pass of our own traversal over a ray kind's set, for a head-to-head:
/// returns the seconds it took, or a negative number when the call failed.
using OurPass = std::function<double(int kind)>;

/// Embree's own acceleration structure: builds the scene `runs` times on a device
/// of `threads` threads (seconds per run appended to `seconds`). When rays is not
/// NULL, then times rtcIntersect1 (primary, diffuse) and rtcOccluded1 (shadow)
/// over the ray sets, `runs` times each, and stores the median Mrays/s per kind
/// and the hits per kind (closest hits, occluded shadow rays).
///
/// With `ours` (and rays), each of Embree's timed passes is followed by one
/// of ours over the same rays, after one such round that is not counted, and
/// head_to_head[kind] is the median over the `runs` rounds of Embree's time
/// over ours (above 1: we trace faster), NaN where one of our passes failed:
/// a ratio of two passes taken a moment apart, which the machine's drift
/// between sittings (a tenth on a shared VM) moves far less than a ratio of
/// medians taken minutes apart.
bool embree_scene_bench(const std::vector<float> &vertices, const std::vector<uint32_t> &indices,
                        uint32_t threads, int runs, const RaySets *rays, std::vector<double> &seconds,
                        double mrays[kRayKindCount], uint64_t hits[kRayKindCount], double &scene_bytes,
                        std::string &err, const OurPass *ours = nullptr,
                        double head_to_head[kRayKindCount] = nullptr);

}  // namespace bench
