// aacbvh-bench: the evaluation of Gu et al. (HPG 2013, sec. 5) on this library.
// For every scene and builder: build time (median, min, max of --runs), SAH cost,
// ray cost (traversal steps + triangle tests per ray, counted by ray_cost.h) of
// primary, shadow and diffuse rays, absolute and relative to full-sweep SAH,
// single-thread Mrays/s of aacbvh_bvh_intersect / aacbvh_bvh_occluded, and bytes
// per triangle; Embree 3 side by side when compiled in. Writes CSV, JSON, an SVG
// plot and a Markdown report on request, or (--replot) writes them again from a
// JSON output without running anything. Uses only the public C API.
//
//   aacbvh-bench [options] [scene.obj ...]      (aacbvh-bench --help)
#include <aacbvh/aacbvh.h>

#include "cli.h"
#include "embree_bench.h"
#include "ray_cost.h"
#include "rays.h"
#include "report.h"
#include "scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#ifndef AACBVH_SCENES_DIR
#define AACBVH_SCENES_DIR ""
#endif

using namespace bench;

namespace {

using Clock = std::chrono::steady_clock;

struct BuilderInfo {
    std::string id;
    std::string label;
    int builder;          ///< an aacbvh_builder, or -1 for the Embree rows
    uint32_t passes = 0;  ///< AACBVH_PARAM_OPTIMIZE_PASSES: "aac-hq+opt2" is AAC-HQ and 2 passes
};

/// Passes of the default "+opt" rows. No pass count meets issue 14's quality
/// target on the scans; 4 gets within 3.5% of full-sweep SAH there and 9-13%
/// below it on the interiors, while each pass costs 1.5 to 2.2 AAC-HQ builds
/// (docs/PERFORMANCE.md, "Optimisation (issue 14)").
constexpr uint32_t kDefaultOptimizePasses = 4;

/// How the reports name a builder: the library's name (aacbvh_builder_name)
/// as the docs write it.
const char *label_of(const std::string &id) {
    static const std::pair<const char *, const char *> labels[] = {
        {"sweep-sah", "Sweep SAH"}, {"binned-sah", "Binned SAH"}, {"locally-ordered", "Locally-ordered"},
        {"ploc", "PLOC"},           {"aac-hq", "AAC-HQ"},         {"aac-fast", "AAC-Fast"},
    };
    for (const auto &l : labels)
        if (id == l.first) return l.second;
    return nullptr;
}

/// Every builder the library offers (aacbvh_builder_name; "aac", which is
/// aac-hq with its parameters unset, left out), reference builders first as
/// the reports list them, then Embree's.
const std::vector<BuilderInfo> &all_builders() {
    static const std::vector<BuilderInfo> all = [] {
        std::vector<BuilderInfo> v;
        for (int b = 0; aacbvh_builder_name(aacbvh_builder(b)); ++b) {
            if (b == AACBVH_BUILDER_AAC) continue;
            const char *id = aacbvh_builder_name(aacbvh_builder(b));
            v.push_back({id, label_of(id) ? label_of(id) : id, b});
        }
        std::stable_partition(v.begin(), v.end(), [](const BuilderInfo &b) { return b.id.compare(0, 3, "aac") != 0; });
        for (const char *id : {"aac-hq", "aac-fast"}) {
            aacbvh_builder b;
            if (aacbvh_builder_from_name(id, &b) != AACBVH_OK) continue;
            const std::string n = std::to_string(kDefaultOptimizePasses);
            v.push_back({std::string(id) + "+opt" + n, std::string(label_of(id)) + " + opt" + n, int(b),
                         kDefaultOptimizePasses});
        }
        v.push_back({"embree-low", "Embree LOW", -1});
        v.push_back({"embree-medium", "Embree MEDIUM", -1});
        v.push_back({"embree-scene", "Embree scene", -1});
        return v;
    }();
    return all;
}

/// "<builder>+optN" (N in 1..AACBVH_MAX_OPTIMIZE_PASSES) for any of the
/// library's builders: that builder, then N passes of aacbvh_bvh_optimize.
/// Made on first use and kept for the run; NULL when the name is not one.
const BuilderInfo *optimized_builder(const std::string &name) {
    static std::vector<std::unique_ptr<BuilderInfo>> made;
    const size_t plus = name.find("+opt");
    uint64_t passes = 0;
    aacbvh_builder b;
    if (plus == std::string::npos || !parse_uint(name.c_str() + plus + 4, passes) || passes < 1 ||
        passes > AACBVH_MAX_OPTIMIZE_PASSES || aacbvh_builder_from_name(name.substr(0, plus).c_str(), &b) != AACBVH_OK)
        return nullptr;
    for (const auto &m : made)
        if (m->id == name) return m.get();
    const std::string base = name.substr(0, plus);
    const std::string label = (label_of(base) ? label_of(base) : base) + std::string(" + opt") + std::to_string(passes);
    made.push_back(std::unique_ptr<BuilderInfo>(new BuilderInfo{name, label, int(b), uint32_t(passes)}));
    return made.back().get();
}

struct Options {
    std::vector<std::string> scenes;
    std::vector<const BuilderInfo *> builders;
    int runs = 5;
    uint32_t width = 256, height = 256;
    uint32_t views = 48;                        ///< --views: in-scene views per scene (0: none)
    uint32_t view_width = 96, view_height = 96; ///< --view-rays: primary rays per view
    std::vector<uint32_t> threads{1};
    uint64_t lo_max_triangles = 400000;
    bool embree = true;
    bool self_check = false;
    uint32_t max_leaf_size = 4;
    int layout = AACBVH_LAYOUT_WIDE8; ///< --layout: what aacbvh_bvh_intersect / occluded traverse (the library's default)
    int triangles = AACBVH_TRIANGLES_COPIED; ///< --triangles: where the queries read triangles from (the default)
    int keep_build_memory = 0; ///< --keep-build-memory: rebuilds reuse the previous build's memory
    std::string csv, json, svg, markdown;
    std::string preview_dir;  ///< --preview DIR: a PGM image of the primary hits per scene
    std::string replot;       ///< --replot FILE: results from this JSON instead of a run
};

void usage(FILE *out) {
    std::fprintf(out,
        "usage: aacbvh-bench [options] [scene.obj ...]\n"
        "The AAC paper's evaluation: build time, SAH cost, ray cost (traversal steps +\n"
        "triangle tests per ray, primary / shadow / diffuse, absolute and relative to\n"
        "full-sweep SAH), single-thread Mrays/s and bytes per triangle, for every scene\n"
        "and builder; Embree 3 beside it when compiled in (%s).\n"
        "\n"
        "options:\n"
        "  --scenes LIST     comma-separated OBJ paths, names of OBJ files in the scenes\n"
        "                    directory, 'shared' (every *.obj there), 'procedural' (about\n"
        "                    240 K triangles) or 'procedural-small' (about 3 K); default:\n"
        "                    every *.obj in %s, else 'procedural'\n"
        "  --builders LIST   comma-separated from sweep-sah, binned-sah, locally-ordered,\n"
        "                    ploc, aac-hq, aac-fast, embree-low, embree-medium,\n"
        "                    embree-scene, or B+optN (builder B, then N passes of\n"
        "                    aacbvh_bvh_optimize, e.g. aac-hq+opt2); or all (the\n"
        "                    default: every builder, aac-hq+opt4 and aac-fast+opt4)\n"
        "  --runs N          builds per builder, scene and thread count (default 5);\n"
        "                    also the timed passes over the rays\n"
        "  --rays N|WxH      primary rays: an N x N image (default 256) or W x H\n"
        "  --views N         in-scene views per scene (default 48; 0 = none): seeded cameras\n"
        "                    on random surface points looking away from them, with primary,\n"
        "                    shadow and diffuse rays; mean and worst view per builder\n"
        "  --view-rays N|WxH primary rays per view (default 96x96)\n"
        "  --threads LIST    thread counts to time builds with, e.g. 1,2 (default 1);\n"
        "                    the first is the tables'; trees and ray timing use 1 thread\n"
        "  --lo-max-triangles N  run locally-ordered only on scenes of at most N\n"
        "                    triangles (default 400000; 0 = no limit)\n"
        "  --no-embree       leave Embree out\n"
        "  --layout L        traversal layout for the Mrays/s columns: wide8 (the library's\n"
        "                    default), wide4 or binary\n"
        "  --triangles S     triangle storage for the Mrays/s columns: copied (the library's\n"
        "                    default) or referenced\n"
        "  --keep-build-memory  set AACBVH_PARAM_KEEP_BUILD_MEMORY: each timed build after\n"
        "                    the first reuses the memory the previous one freed (per-frame\n"
        "                    rebuilds); Embree LOW / MEDIUM then rebuild into one RTCBVH\n"
        "  --csv FILE, --json FILE, --svg FILE, --markdown FILE   write the results\n"
        "  --preview DIR     write DIR/<scene>.pgm, the primary hits shaded by the cosine\n"
        "                    to the light (to check the cameras)\n"
        "  --replot FILE     run nothing: read the results from FILE (a --json output)\n"
        "                    and write the outputs asked for from them, e.g.\n"
        "                    --replot docs/evaluation.json --svg docs/evaluation.svg\n"
        "  --self-check      read the written files back and check their syntax and the\n"
        "                    trees; exit 1 on any failure (for tests)\n"
        "  -h, --help        this text\n",
        embree_compiled() ? ("Embree " + embree_version()).c_str() : "Embree not compiled in",
        AACBVH_SCENES_DIR[0] ? AACBVH_SCENES_DIR : "(no scenes directory compiled in)");
}

bool parse_args(int argc, char **argv, Options &opt) {
    bool builders_given = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&](const char *what) -> const char * {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "aacbvh-bench: %s needs a value\n", what);
                return nullptr;
            }
            return argv[++i];
        };
        uint64_t v = 0;
        if (a == "-h" || a == "--help") {
            usage(stdout);
            std::exit(0);
        } else if (a == "--scenes") {
            const char *s = next("--scenes");
            if (!s) return false;
            for (const std::string &p : split(s, ',')) opt.scenes.push_back(p);
        } else if (a == "--builders") {
            const char *s = next("--builders");
            if (!s) return false;
            builders_given = true;
            for (const std::string &name : split(s, ',')) {
                if (name == "all") {
                    for (const BuilderInfo &b : all_builders()) opt.builders.push_back(&b);
                    continue;
                }
                const BuilderInfo *found = nullptr;
                for (const BuilderInfo &b : all_builders())
                    if (name == b.id) found = &b;
                if (!found) found = optimized_builder(name);
                if (!found) {
                    std::fprintf(stderr, "aacbvh-bench: unknown builder '%s'\n", name.c_str());
                    return false;
                }
                opt.builders.push_back(found);
            }
        } else if (a == "--runs") {
            const char *s = next("--runs");
            if (!s || !parse_uint(s, v) || v < 1 || v > 1000) {
                std::fprintf(stderr, "aacbvh-bench: --runs takes 1 to 1000\n");
                return false;
            }
            opt.runs = int(v);
        } else if (a == "--views") {
            const char *s = next("--views");
            if (!s || !parse_uint(s, v) || v > 100000) {
                std::fprintf(stderr, "aacbvh-bench: --views takes 0 to 100000\n");
                return false;
            }
            opt.views = uint32_t(v);
        } else if (a == "--rays" || a == "--view-rays") {
            const char *s = next(a.c_str());
            if (!s) return false;
            const std::vector<std::string> wh = split(s, 'x');
            uint64_t w = 0, h = 0;
            if (wh.size() == 1 && parse_uint(wh[0].c_str(), w)) h = w;
            else if (wh.size() != 2 || !parse_uint(wh[0].c_str(), w) || !parse_uint(wh[1].c_str(), h)) w = 0;
            if (w < 1 || h < 1 || w > 16384 || h > 16384) {
                std::fprintf(stderr, "aacbvh-bench: %s takes N or WxH, 1 to 16384\n", a.c_str());
                return false;
            }
            (a == "--rays" ? opt.width : opt.view_width) = uint32_t(w);
            (a == "--rays" ? opt.height : opt.view_height) = uint32_t(h);
        } else if (a == "--threads") {
            const char *s = next("--threads");
            if (!s) return false;
            opt.threads.clear();
            for (const std::string &t : split(s, ',')) {
                if (!parse_uint(t.c_str(), v) || v < 1 || v > 1024) {
                    std::fprintf(stderr, "aacbvh-bench: --threads takes counts from 1 to 1024\n");
                    return false;
                }
                if (std::find(opt.threads.begin(), opt.threads.end(), uint32_t(v)) == opt.threads.end())
                    opt.threads.push_back(uint32_t(v));
            }
            if (opt.threads.empty()) return false;
        } else if (a == "--lo-max-triangles") {
            const char *s = next("--lo-max-triangles");
            if (!s || !parse_uint(s, v)) return false;
            opt.lo_max_triangles = v;
        } else if (a == "--preview") {
            const char *s = next("--preview");
            if (!s) return false;
            opt.preview_dir = s;
        } else if (a == "--no-embree") {
            opt.embree = false;
        } else if (a == "--layout") {
            const char *s = next("--layout");
            if (!s) return false;
            if (std::string(s) == "binary")
                opt.layout = AACBVH_LAYOUT_BINARY;
            else if (std::string(s) == "wide4")
                opt.layout = AACBVH_LAYOUT_WIDE4;
            else if (std::string(s) == "wide8")
                opt.layout = AACBVH_LAYOUT_WIDE8;
            else
                return false;
        } else if (a == "--keep-build-memory") {
            opt.keep_build_memory = 1;
        } else if (a == "--triangles") {
            const char *s = next("--triangles");
            if (!s) return false;
            if (std::string(s) == "referenced")
                opt.triangles = AACBVH_TRIANGLES_REFERENCED;
            else if (std::string(s) == "copied")
                opt.triangles = AACBVH_TRIANGLES_COPIED;
            else
                return false;
        } else if (a == "--self-check") {
            opt.self_check = true;
        } else if (a == "--replot") {
            const char *s = next("--replot");
            if (!s) return false;
            opt.replot = s;
        } else if (a == "--csv" || a == "--json" || a == "--svg" || a == "--markdown") {
            const char *s = next(a.c_str());
            if (!s) return false;
            (a == "--csv" ? opt.csv : a == "--json" ? opt.json : a == "--svg" ? opt.svg : opt.markdown) = s;
        } else if (!a.empty() && a[0] == '-') {
            std::fprintf(stderr, "aacbvh-bench: unknown option %s (see --help)\n", a.c_str());
            return false;
        } else {
            opt.scenes.push_back(a);
        }
    }
    if (!builders_given)
        for (const BuilderInfo &b : all_builders()) opt.builders.push_back(&b);
    if (!opt.embree || !embree_compiled()) {
        opt.builders.erase(std::remove_if(opt.builders.begin(), opt.builders.end(),
                                          [](const BuilderInfo *b) { return b->builder < 0; }),
                           opt.builders.end());
    }
    // Sweep SAH is the reference of the relative costs: measure it first.
    std::stable_sort(opt.builders.begin(), opt.builders.end(), [](const BuilderInfo *a, const BuilderInfo *b) {
        return a->id == "sweep-sah" && b->id != "sweep-sah";
    });
    opt.builders.erase(std::unique(opt.builders.begin(), opt.builders.end()), opt.builders.end());
    return true;
}

