// aacbvh-batch-threads: how a ray batch scales with the context's threads.
// Each scene's BVH (default parameters) is built on one context per thread
// count; the benchmark's three ray kinds (primary rays through a W x H image,
// shadow and diffuse rays from their hits, as aacbvh-bench makes them) are
// traced as whole batches through aacbvh_bvh_intersect / aacbvh_bvh_occluded,
// and the median Mrays/s of several runs is printed per thread count with the
// speedup over the first count. Every thread count must give exactly the
// first count's answers: the exit status is 1 when one differs (or a call
// fails), else 0. Speed is reported, never asserted. With --embree (when the
// benchmark was compiled with Embree 3), the same rays also go through
// Embree's own scene, one rtcIntersect1 / rtcOccluded1 call a ray on one
// thread, as aacbvh-bench times it: its Mrays/s and ours on the first thread
// count over it, from the same run; scripts/ray_instructions.sh counts both
// kernels' instructions a ray this way.
//
//   aacbvh-batch-threads [--scenes LIST] [--rays N|WxH] [--threads LIST] [--runs N] [--embree]
#include <aacbvh/aacbvh.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cli.h"
#include "embree_bench.h"
#include "rays.h"
#include "scene.h"

#ifndef AACBVH_SCENES_DIR
#define AACBVH_SCENES_DIR ""
#endif

