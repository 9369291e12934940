#include "rays.h"
#include "random.h"
#include "scene.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace bench {

namespace {

struct Vec {
    float x, y, z;
};
Vec make(const float *p) { return {p[0], p[1], p[2]}; }
Vec operator+(Vec a, Vec b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec operator-(Vec a, Vec b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec operator*(Vec a, float s) { return {a.x * s, a.y * s, a.z * s}; }
float dot(Vec a, Vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec cross(Vec a, Vec b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
Vec normalize(Vec a) {
    const float len = std::sqrt(dot(a, a));
    return len > 0.0f ? a * (1.0f / len) : Vec{0.0f, 0.0f, 0.0f};
}

/// A camera of the table: eye, target, light as fractions of the scene bounds
/// (0 = lower, 1 = upper on each axis), so the table survives rescaled copies.
struct TableEntry {
    const char *name;
    float eye[3], target[3], light[3];
    float fov_y_degrees;
};

// Picked by looking at the scene bounds and rendered previews (y is up in all of them).
const TableEntry kTable[] = {
    // Atrium: from one end of the ground-floor nave toward the other, light high in the atrium.
    {"sponza_dabrovic", {0.08f, 0.22f, 0.50f}, {0.90f, 0.30f, 0.50f}, {0.50f, 0.80f, 0.50f}, 60.0f},
    // Room: from near one wall across the table, light under the ceiling.
    {"conference", {0.85f, 0.50f, 0.75f}, {0.30f, 0.20f, 0.30f}, {0.60f, 0.85f, 0.50f}, 60.0f},
    // Nave: from the entrance end toward the altar, light in the upper nave.
    {"sibenik", {0.06f, 0.30f, 0.50f}, {0.80f, 0.32f, 0.50f}, {0.50f, 0.75f, 0.50f}, 60.0f},
    // Along the track between the temple's walls and foliage, a little above the ground.
    {"stk_temple", {0.50f, 0.25f, 0.70f}, {0.50f, 0.22f, 0.30f}, {0.40f, 0.95f, 0.50f}, 65.0f},
    // Scans, from the front (+z) and a little above.
    {"bunny", {0.50f, 0.80f, 3.20f}, {0.50f, 0.45f, 0.50f}, {1.50f, 2.50f, 2.50f}, 40.0f},
    {"bunny_npm_lowres", {0.50f, 0.80f, 3.20f}, {0.50f, 0.45f, 0.50f}, {1.50f, 2.50f, 2.50f}, 40.0f},
    {"dragon_vrip", {0.50f, 0.80f, 3.80f}, {0.50f, 0.45f, 0.50f}, {1.50f, 2.50f, 2.50f}, 40.0f},
};

void from_bounds(const Bounds &b, const float frac[3], float out[3]) {
    for (int k = 0; k < 3; ++k) out[k] = b.lower[k] + frac[k] * (b.upper[k] - b.lower[k]);
}

}  // namespace

float Bounds::diagonal() const {
    const float dx = upper[0] - lower[0], dy = upper[1] - lower[1], dz = upper[2] - lower[2];
    return std::sqrt(dx * dx + dy * dy + dz * dz);
}

Bounds vertex_bounds(const std::vector<float> &xyz) {
    Bounds b;
    scene_bounds(xyz.data(), xyz.size() / 3, b.lower, b.upper);
    return b;
}

Camera camera_for_scene(const std::string &scene_name, const Bounds &bounds) {
    Camera cam;
    cam.up[0] = 0.0f;
    cam.up[1] = 1.0f;
    cam.up[2] = 0.0f;
    for (const TableEntry &e : kTable) {
        if (scene_name == e.name) {
            from_bounds(bounds, e.eye, cam.eye);
            from_bounds(bounds, e.target, cam.target);
            from_bounds(bounds, e.light, cam.light);
            cam.fov_y_degrees = e.fov_y_degrees;
            cam.source = "table";
            return cam;
        }
    }
    // Unknown scene: from outside, above and in front (+z) of the centre at a
    // distance set by the diagonal, so flat and tall scenes both fill the view.
    const float d = 1.1f * bounds.diagonal();
    const float dir[3] = {0.33f, 0.52f, 0.79f}, to_light[3] = {-0.5f, 0.8f, 0.33f};
    for (int k = 0; k < 3; ++k) {
        cam.target[k] = 0.5f * (bounds.lower[k] + bounds.upper[k]);
        cam.eye[k] = cam.target[k] + d * dir[k];
        cam.light[k] = cam.target[k] + d * to_light[k];
    }
    cam.fov_y_degrees = 45.0f;
    cam.source = "bounds";
    return cam;
}

const char *ray_kind_name(int kind) {
    switch (kind) {
    case kPrimary: return "primary";
    case kShadow: return "shadow";
    case kDiffuse: return "diffuse";
    default: return "?";
    }
}

std::vector<aacbvh_ray> make_primary_rays(const Camera &camera, uint32_t width, uint32_t height) {
    const Vec eye = make(camera.eye);
    const Vec forward = normalize(make(camera.target) - eye);
    Vec right = normalize(cross(forward, make(camera.up)));
    if (dot(right, right) == 0.0f) right = {1.0f, 0.0f, 0.0f};  // looking straight along up
    const Vec up = cross(right, forward);
    const float half_h = std::tan(0.5f * camera.fov_y_degrees * 3.14159265f / 180.0f);
    const float half_w = half_h * float(width) / float(height);

    std::vector<aacbvh_ray> rays(size_t(width) * height);
    for (uint32_t y = 0; y < height; ++y) {
        for (uint32_t x = 0; x < width; ++x) {
            const float sx = (2.0f * (x + 0.5f) / width - 1.0f) * half_w;
            const float sy = (1.0f - 2.0f * (y + 0.5f) / height) * half_h;
            const Vec d = normalize(forward + right * sx + up * sy);
            aacbvh_ray &r = rays[size_t(y) * width + x];
            r.org[0] = eye.x;
            r.org[1] = eye.y;
            r.org[2] = eye.z;
            r.dir[0] = d.x;
            r.dir[1] = d.y;
            r.dir[2] = d.z;
            r.tmin = 0.0f;
            r.tmax = std::numeric_limits<float>::infinity();
        }
    }
    return rays;
}

void make_secondary_rays(const std::vector<aacbvh_ray> &primary, const std::vector<aacbvh_hit> &hits,
                         const std::vector<float> &vertices, const std::vector<uint32_t> &indices,
                         const Camera &camera, float scene_diagonal, uint64_t seed,
                         std::vector<aacbvh_ray> &shadow, std::vector<aacbvh_ray> &diffuse) {
    shadow.clear();
    diffuse.clear();
    SplitMix64 rng(seed);
    const float offset = 1e-5f * scene_diagonal;
    const Vec light = make(camera.light);
    for (size_t i = 0; i < primary.size(); ++i) {
        const aacbvh_hit &h = hits[i];
        if (h.prim_id == AACBVH_INVALID_ID) continue;
        const aacbvh_ray &pr = primary[i];
        const Vec dir = make(pr.dir);
        const Vec p = make(pr.org) + dir * h.t;
        const uint32_t *tri = &indices[3 * size_t(h.prim_id)];
        const Vec a = make(&vertices[3 * size_t(tri[0])]);
        const Vec b = make(&vertices[3 * size_t(tri[1])]);
        const Vec c = make(&vertices[3 * size_t(tri[2])]);
        Vec n = normalize(cross(b - a, c - a));
        if (dot(n, n) == 0.0f) continue;  // a zero-area triangle: no normal to bounce around
        if (dot(n, dir) > 0.0f) n = n * -1.0f;  // toward the side the ray came from
        const Vec o = p + n * offset;

        const Vec to_light = light - o;
        if (dot(to_light, n) > 0.0f) {
            aacbvh_ray s;
            s.org[0] = o.x; s.org[1] = o.y; s.org[2] = o.z;
            s.dir[0] = to_light.x; s.dir[1] = to_light.y; s.dir[2] = to_light.z;
            s.tmin = 0.0f;
            s.tmax = 0.9999f;  // just short of the light (t is in units of dir)
            shadow.push_back(s);
        }

        // Cosine-weighted direction around n (Malley's method).
        const float u1 = rng.uniform_float(), u2 = rng.uniform_float();
        const float r = std::sqrt(u1), phi = 2.0f * 3.14159265f * u2;
        const Vec t0 = normalize(std::fabs(n.x) > 0.5f ? cross(n, Vec{0, 1, 0}) : cross(n, Vec{1, 0, 0}));
        const Vec t1 = cross(n, t0);
        const Vec d = normalize(t0 * (r * std::cos(phi)) + t1 * (r * std::sin(phi)) +
                                n * std::sqrt(std::max(0.0f, 1.0f - u1)));
        aacbvh_ray dr;
        dr.org[0] = o.x; dr.org[1] = o.y; dr.org[2] = o.z;
        dr.dir[0] = d.x; dr.dir[1] = d.y; dr.dir[2] = d.z;
        dr.tmin = 0.0f;
        dr.tmax = std::numeric_limits<float>::infinity();
        diffuse.push_back(dr);
    }
}

std::vector<Camera> make_views(const std::vector<float> &vertices, const std::vector<uint32_t> &indices,
                               uint32_t count, const float light[3], float scene_diagonal, uint64_t seed) {
    std::vector<Camera> views;
    const size_t triangles = indices.size() / 3;
    // Running sums of the triangles' areas (doubled), in double so that large
    // scenes do not lose their small triangles to rounding.
    std::vector<double> cumulative(triangles);
    double total = 0.0;
    auto corners = [&](size_t t, Vec &a, Vec &b, Vec &c) {
        a = make(&vertices[3 * size_t(indices[3 * t])]);
        b = make(&vertices[3 * size_t(indices[3 * t + 1])]);
        c = make(&vertices[3 * size_t(indices[3 * t + 2])]);
    };
    for (size_t t = 0; t < triangles; ++t) {
        Vec a, b, c;
        corners(t, a, b, c);
        const Vec n = cross(b - a, c - a);
        const double area = std::sqrt(double(dot(n, n)));
        total += std::isfinite(area) ? area : 0.0;
        cumulative[t] = total;
    }
    if (!(total > 0.0)) return views;
    SplitMix64 rng(seed);
    const float offset = 1e-3f * scene_diagonal;
    // Bounded: a triangle of positive area whose normal still rounds to zero in
    // float is tried again, but never forever.
    for (uint64_t attempt = 0; views.size() < count && attempt < 100 * uint64_t(count); ++attempt) {
        const double pick = rng.uniform() * total;
        const size_t t = size_t(std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin());
        if (t >= triangles) continue;
        Vec a, b, c;
        corners(t, a, b, c);
        const Vec n = normalize(cross(b - a, c - a));
        if (dot(n, n) == 0.0f) continue;
        // A uniform point on the triangle: fold the unit square's upper half back.
        float u = rng.uniform_float(), v = rng.uniform_float();
        if (u + v > 1.0f) {
            u = 1.0f - u;
            v = 1.0f - v;
        }
        const Vec eye = a + (b - a) * u + (c - a) * v + n * offset;
        float d[3];
        rng.direction(d);
        Vec dir = make(d);
        if (dot(dir, n) < 0.0f) dir = dir * -1.0f;  // into the hemisphere the normal faces
        Camera cam;
        cam.eye[0] = eye.x; cam.eye[1] = eye.y; cam.eye[2] = eye.z;
        cam.target[0] = eye.x + dir.x; cam.target[1] = eye.y + dir.y; cam.target[2] = eye.z + dir.z;
        cam.up[0] = 0.0f; cam.up[1] = 1.0f; cam.up[2] = 0.0f;
        cam.fov_y_degrees = 60.0f;
        for (int k = 0; k < 3; ++k) cam.light[k] = light[k];
        cam.source = "view";
        views.push_back(cam);
    }
    return views;
}

}  // namespace bench
