// Axis-parallel rays against oblique rays: the same origins and count, timed
// through aacbvh_bvh_intersect() on a one-thread context, median of several
// runs, for each traversal layout. Axis-parallel rays have zero direction
// components (infinite reciprocals in the slab test), which must not make
// traversal much slower: the requirement is axis / oblique <= 2.
//
//   aacbvh-ray-directions [--scene FILE.obj] [--rays N] [--runs R]
//
// Without --scene it uses sponza_dabrovic.obj from AACBVH_SCENES_DIR when
// present, else the generated scene of scene.h. Exit status 1 when a layout
// misses the requirement (or fails), else 0.
#include <aacbvh/aacbvh.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "random.h"
#include "scene.h"

#ifndef AACBVH_SCENES_DIR
#define AACBVH_SCENES_DIR ""
#endif

namespace {

constexpr double kMaxRatio = 2.0;

struct Options {
    std::string scene;
    size_t rays = 200000;
    int runs = 5;
};

bool parse(int argc, char **argv, Options &o) {
    for (int i = 1; i < argc; ++i) {
        const bool has_value = i + 1 < argc;
        if (!std::strcmp(argv[i], "--scene") && has_value) {
            o.scene = argv[++i];
        } else if (!std::strcmp(argv[i], "--rays") && has_value) {
            o.rays = std::strtoull(argv[++i], nullptr, 10);
        } else if (!std::strcmp(argv[i], "--runs") && has_value) {
            o.runs = std::atoi(argv[++i]);
        } else {
            std::fprintf(stderr, "usage: %s [--scene FILE.obj] [--rays N] [--runs R]\n", argv[0]);
            return false;
        }
    }
    return o.rays > 0 && o.runs > 0;
}

/// Median wall time in milliseconds of `runs` intersect calls over `rays`.
double median_ms(const aacbvh_bvh *bvh, const std::vector<aacbvh_ray> &rays, std::vector<aacbvh_hit> &hits,
                 int runs, bool &ok) {
    std::vector<double> times;
    for (int r = 0; r < runs; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        ok = ok && aacbvh_bvh_intersect(bvh, rays.data(), hits.data(), rays.size()) == AACBVH_OK;
        const auto t1 = std::chrono::steady_clock::now();
        times.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    }
    std::sort(times.begin(), times.end());
    return times[times.size() / 2];
}

size_t count_hits(const std::vector<aacbvh_hit> &hits) {
    return size_t(std::count_if(hits.begin(), hits.end(), [](const aacbvh_hit &h) { return h.prim_id != AACBVH_INVALID_ID; }));
}

} // namespace

int main(int argc, char **argv) {
    Options opt;
    if (!parse(argc, argv, opt)) return 2;

    Scene scene;
    std::string err;
    if (opt.scene.empty()) {
        const std::string fallback = std::string(AACBVH_SCENES_DIR) + "/sponza_dabrovic.obj";
        if (!load_obj(fallback, scene, err)) scene = make_procedural_scene();
    } else if (!load_obj(opt.scene, scene, err)) {
        std::fprintf(stderr, "%s\n", err.c_str());
        return 2;
    }

    // Origins uniform in the middle 80% of the scene's box; axis-parallel
    // rays cycle through +x, -x, +y, -y, +z, -z (the other components exactly
    // zero); oblique rays take uniform random directions on the sphere.
    float lo[3], hi[3];
    scene_bounds(scene.vertices.data(), scene.vertex_count(), lo, hi);
    SplitMix64 random(7);
    std::vector<aacbvh_ray> axis_rays(opt.rays), oblique_rays(opt.rays);
    for (size_t i = 0; i < opt.rays; ++i) {
        aacbvh_ray &a = axis_rays[i];
        aacbvh_ray &o = oblique_rays[i];
        for (int k = 0; k < 3; ++k)
            a.org[k] = o.org[k] = lo[k] + (hi[k] - lo[k]) * (0.1f + 0.8f * random.uniform_float());
        a.tmin = o.tmin = 0.0f;
        a.tmax = o.tmax = INFINITY;
        a.dir[0] = a.dir[1] = a.dir[2] = 0.0f;
        a.dir[(i / 2) % 3] = (i % 2) ? -1.0f : 1.0f;
        random.direction(o.dir);
    }

    aacbvh_context *ctx = nullptr;
    if (aacbvh_context_create(1, &ctx) != AACBVH_OK) return 1;
    std::printf("scene %s: %zu triangles; %zu rays per set, median of %d runs, 1 thread\n", scene.name.c_str(),
                scene.triangle_count(), opt.rays, opt.runs);
    std::printf("%-8s %12s %12s %8s %10s %10s  %s\n", "layout", "axis ms", "oblique ms", "ratio", "axis hits",
                "obl. hits", "(axis / oblique <= 2)");
    int status = 0;
    const struct {
        const char *name;
        aacbvh_layout layout;
    } layouts[] = {{"binary", AACBVH_LAYOUT_BINARY}, {"wide4", AACBVH_LAYOUT_WIDE4}};
    std::vector<aacbvh_hit> hits(opt.rays);
    for (const auto &l : layouts) {
        aacbvh_bvh *bvh = nullptr;
        bool ok = aacbvh_bvh_create(ctx, &bvh) == AACBVH_OK;
        if (ok && aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, l.layout) != AACBVH_OK) {
            std::printf("%-8s not available: %s\n", l.name, aacbvh_bvh_last_error(bvh));
            aacbvh_bvh_destroy(bvh);
            continue;
        }
        ok = ok && aacbvh_bvh_set_triangles(bvh, scene.vertices.data(), scene.vertex_count(), 12,
                                            scene.indices.data(), scene.triangle_count()) == AACBVH_OK;
        ok = ok && aacbvh_bvh_build(bvh) == AACBVH_OK;
        if (!ok) {
            std::printf("%-8s failed: %s\n", l.name, aacbvh_bvh_last_error(bvh));
            aacbvh_bvh_destroy(bvh);
            status = 1;
            continue;
        }
        // One untimed pass of each set first warms the caches.
        median_ms(bvh, axis_rays, hits, 1, ok);
        const double axis_ms = median_ms(bvh, axis_rays, hits, opt.runs, ok);
        const size_t axis_hits = count_hits(hits);
        median_ms(bvh, oblique_rays, hits, 1, ok);
        const double oblique_ms = median_ms(bvh, oblique_rays, hits, opt.runs, ok);
        const size_t oblique_hits = count_hits(hits);
        const double ratio = axis_ms / oblique_ms;
        const bool pass = ok && ratio <= kMaxRatio;
        std::printf("%-8s %12.2f %12.2f %8.3f %10zu %10zu  %s\n", l.name, axis_ms, oblique_ms, ratio, axis_hits,
                    oblique_hits, pass ? "ok" : "FAIL");
        if (!pass) status = 1;
        aacbvh_bvh_destroy(bvh);
    }
    aacbvh_context_destroy(ctx);
    return status;
}