namespace {

using namespace bench;

struct Options {
    std::vector<std::string> scenes;
    uint32_t width = 384, height = 384;
    std::vector<uint32_t> threads;
    int runs = 5;
    bool embree = false;
};

void usage(const char *argv0) {
    std::fprintf(stderr,
                 "usage: %s [--scenes LIST] [--rays N|WxH] [--threads LIST] [--runs N] [--embree]\n"
                 "  --scenes LIST   comma-separated OBJ paths, names of OBJ files in the scenes\n"
                 "                  directory, 'shared' (every *.obj there), 'procedural' or\n"
                 "                  'procedural-small'; default: every *.obj in %s,\n"
                 "                  else 'procedural'\n"
                 "  --rays N|WxH    primary rays: an N x N image or W x H (default 384: 147,456 rays)\n"
                 "  --threads LIST  context thread counts, e.g. 1,2 (default 1 and this machine's\n"
                 "                  hardware threads); speedups are over the first\n"
                 "  --runs N        timed passes per ray kind and thread count (default 5)\n"
                 "  --embree        also trace the rays through Embree 3's scene, one thread\n"
                 "                  (when compiled in): its Mrays/s, and ours over it\n",
                 argv0, AACBVH_SCENES_DIR[0] ? AACBVH_SCENES_DIR : "(none)");
}

bool parse(int argc, char **argv, Options &o) {
    for (int i = 1; i < argc; ++i) {
        const Parsed shared = parse_shared_option(argc, argv, i, o.scenes, o.threads, o.runs);
        if (shared == Parsed::Bad) return false;
        if (shared == Parsed::Taken) continue;
        if (!std::strcmp(argv[i], "--rays") && i + 1 < argc) {
            const std::vector<std::string> wh = split(argv[++i], 'x');
            uint64_t w = 0, h = 0;
            if (wh.empty() || wh.size() > 2 || !parse_uint(wh[0].c_str(), w) ||
                !parse_uint(wh.back().c_str(), h) || w == 0 || h == 0 || w > 16384 || h > 16384)
                return false;
            o.width = uint32_t(w);
            o.height = uint32_t(h);
        } else if (!std::strcmp(argv[i], "--embree")) {
            o.embree = true;
        } else {
            return false;
        }
    }
    if (o.threads.empty()) o.threads = default_thread_counts();
    return true;
}

struct HandleDeleter {
    void operator()(aacbvh_bvh *b) const { aacbvh_bvh_destroy(b); }
};
struct ContextDeleter {
    void operator()(aacbvh_context *c) const { aacbvh_context_destroy(c); }
};
using Handle = std::unique_ptr<aacbvh_bvh, HandleDeleter>;
using Context = std::unique_ptr<aacbvh_context, ContextDeleter>;

/// One ray kind's answers: closest hits, or the occlusion flags.
struct Answers {
    std::vector<aacbvh_hit> hits;
    std::vector<uint8_t> occluded;
    bool operator==(const Answers &o) const {
        if (occluded != o.occluded || hits.size() != o.hits.size()) return false;
        for (size_t i = 0; i < hits.size(); ++i) {
            const aacbvh_hit &a = hits[i], &b = o.hits[i];
            if (a.prim_id != b.prim_id || std::memcmp(&a.t, &b.t, sizeof a.t) != 0 ||
                std::memcmp(&a.u, &b.u, sizeof a.u) != 0 || std::memcmp(&a.v, &b.v, sizeof a.v) != 0)
                return false;
        }
        return true;
    }
};

/// Traces `rays` of `kind` once into `out`; false when the call fails.
bool trace(aacbvh_bvh *bvh, int kind, const std::vector<aacbvh_ray> &rays, Answers &out) {
    if (kind == kShadow) {
        out.occluded.resize(rays.size());
        return aacbvh_bvh_occluded(bvh, rays.data(), out.occluded.data(), rays.size()) == AACBVH_OK;
    }
    out.hits.resize(rays.size());
    return aacbvh_bvh_intersect(bvh, rays.data(), out.hits.data(), rays.size()) == AACBVH_OK;
}

/// Runs one scene; returns false when a call failed or answers differed.
bool run_scene(const Scene &scene, const Options &opt) {
    const Bounds bounds = vertex_bounds(scene.vertices);
    const Camera camera = camera_for_scene(scene.name, bounds);
    std::vector<aacbvh_ray> rays[kRayKindCount];
    rays[kPrimary] = make_primary_rays(camera, opt.width, opt.height);

    std::vector<Context> contexts;
    std::vector<Handle> handles;
    for (uint32_t t : opt.threads) {
        aacbvh_context *c = nullptr;
        aacbvh_bvh *b = nullptr;
        if (aacbvh_context_create(t, &c) != AACBVH_OK) {
            std::fprintf(stderr, "%s: cannot create a context of %u threads\n", scene.name.c_str(), t);
            return false;
        }
        contexts.emplace_back(c);
        if (aacbvh_bvh_create(c, &b) != AACBVH_OK) return false;
        handles.emplace_back(b);
        if (aacbvh_bvh_set_triangles(b, scene.vertices.data(), scene.vertex_count(), 12, scene.indices.data(),
                                     scene.triangle_count()) != AACBVH_OK ||
            aacbvh_bvh_build(b) != AACBVH_OK) {
            std::fprintf(stderr, "%s: build failed: %s\n", scene.name.c_str(), aacbvh_bvh_last_error(b));
            return false;
        }
    }
    // The secondary rays from the first context's primary hits.
    Answers primary;
    if (!trace(handles[0].get(), kPrimary, rays[kPrimary], primary)) return false;
    make_secondary_rays(rays[kPrimary], primary.hits, scene.vertices, scene.indices, camera, bounds.diagonal(),
                        0x5EED, rays[kShadow], rays[kDiffuse]);

    // Embree's scene on the same rays (one thread, single-ray calls).
    double embree_mrays[kRayKindCount] = {};
    bool with_embree = false;
    if (opt.embree && embree_compiled()) {
        RaySets sets;
        sets.width = opt.width;
        sets.height = opt.height;
        for (int kind = 0; kind < kRayKindCount; ++kind) sets.rays[kind] = rays[kind];
        std::vector<double> build_seconds;
        uint64_t embree_hits[kRayKindCount] = {};
        double embree_bytes = 0.0;
        std::string err;
        with_embree = embree_scene_bench(scene.vertices, scene.indices, 1, opt.runs, &sets, build_seconds,
                                         embree_mrays, embree_hits, embree_bytes, err);
        if (!with_embree) std::fprintf(stderr, "%s: Embree: %s\n", scene.name.c_str(), err.c_str());
    }

    bool ok = true;
    for (int kind = 0; kind < kRayKindCount; ++kind) {
        std::printf("%-18s %-8s %8zu", scene.name.c_str(), ray_kind_name(kind), rays[kind].size());
        Answers first;
        double first_mrays = 0.0;
        for (size_t ti = 0; ti < handles.size(); ++ti) {
            Answers answers;
            // One untimed pass: the answers, and warm caches.
            if (!trace(handles[ti].get(), kind, rays[kind], answers)) {
                std::printf("  call failed: %s\n", aacbvh_bvh_last_error(handles[ti].get()));
                return false;
            }
            // The timed passes write into answers of the right size already,
            // so no allocation is timed.
            Answers scratch = answers;
            std::vector<double> seconds;
            for (int r = 0; r < opt.runs; ++r) {
                const auto t0 = std::chrono::steady_clock::now();
                const bool traced = trace(handles[ti].get(), kind, rays[kind], scratch);
                seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
                ok = ok && traced;
            }
            std::sort(seconds.begin(), seconds.end());
            const double med = seconds[seconds.size() / 2];
            const double mrays = med > 0.0 ? rays[kind].size() * 1e-6 / med : 0.0;
            if (ti == 0) {
                first = std::move(answers);
                first_mrays = mrays;
                std::printf("  %8.2f", mrays);
            } else {
                const bool same = answers == first;
                ok = ok && same;
                std::printf("  %8.2f (%.2fx)%s", mrays, first_mrays > 0.0 ? mrays / first_mrays : 0.0,
                            same ? "" : " ANSWERS DIFFER");
            }
        }
        if (with_embree)
            std::printf("  %8.2f (%.2fx)", embree_mrays[kind],
                        embree_mrays[kind] > 0.0 ? first_mrays / embree_mrays[kind] : 0.0);
        std::printf("\n");
    }
    return ok;
}

}  // namespace

int main(int argc, char **argv) {
    Options opt;
    if (!parse(argc, argv, opt)) {
        usage(argv[0]);
        return 2;
    }

    print_machine_line("aacbvh-batch-threads");
    std::printf("whole batches, default parameters, median of %d runs; Mrays/s per thread count "
                "(speedup over %u thread%s)\n",
                opt.runs, opt.threads[0], opt.threads[0] == 1 ? "" : "s");
    std::printf("%-18s %-8s %8s", "scene", "rays", "count");
    for (uint32_t t : opt.threads) std::printf("  %5u thr", t);
    if (opt.embree) {
        if (embree_compiled())
            std::printf("  Embree %s, 1 thr (ours, %u thr, over it)", embree_version().c_str(), opt.threads[0]);
        else
            std::printf("  (Embree: not compiled in)");
    }
    std::printf("\n");
    const bool ok = for_each_scene(opt.scenes, AACBVH_SCENES_DIR, "aacbvh-batch-threads",
                                   [&](const Scene &scene) { return run_scene(scene, opt); });
    return ok ? 0 : 1;
}
