// The benchmark's ray sets: primary rays from a per-scene camera, shadow rays
// from the primary hits to a point light, and diffuse bounce rays from the
// primary hits (the three kinds of Gu et al., HPG 2013, sec. 5).
#pragma once

#include <aacbvh/aacbvh.h>

#include <cstdint>
#include <string>
#include <vector>

namespace bench {

/// A pinhole camera and a point light, in scene coordinates.
struct Camera {
    float eye[3];
    float target[3];
    float up[3];
    float fov_y_degrees;
    float light[3];
    std::string source;  ///< "table" (a known scene) or "bounds" (the fallback)
};

/// Axis-aligned bounds of a vertex array (x, y, z per vertex).
struct Bounds {
    float lower[3];
    float upper[3];
    float diagonal() const;
};
Bounds vertex_bounds(const std::vector<float> &xyz);

/// The camera for a scene: from a table of the known scenes (cameras inside the
/// interiors of sponza, conference, sibenik and stk_temple; the scans seen from
/// outside), else one placed from the bounds, looking at the centre from outside.
Camera camera_for_scene(const std::string &scene_name, const Bounds &bounds);

/// The three ray kinds, in the order reported everywhere.
enum RayKind { kPrimary = 0, kShadow = 1, kDiffuse = 2, kRayKindCount = 3 };
const char *ray_kind_name(int kind);  ///< "primary", "shadow", "diffuse"

struct RaySets {
    uint32_t width = 0, height = 0;     ///< image of the primary rays
    std::vector<aacbvh_ray> rays[kRayKindCount];
    uint64_t primary_hits = 0;
};

/// Primary rays through the pixel centres of a width x height image.
std::vector<aacbvh_ray> make_primary_rays(const Camera &camera, uint32_t width, uint32_t height);

/// From the closest hits of the primary rays (hits[i] for primary[i]) makes one
/// shadow ray per hit whose surface faces the light (any hit, tmax just short of
/// the light) and one diffuse ray per hit (cosine-weighted around the geometric
/// normal turned toward the viewer, fixed seed). Origins are pushed off the surface
/// by a small fraction of the scene diagonal.
void make_secondary_rays(const std::vector<aacbvh_ray> &primary, const std::vector<aacbvh_hit> &hits,
                         const std::vector<float> &vertices, const std::vector<uint32_t> &indices,
                         const Camera &camera, float scene_diagonal, uint64_t seed,
                         std::vector<aacbvh_ray> &shadow, std::vector<aacbvh_ray> &diffuse);

/// In-scene views (issue 17: rays that start inside the scene): `count`
/// cameras standing on the scene's surfaces. Each picks a triangle with
/// probability proportional to its area and a uniform point on it, stands
/// `1e-3 * scene_diagonal` off it along the triangle's normal (the side its
/// winding faces) and looks in a direction uniform over the hemisphere around
/// that normal (so away from the surface it stands on), 60 degree field of
/// view, the light at `light`. Fixed by the seed: every builder and every run
/// sees the same views. Empty when the scene has no triangle of non-zero area.
std::vector<Camera> make_views(const std::vector<float> &vertices, const std::vector<uint32_t> &indices,
                               uint32_t count, const float light[3], float scene_diagonal, uint64_t seed);

}  // namespace bench