double median(std::vector<double> v) {
    if (v.empty()) return kNaN;
    std::sort(v.begin(), v.end());
    const size_t m = v.size() / 2;
    return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

BuildTiming timing_of(uint32_t threads, const std::vector<double> &seconds) {
    BuildTiming t;
    t.threads = threads;
    t.runs = int(seconds.size());
    if (!seconds.empty()) {
        t.median_ms = 1e3 * median(seconds);
        t.min_ms = 1e3 * *std::min_element(seconds.begin(), seconds.end());
        t.max_ms = 1e3 * *std::max_element(seconds.begin(), seconds.end());
    }
    return t;
}

/// Resolves a --scenes entry to a loaded scene.
bool load_scene(const std::string &spec, Scene &scene, std::string &err) {
    return load_scene_spec(spec, AACBVH_SCENES_DIR, scene, err);
}

/// The thread contexts, one per count, made on first use.
struct Contexts {
    std::map<uint32_t, aacbvh_context *> by_threads;
    aacbvh_context *get(uint32_t threads) {
        auto it = by_threads.find(threads);
        if (it != by_threads.end()) return it->second;
        aacbvh_context *ctx = nullptr;
        if (aacbvh_context_create(threads, &ctx) != AACBVH_OK) return nullptr;
        by_threads[threads] = ctx;
        return ctx;
    }
    ~Contexts() {
        for (auto &kv : by_threads) aacbvh_context_destroy(kv.second);
    }
};

struct BvhDeleter {
    void operator()(aacbvh_bvh *b) const { aacbvh_bvh_destroy(b); }
};
using BvhPtr = std::unique_ptr<aacbvh_bvh, BvhDeleter>;

/// A BVH over the scene with the given builder and the options' handle parameters.
BvhPtr make_bvh(aacbvh_context *ctx, const Scene &scene, int builder, const Options &opt, std::string &err,
                uint32_t optimize_passes = 0) {
    aacbvh_bvh *raw = nullptr;
    if (!ctx || aacbvh_bvh_create(ctx, &raw) != AACBVH_OK) {
        err = "cannot create a BVH";
        return nullptr;
    }
    BvhPtr bvh(raw);
    if (aacbvh_bvh_set_param_int(raw, AACBVH_PARAM_BUILDER, builder) != AACBVH_OK ||
        aacbvh_bvh_set_param_int(raw, AACBVH_PARAM_MAX_LEAF_SIZE, opt.max_leaf_size) != AACBVH_OK ||
        aacbvh_bvh_set_param_int(raw, AACBVH_PARAM_TRAVERSAL_LAYOUT, opt.layout) != AACBVH_OK ||
        aacbvh_bvh_set_param_int(raw, AACBVH_PARAM_TRIANGLE_STORAGE, opt.triangles) != AACBVH_OK ||
        aacbvh_bvh_set_param_int(raw, AACBVH_PARAM_KEEP_BUILD_MEMORY, opt.keep_build_memory) != AACBVH_OK ||
        aacbvh_bvh_set_param_int(raw, AACBVH_PARAM_OPTIMIZE_PASSES, optimize_passes) != AACBVH_OK ||
        aacbvh_bvh_set_triangles(raw, scene.vertices.data(), scene.vertex_count(), 3 * sizeof(float),
                                 scene.indices.data(), scene.triangle_count()) != AACBVH_OK) {
        err = aacbvh_bvh_last_error(raw);
        return nullptr;
    }
    return bvh;
}

/// Times `runs` calls of fn (returning false on failure), median Mrays/s.
template <class Fn>
double time_rays(size_t count, int runs, Fn fn) {
    std::vector<double> s;
    for (int r = 0; r < runs; ++r) {
        const auto t0 = Clock::now();
        if (!fn()) return kNaN;
        s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    }
    const double m = median(s);
    return m > 0 ? count / m * 1e-6 : kNaN;
}

struct Checker {
    bool enabled = false;
    int failures = 0;
    void fail(const std::string &what) {
        ++failures;
        std::fprintf(stderr, "aacbvh-bench: CHECK FAILED: %s\n", what.c_str());
    }
};

/// Fills the quality columns of a row from a tree: SAH, ray costs.
void measure_tree(const FlatTree &tree, const Scene &scene, const RaySets &rays, Row &row,
                  std::vector<CountedHit> *primary_hits, Checker &check) {
    std::string err;
    if (!check_tree(tree, scene.triangle_count(), err)) check.fail(scene.name + ", " + row.label + ": " + err);
    const CostTracer tracer(tree, scene.vertices.data(), scene.indices.data(), scene.triangle_count());
    const CostSummary p = measure_closest(tracer, rays.rays[kPrimary], primary_hits);
    const CostSummary s = measure_any(tracer, rays.rays[kShadow]);
    const CostSummary d = measure_closest(tracer, rays.rays[kDiffuse]);
    const CostSummary *all[kRayKindCount] = {&p, &s, &d};
    for (int k = 0; k < kRayKindCount; ++k) {
        row.cost[k] = all[k]->rays ? all[k]->total() : kNaN;
        row.steps[k] = all[k]->rays ? all[k]->steps : kNaN;
    }
    if (std::isnan(row.sah)) row.sah = sah_cost(tree);
    const Overlap o = overlap_of(tree);
    row.overlap_area = o.area;
    row.overlap_volume = o.volume;
}

/// The in-scene views' counts (and, given the library's tree, trace times)
/// into row.view_samples: one sample per view and ray kind.
void measure_views(const FlatTree &tree, const Scene &scene, const std::vector<RaySets> &views, aacbvh_bvh *bvh,
                   int runs, Row &row) {
    const CostTracer tracer(tree, scene.vertices.data(), scene.indices.data(), scene.triangle_count());
    std::vector<aacbvh_hit> hits;
    std::vector<uint8_t> occluded;
    for (int k = 0; k < kRayKindCount; ++k) row.view_samples[k].assign(views.size(), ViewSample{});
    for (size_t v = 0; v < views.size(); ++v) {
        for (int k = 0; k < kRayKindCount; ++k) {
            const std::vector<aacbvh_ray> &rays = views[v].rays[k];
            ViewSample &out = row.view_samples[k][v];
            out.rays = rays.size();
            if (rays.empty()) continue;
            const CostSummary c = k == kShadow ? measure_any(tracer, rays) : measure_closest(tracer, rays);
            out.steps = c.steps;
            out.tests = c.tests;
            if (!bvh) continue;
            hits.resize(rays.size());
            occluded.resize(rays.size());
            const double mrays = time_rays(rays.size(), runs, [&] {
                return k == kShadow
                           ? aacbvh_bvh_occluded(bvh, rays.data(), occluded.data(), rays.size()) == AACBVH_OK
                           : aacbvh_bvh_intersect(bvh, rays.data(), hits.data(), rays.size()) == AACBVH_OK;
            });
            out.seconds = mrays > 0 ? rays.size() * 1e-6 / mrays : kNaN;
        }
    }
}

/// Compares the counting tracer's closest hits with the library's: a wrong tree
/// or tracer shows up as disagreement. Returns the fraction of rays that disagree.
double hit_disagreement(const std::vector<CountedHit> &counted, const std::vector<aacbvh_hit> &lib) {
    if (counted.empty()) return 0.0;
    size_t bad = 0;
    for (size_t i = 0; i < counted.size(); ++i) {
        const bool h0 = counted[i].prim_id != AACBVH_INVALID_ID, h1 = lib[i].prim_id != AACBVH_INVALID_ID;
        if (h0 != h1) ++bad;
        else if (h0 && std::fabs(counted[i].t - lib[i].t) > 1e-3f * std::max(1.0f, std::fabs(lib[i].t))) ++bad;
    }
    return double(bad) / counted.size();
}

std::string format_check(const std::string &scene, const char *label, double own, double lib) {
    char buf[256];
    std::snprintf(buf, sizeof buf, "%s, %s: SAH recomputed from the nodes %.6g, aacbvh_stats %.6g", scene.c_str(),
                  label, own, lib);
    return buf;
}

/// A grey image of the primary hits: brightness from the cosine between the
/// geometric normal and the direction to the light; misses black.
void write_preview(const std::string &dir, const Scene &scene, const Camera &cam, const RaySets &rays,
                   const std::vector<aacbvh_hit> &hits) {
    const std::string path = dir + "/" + scene.name + ".pgm";
    std::FILE *f = std::fopen(path.c_str(), "wb");
    if (!f) return;
    std::fprintf(f, "P5\n%u %u\n255\n", rays.width, rays.height);
    for (size_t i = 0; i < hits.size(); ++i) {
        unsigned char g = 0;
        if (hits[i].prim_id != AACBVH_INVALID_ID) {
            const aacbvh_ray &r = rays.rays[kPrimary][i];
            const uint32_t *t = &scene.indices[3 * size_t(hits[i].prim_id)];
            float v[3][3], p[3], e1[3], e2[3], n[3], l[3];
            for (int c = 0; c < 3; ++c)
                for (int k = 0; k < 3; ++k) v[c][k] = scene.vertices[3 * size_t(t[c]) + k];
            for (int k = 0; k < 3; ++k) {
                p[k] = r.org[k] + hits[i].t * r.dir[k];
                e1[k] = v[1][k] - v[0][k];
                e2[k] = v[2][k] - v[0][k];
                l[k] = cam.light[k] - p[k];
            }
            n[0] = e1[1] * e2[2] - e1[2] * e2[1];
            n[1] = e1[2] * e2[0] - e1[0] * e2[2];
            n[2] = e1[0] * e2[1] - e1[1] * e2[0];
            const float nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            const float ll = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
            const float cosine = nn > 0 && ll > 0 ? std::fabs(n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) / (nn * ll) : 0;
            g = (unsigned char)(40 + 215 * cosine);
        }
        std::fputc(g, f);
    }
    std::fclose(f);
}

/// Runs every builder on one scene.
SceneResult run_scene(const Scene &scene, const std::string &source, const Options &opt, Contexts &contexts,
                      Checker &check) {
    SceneResult res;
    res.name = scene.name;
    res.source = source;
    res.triangles = scene.triangle_count();
    res.width = opt.width;
    res.height = opt.height;
    const Bounds bounds = vertex_bounds(scene.vertices);
    res.camera = camera_for_scene(scene.name, bounds);
    aacbvh_context *ctx1 = contexts.get(1);

    // The ray sets: primary rays, and secondary rays from their hits found with
    // an AAC-HQ tree (the hits do not depend on the tree, so every builder traces the same rays).
    RaySets rays;
    rays.width = opt.width;
    rays.height = opt.height;
    rays.rays[kPrimary] = make_primary_rays(res.camera, opt.width, opt.height);
    std::vector<RaySets> views;  // the in-scene views' rays, made the same way
    {
        std::string err;
        BvhPtr ref = make_bvh(ctx1, scene, AACBVH_BUILDER_AAC_HQ, opt, err);
        std::vector<aacbvh_hit> hits(rays.rays[kPrimary].size());
        if (!ref || aacbvh_bvh_build(ref.get()) != AACBVH_OK ||
            aacbvh_bvh_intersect(ref.get(), rays.rays[kPrimary].data(), hits.data(), hits.size()) != AACBVH_OK) {
            check.fail(scene.name + ": cannot trace the primary rays: " +
                       (ref ? aacbvh_bvh_last_error(ref.get()) : err));
        } else {
            make_secondary_rays(rays.rays[kPrimary], hits, scene.vertices, scene.indices, res.camera,
                                bounds.diagonal(), 0x5EED, rays.rays[kShadow], rays.rays[kDiffuse]);
            for (const aacbvh_hit &h : hits) rays.primary_hits += h.prim_id != AACBVH_INVALID_ID;
            if (!opt.preview_dir.empty()) write_preview(opt.preview_dir, scene, res.camera, rays, hits);
            const std::vector<Camera> cameras =
                make_views(scene.vertices, scene.indices, opt.views, res.camera.light, bounds.diagonal(), 0x51E3);
            for (size_t v = 0; v < cameras.size(); ++v) {
                RaySets vr;
                vr.width = opt.view_width;
                vr.height = opt.view_height;
                vr.rays[kPrimary] = make_primary_rays(cameras[v], opt.view_width, opt.view_height);
                std::vector<aacbvh_hit> vhits(vr.rays[kPrimary].size());
                if (aacbvh_bvh_intersect(ref.get(), vr.rays[kPrimary].data(), vhits.data(), vhits.size()) !=
                    AACBVH_OK) {
                    check.fail(scene.name + ": cannot trace a view's primary rays");
                    views.clear();
                    break;
                }
                make_secondary_rays(vr.rays[kPrimary], vhits, scene.vertices, scene.indices, cameras[v],
                                    bounds.diagonal(), 0x5EED + v, vr.rays[kShadow], vr.rays[kDiffuse]);
                for (const aacbvh_hit &h : vhits) vr.primary_hits += h.prim_id != AACBVH_INVALID_ID;
                views.push_back(std::move(vr));
            }
        }
    }
    res.views = uint32_t(views.size());
    if (!views.empty()) {
        res.view_width = opt.view_width;
        res.view_height = opt.view_height;
        uint64_t hit = 0;
        for (const RaySets &v : views) {
            hit += v.primary_hits;
            for (int k = 0; k < kRayKindCount; ++k) res.view_ray_counts[k] += v.rays[k].size();
        }
        std::fprintf(stderr, "[%s] %zu in-scene views, %llu of %llu primary rays hit\n", scene.name.c_str(),
                     views.size(), (unsigned long long)hit, (unsigned long long)res.view_ray_counts[kPrimary]);
    } else if (opt.views > 0) {
        check.fail(scene.name + ": no in-scene view could be made");
    }
    for (int k = 0; k < kRayKindCount; ++k) res.ray_counts[k] = rays.rays[k].size();
    std::fprintf(stderr, "[%s] %zu triangles, %llu of %zu primary rays hit\n", scene.name.c_str(),
                 scene.triangle_count(), (unsigned long long)rays.primary_hits, rays.rays[kPrimary].size());

    for (const BuilderInfo *b : opt.builders) {
        Row row;
        row.builder = b->id;
        row.label = b->label;
        row.status = "ok";
        std::fprintf(stderr, "[%s] %s ...\n", scene.name.c_str(), b->label.c_str());
        if (b->builder == AACBVH_BUILDER_LOCALLY_ORDERED && opt.lo_max_triangles &&
            scene.triangle_count() > opt.lo_max_triangles) {
            row.status = "skipped";
            row.note = "over " + std::to_string(opt.lo_max_triangles) + " triangles (--lo-max-triangles)";
            res.rows.push_back(row);
            continue;
        }
        if (b->builder >= 0) {
            BvhPtr quality_bvh;  // the 1-thread tree whose quality and ray speed are measured
            for (uint32_t t : opt.threads) {
                std::string err;
                BvhPtr bvh = make_bvh(contexts.get(t), scene, b->builder, opt, err, b->passes);
                if (!bvh) {
                    row.status = "error";
                    row.note = err;
                    break;
                }
                std::vector<double> seconds;
                for (int r = 0; r < opt.runs; ++r) {
                    const auto t0 = Clock::now();
                    const aacbvh_status s = aacbvh_bvh_build(bvh.get());
                    const double sec = std::chrono::duration<double>(Clock::now() - t0).count();
                    if (s != AACBVH_OK) {
                        const std::string msg = aacbvh_bvh_last_error(bvh.get());
                        row.status = msg.find("not available") != std::string::npos ? "n/a" : "error";
                        row.note = msg;
                        break;
                    }
                    seconds.push_back(sec);
                }
                if (row.status != "ok") break;
                row.timings.push_back(timing_of(t, seconds));
                if (t == 1) quality_bvh = std::move(bvh);
            }
            if (row.status == "ok" && !quality_bvh) {
                std::string err;
                quality_bvh = make_bvh(ctx1, scene, b->builder, opt, err, b->passes);
                if (!quality_bvh || aacbvh_bvh_build(quality_bvh.get()) != AACBVH_OK) {
                    row.status = "error";
                    row.note = quality_bvh ? aacbvh_bvh_last_error(quality_bvh.get()) : err;
                }
            }
            if (row.status == "ok" && b->passes > 0) {
                // The build times above include the passes; the note gives
                // them alone: builds without, then aacbvh_bvh_optimize timed.
                std::string err;
                const uint32_t t = opt.threads[0];
                BvhPtr plain = make_bvh(contexts.get(t), scene, b->builder, opt, err);
                std::vector<double> seconds;
                for (int r = 0; plain && r < opt.runs; ++r) {
                    if (aacbvh_bvh_build(plain.get()) != AACBVH_OK) break;
                    const auto t0 = Clock::now();
                    if (aacbvh_bvh_optimize(plain.get(), b->passes) != AACBVH_OK) break;
                    seconds.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
                }
                char buf[160];
                if (int(seconds.size()) == opt.runs)
                    std::snprintf(buf, sizeof buf, "optimisation alone %.3g ms (median of %d, %u thread%s)",
                                  1e3 * median(seconds), opt.runs, t, t == 1 ? "" : "s");
                else
                    std::snprintf(buf, sizeof buf, "optimisation alone: failed (%s)",
                                  plain ? aacbvh_bvh_last_error(plain.get()) : err.c_str());
                row.note = buf;
            }
            if (row.status == "ok") {
                aacbvh_bvh *bvh = quality_bvh.get();
                aacbvh_stats stats{};
                stats.struct_size = sizeof(stats);
                FlatTree tree;
                std::string err;
                if (aacbvh_bvh_get_stats(bvh, &stats) != AACBVH_OK || !fetch_tree(bvh, tree, err)) {
                    row.status = "error";
                    row.note = "cannot read the tree: " + err;
                } else {
                    row.sah = stats.sah_cost;
                    row.bytes_per_triangle = res.triangles ? double(stats.memory_bytes) / res.triangles : kNaN;
                    const double own_sah = sah_cost(tree);
                    if (std::fabs(own_sah - stats.sah_cost) > 1e-3 * std::max(1.0, stats.sah_cost))
                        check.fail(format_check(scene.name, b->label.c_str(), own_sah, stats.sah_cost));
                    std::vector<CountedHit> counted;
                    measure_tree(tree, scene, rays, row, &counted, check);
                    measure_views(tree, scene, views, bvh, opt.runs, row);
                    std::vector<aacbvh_hit> hits(rays.rays[kPrimary].size());
                    std::vector<uint8_t> occluded(rays.rays[kShadow].size());
                    const auto &rp = rays.rays[kPrimary], &rs = rays.rays[kShadow], &rd = rays.rays[kDiffuse];
                    row.mrays[kPrimary] = time_rays(rp.size(), opt.runs, [&] {
                        return aacbvh_bvh_intersect(bvh, rp.data(), hits.data(), rp.size()) == AACBVH_OK;
                    });
                    const double disagree = hit_disagreement(counted, hits);
                    if (disagree > 0.002)
                        check.fail(scene.name + ", " + b->label + ": the counting tracer and aacbvh_bvh_intersect "
                                   "disagree on " + std::to_string(100 * disagree) + "% of primary rays");
                    row.mrays[kShadow] = time_rays(rs.size(), opt.runs, [&] {
                        return aacbvh_bvh_occluded(bvh, rs.data(), occluded.data(), rs.size()) == AACBVH_OK;
                    });
                    std::vector<aacbvh_hit> dhits(rd.size());
                    row.mrays[kDiffuse] = time_rays(rd.size(), opt.runs, [&] {
                        return aacbvh_bvh_intersect(bvh, rd.data(), dhits.data(), rd.size()) == AACBVH_OK;
                    });
                }
            }
        } else if (row.builder == "embree-low" || row.builder == "embree-medium") {
            const EmbreeQuality q = row.builder == "embree-low" ? EmbreeQuality::kLow : EmbreeQuality::kMedium;
            FlatTree tree;
            for (size_t ti = 0; ti < opt.threads.size() && row.status == "ok"; ++ti) {
                std::vector<double> seconds;
                std::string err;
                if (!embree_build_bvh(scene.vertices, scene.indices, q, opt.threads[ti], opt.runs, opt.max_leaf_size,
                                      opt.keep_build_memory != 0, seconds, ti == 0 ? &tree : nullptr, err)) {
                    row.status = "error";
                    row.note = err;
                } else {
                    row.timings.push_back(timing_of(opt.threads[ti], seconds));
                }
            }
            if (row.status == "ok") {
                row.bytes_per_triangle = res.triangles ? double(flat_tree_bytes(tree)) / res.triangles : kNaN;
                row.note = "tree converted to aacbvh nodes; build time is rtcBuildBVH alone";
                measure_tree(tree, scene, rays, row, nullptr, check);
                measure_views(tree, scene, views, nullptr, opt.runs, row);
            }
        } else {  // embree-scene
            // The head-to-head (where Embree is compiled in): the default
            // tree (AAC-HQ, one thread), built now as Embree's scene is, so
            // that neither has sat idle for minutes, each of Embree's passes
            // followed by one of ours over the same rays.
            std::vector<aacbvh_hit> our_hits;
            std::vector<uint8_t> our_occluded;
            BvhPtr default_bvh;
            if (embree_compiled()) {
                std::string duel_err;
                default_bvh = make_bvh(ctx1, scene, AACBVH_BUILDER_AAC_HQ, opt, duel_err);
                if (default_bvh && aacbvh_bvh_build(default_bvh.get()) != AACBVH_OK) default_bvh.reset();
            }
            OurPass ours; // empty without a tree: no head-to-head
            if (default_bvh) {
                size_t most_rays = 0;
                for (int k = 0; k < kRayKindCount; ++k) most_rays = std::max(most_rays, rays.rays[k].size());
                our_hits.resize(most_rays);
                our_occluded.resize(most_rays);
                ours = [&](int kind) {
                    const std::vector<aacbvh_ray> &set = rays.rays[kind];
                    const auto t0 = Clock::now();
                    const aacbvh_status s =
                        kind == kShadow
                            ? aacbvh_bvh_occluded(default_bvh.get(), set.data(), our_occluded.data(), set.size())
                            : aacbvh_bvh_intersect(default_bvh.get(), set.data(), our_hits.data(), set.size());
                    const double sec = std::chrono::duration<double>(Clock::now() - t0).count();
                    return s == AACBVH_OK ? sec : -1.0;
                };
            }
            for (size_t ti = 0; ti < opt.threads.size() && row.status == "ok"; ++ti) {
                std::vector<double> seconds;
                std::string err;
                uint64_t hits[kRayKindCount] = {0, 0, 0};
                double scene_bytes = 0.0;
                if (!embree_scene_bench(scene.vertices, scene.indices, opt.threads[ti], opt.runs,
                                        ti == 0 ? &rays : nullptr, seconds, row.mrays, hits, scene_bytes, err,
                                        ti == 0 ? &ours : nullptr, ti == 0 ? res.head_to_head : nullptr)) {
                    row.status = "error";
                    row.note = err;
                } else {
                    row.timings.push_back(timing_of(opt.threads[ti], seconds));
                    if (ti == 0 && res.triangles) row.bytes_per_triangle = scene_bytes / double(res.triangles);
                    if (ti == 0 && rays.primary_hits &&
                        std::fabs(double(hits[kPrimary]) - double(rays.primary_hits)) > 0.002 * rays.primary_hits)
                        check.fail(scene.name + ": Embree hits " + std::to_string(hits[kPrimary]) +
                                   " primary rays, aacbvh " + std::to_string(rays.primary_hits));
                }
            }
            if (row.status == "ok") row.note = "Embree's own BVH; no ray cost (its tree is not exposed)";
        }
        res.rows.push_back(row);
    }

    // Ray cost relative to full-sweep SAH.
    if (const Row *sweep = res.find("sweep-sah")) {
        const Row ref = *sweep;
        for (Row &r : res.rows)
            for (int k = 0; k < kRayKindCount; ++k) r.rel_cost[k] = r.cost[k] / ref.cost[k];
    }
    res.summarise_views();
    return res;
}

/// The benchmark itself: every scene and builder, printed as it goes. false
/// when nothing could run.
bool run_benchmark(int argc, char **argv, const Options &opt, Checker &check, RunInfo &info,
                   std::vector<SceneResult> &results) {
    for (int i = 0; i < argc; ++i) {
        std::string a = argv[i];
        if (i == 0) a = "aacbvh-bench";
        info.command += (i ? " " : "") + a;
    }
    info.library_version = std::string(aacbvh_version_string()) +
                           (opt.layout == AACBVH_LAYOUT_WIDE8   ? " (traversal layout wide8"
                            : opt.layout == AACBVH_LAYOUT_WIDE4 ? " (traversal layout wide4"
                                                                : " (traversal layout binary") +
                           (opt.triangles == AACBVH_TRIANGLES_COPIED ? ", triangles copied" : ", triangles referenced") +
                           (opt.keep_build_memory ? ", build memory kept between builds)" : ")");
    info.embree_version = embree_compiled() ? embree_version() : "not compiled in";
    if (!opt.embree && embree_compiled()) info.embree_version += " (left out: --no-embree)";
    info.cpu = cpu_name();
    info.hardware_threads = std::thread::hardware_concurrency();
    info.threads = opt.threads;
    info.runs = opt.runs;
    {
        const std::time_t now = std::time(nullptr);
        char buf[64];
        std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
        info.date = buf;
    }

    const std::vector<std::string> specs = expand_scene_specs(opt.scenes, AACBVH_SCENES_DIR);

    Contexts contexts;
    if (!contexts.get(1)) {
        std::fprintf(stderr, "aacbvh-bench: cannot create a context\n");
        return false;
    }
    for (const std::string &spec : specs) {
        Scene scene;
        std::string err;
        const auto t0 = Clock::now();
        if (!load_scene(spec, scene, err)) {
            std::fprintf(stderr, "aacbvh-bench: %s: %s (skipped)\n", spec.c_str(), err.c_str());
            if (opt.self_check) check.fail("cannot load " + spec);
            continue;
        }
        std::fprintf(stderr, "[%s] loaded in %.1f s\n", scene.name.c_str(),
                     std::chrono::duration<double>(Clock::now() - t0).count());
        const bool generated = spec.rfind("procedural", 0) == 0;
        results.push_back(run_scene(scene, generated ? "generated" : spec, opt, contexts, check));
        print_scene(stdout, results.back(), info);
    }
    if (results.empty()) {
        std::fprintf(stderr, "aacbvh-bench: no scene could be loaded\n");
        return false;
    }
    return true;
}

}  // namespace

int main(int argc, char **argv) {
    Options opt;
    if (!parse_args(argc, argv, opt)) return 2;

    Checker check;
    check.enabled = opt.self_check;
    RunInfo info;
    std::vector<SceneResult> results;
    if (opt.replot.empty()) {
        if (!run_benchmark(argc, argv, opt, check, info, results)) return 1;
    } else {
        std::string err;
        if (!read_json(opt.replot, results, info, err)) {
            std::fprintf(stderr, "aacbvh-bench: %s\n", err.c_str());
            return 1;
        }
    }

    struct Output {
        const std::string &path;
        bool (*write)(const std::string &, const std::vector<SceneResult> &, const RunInfo &, std::string &);
        bool (*verify)(const std::string &, std::string &);
    };
    const Output outputs[] = {{opt.csv, write_csv, check_csv_file},
                              {opt.json, write_json, check_json_file},
                              {opt.svg, write_svg, check_svg_file},
                              {opt.markdown, write_markdown, check_markdown_file}};
    int status = 0;
    for (const Output &o : outputs) {
        if (o.path.empty()) continue;
        std::string err;
        if (!o.write(o.path, results, info, err)) {
            std::fprintf(stderr, "aacbvh-bench: %s\n", err.c_str());
            status = 1;
            continue;
        }
        std::fprintf(stderr, "wrote %s\n", o.path.c_str());
        if (opt.self_check && !o.verify(o.path, err)) check.fail(err);
    }
    if (opt.self_check) {
        // Every tree the benchmark measured must have cost figures.
        for (const SceneResult &s : results)
            for (const Row &r : s.rows)
                if (r.status == "ok" && r.builder != "embree-scene" && !(r.cost[kPrimary] > 0))
                    check.fail(s.name + ", " + r.label + ": no ray cost");
        for (const SceneResult &s : results) {
            for (const Row &r : s.rows) {
                if (r.status != "ok" || r.builder == "embree-scene") continue;
                // Overlap: a sum of non-negative shares (files from before it was measured have none).
                if (opt.replot.empty() &&
                    (!(r.overlap_area >= 0) || !(r.overlap_volume >= 0 || std::isnan(r.overlap_volume))))
                    check.fail(s.name + ", " + r.label + ": no overlap figure");
                if (s.views == 0) continue;
                const bool library = r.builder.rfind("embree", 0) != 0;
                for (int k = 0; k < kRayKindCount; ++k) {
                    const ViewFigures &v = r.views[k];
                    if (k != kPrimary && !(s.view_ray_counts[k] > 0)) continue;
                    const std::string what = s.name + ", " + r.label + ", " + ray_kind_name(k) + " views: ";
                    // Every view tests the root's box; the worst view is no better than the mean.
                    if (!(v.steps_mean >= 1) || !(v.steps_worst >= v.steps_mean) || !(v.tests_worst >= v.tests_mean))
                        check.fail(what + "no ray cost, or a worst view better than the mean");
                    if (!(v.rel_cost_worst >= v.rel_cost_mean) || !(v.rel_cost_mean > 0))
                        check.fail(what + "no cost relative to sweep SAH");
                    if (library && (!(v.mrays_mean > 0) || !(v.mrays_worst <= v.mrays_mean * (1 + 1e-9)) ||
                                    !(v.rel_time_worst >= v.rel_time_mean)))
                        check.fail(what + "no timing, or a slowest view faster than the mean");
                    // The worst of the views with many rays is one of all the views.
                    if (v.rel_time_worst_timed > v.rel_time_worst)
                        check.fail(what + "the worst of the large views above the worst of all");
                    // Sweep SAH against itself: exactly 1 on every view.
                    if (r.builder == "sweep-sah" && (v.rel_cost_mean != 1.0 || v.rel_cost_worst != 1.0 ||
                                                     std::fabs(v.rel_time_mean - 1.0) > 1e-12))
                        check.fail(what + "sweep SAH is not 1 against itself");
                }
            }
        }
        std::fprintf(stderr, "self-check: %s\n", check.failures ? "FAILED" : "passed");
        if (check.failures) status = 1;
    } else if (check.failures) {
        std::fprintf(stderr, "aacbvh-bench: %d check(s) failed (see above)\n", check.failures);
    }
    return status;
}
