// aacbvh-demo: builds a BVH over each scene with each builder, several times,
// and prints build time, tree quality (SAH cost) and size, with build time and
// SAH cost also as ratios to the reference builder (sweep SAH) on the same
// scene, and a legend of the columns under the table. Every builder's closest
// hits for a fixed set of random rays are compared with the first builder's
// (the reference, which runs first), so a wrong tree shows up as a failure
// rather than a fast time.
//
//   aacbvh-demo [options] [scene.obj ...]     (aacbvh-demo --help for options)
//
// Scenes: the OBJ files named on the command line; else every *.obj in the
// directory named by the environment variable AACBVH_SCENES, or else in the
// directory compiled in as AACBVH_SCENES_DIR; else a generated scene.
#include <aacbvh/aacbvh.h>

#include "random.h"
#include "scene.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <string>
#include <vector>

#ifndef AACBVH_SCENES_DIR
#define AACBVH_SCENES_DIR ""
#endif

namespace {

struct BuilderInfo {
    const char *name;        ///< command-line and table name
    aacbvh_builder builder;
};

/// The builder the ratio columns divide by: top-down full-sweep SAH, the
/// classic quality reference (the AAC paper's too). It runs first on each scene.
constexpr aacbvh_builder kReference = AACBVH_BUILDER_SWEEP_SAH;

/// Relative difference of closest-hit distances accepted as rounding.
constexpr double kRelativeTolerance = 1e-5;

/// Every builder the library offers (aacbvh_builder_name), in its order.
/// "aac" is left out: with its parameters unset it is aac-hq.
std::vector<BuilderInfo> library_builders() {
    std::vector<BuilderInfo> out;
    for (int b = 0; aacbvh_builder_name(aacbvh_builder(b)); ++b)
        if (b != AACBVH_BUILDER_AAC) out.push_back({aacbvh_builder_name(aacbvh_builder(b)), aacbvh_builder(b)});
    return out;
}

struct Options {
    int runs = 5;
    uint32_t threads = 1;
    std::vector<BuilderInfo> builders;
    bool builders_chosen = false;            ///< --builders given: no size limit for locally-ordered
    uint64_t lo_max_triangles = 400000;      ///< locally-ordered is O(n log n) with a large constant
    double time_budget_s = 20.0;             ///< per scene and builder; at least one run
    size_t ray_count = 4096;
    bool procedural = false;
    bool small = false;
    std::vector<std::string> paths;
};

void usage(FILE *out) {
    std::fprintf(out,
        "usage: aacbvh-demo [options] [scene.obj ...]\n"
        "Builds BVHs over each scene with each builder and prints a table of build\n"
        "times (median, min, max over the runs), SAH cost, both also relative to\n"
        "sweep-sah on the same scene, node and leaf counts, depth and memory per\n"
        "triangle; a legend under the table says what each column means.\n"
        "\n"
        "Scenes: the OBJ files given; else every *.obj in $AACBVH_SCENES, else in\n"
        "  %s;\n"
        "  else a generated scene of about 240 K triangles.\n"
        "\n"
        "options:\n"
        "  --runs N              builds per scene and builder (default 5)\n"
        "  --threads N           threads of the context (default 1; 0 = one per core)\n"
        "  --builders LIST       comma-separated builder names (aacbvh_builder_name: aac-hq,\n"
        "                        aac-fast, sweep-sah, ...); or all (the default)\n"
        "  --lo-max-triangles N  by default, run locally-ordered only on scenes of at\n"
        "                        most N triangles (default 400000; 0 = no limit)\n"
        "  --time-budget S       stop repeating a builder on a scene once its builds\n"
        "                        took S seconds (default 20; it always runs once)\n"
        "  --rays N              rays of the cross-builder hit check (default 4096; 0 = off)\n"
        "  --procedural          use the generated scene even when OBJ files exist\n"
        "  --small               use a generated scene of about 10 K triangles\n"
        "  -h, --help            this text\n",
        AACBVH_SCENES_DIR[0] ? AACBVH_SCENES_DIR : "(no directory compiled in)");
}

bool parse_uint(const char *text, uint64_t max, uint64_t &out) {
    if (text == nullptr || *text == '\0' || *text == '-')
        return false;
    char *end = nullptr;
    const unsigned long long value = std::strtoull(text, &end, 10);
    if (*end != '\0' || value > max)
        return false;
    out = value;
    return true;
}

bool parse_builders(const std::string &list, std::vector<BuilderInfo> &out) {
    out.clear();
    size_t start = 0;
    while (start <= list.size()) {
        size_t comma = list.find(',', start);
        if (comma == std::string::npos)
            comma = list.size();
        std::string name = list.substr(start, comma - start);
        std::transform(name.begin(), name.end(), name.begin(), [](char c) {
            return c == '_' ? '-' : static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        });
        aacbvh_builder builder;
        if (name == "all") {
            out = library_builders();
        } else if (aacbvh_builder_from_name(name.c_str(), &builder) == AACBVH_OK) {
            out.push_back({aacbvh_builder_name(builder), builder});
        } else {
            std::fprintf(stderr, "aacbvh-demo: %s\n", aacbvh_last_error());
            return false;
        }
        start = comma + 1;
    }
    return !out.empty();
}

bool parse_options(int argc, char **argv, Options &opt, bool &help) {
    opt.builders = library_builders();
    help = false;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        const char *value = i + 1 < argc ? argv[i + 1] : nullptr;
        uint64_t n = 0;
        auto bad = [&]() {
            std::fprintf(stderr, "aacbvh-demo: %s needs a valid value (see --help)\n", arg.c_str());
            return false;
        };
        if (arg == "-h" || arg == "--help") {
            help = true;
        } else if (arg == "--runs") {
            if (!parse_uint(value, 1000, n) || n == 0)
                return bad();
            opt.runs = static_cast<int>(n);
            ++i;
        } else if (arg == "--threads") {
            if (!parse_uint(value, 1024, n))
                return bad();
            opt.threads = static_cast<uint32_t>(n);
            ++i;
        } else if (arg == "--builders") {
            if (value == nullptr || !parse_builders(value, opt.builders))
                return bad();
            opt.builders_chosen = true;
            ++i;
        } else if (arg == "--lo-max-triangles") {
            if (!parse_uint(value, UINT64_MAX, n))
                return bad();
            opt.lo_max_triangles = n;
            ++i;
        } else if (arg == "--time-budget") {
            char *end = nullptr;
            opt.time_budget_s = value ? std::strtod(value, &end) : -1.0;
            if (value == nullptr || *end != '\0' || !(opt.time_budget_s >= 0.0))
                return bad();
            ++i;
        } else if (arg == "--rays") {
            if (!parse_uint(value, 1u << 24, n))
                return bad();
            opt.ray_count = static_cast<size_t>(n);
            ++i;
        } else if (arg == "--procedural") {
            opt.procedural = true;
        } else if (arg == "--small") {
            opt.procedural = opt.small = true;
        } else if (arg.size() > 1 && arg[0] == '-') {
            std::fprintf(stderr, "aacbvh-demo: unknown option '%s' (see --help)\n", arg.c_str());
            return false;
        } else {
            opt.paths.push_back(arg);
        }
    }
    // The reference first: the ratio columns and the ray check need its results.
    std::stable_partition(opt.builders.begin(), opt.builders.end(),
                          [](const BuilderInfo &b) { return b.builder == kReference; });
    return true;
}

// A fixed set of rays per scene: origins spread through the middle of the
// scene's bounds, directions uniform over the sphere. Same rays every run.
std::vector<aacbvh_ray> make_rays(const Scene &scene, size_t count) {
    float lo[3], hi[3];
    scene_bounds(scene.vertices.data(), scene.vertex_count(), lo, hi);
    SplitMix64 random(0x5EED5EED12345678ull);
    std::vector<aacbvh_ray> rays(count);
    for (aacbvh_ray &ray : rays) {
        for (int k = 0; k < 3; ++k) {
            const double centre = 0.5 * (double(lo[k]) + hi[k]), half = 0.5 * (double(hi[k]) - lo[k]);
            ray.org[k] = static_cast<float>(centre + 0.8 * half * random.uniform(-1.0, 1.0));
        }
        random.direction(ray.dir);
        ray.tmin = 0.0f;
        ray.tmax = INFINITY;
    }
    return rays;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Failure {};

void check(aacbvh_status status, const aacbvh_bvh *bvh, const char *what, const std::string &where) {
    if (status == AACBVH_OK)
        return;
    std::fflush(stdout);
    std::fprintf(stderr, "aacbvh-demo: %s failed on %s: %s: %s\n", what, where.c_str(),
                 aacbvh_status_string(status), bvh ? aacbvh_bvh_last_error(bvh) : "");
    throw Failure();
}

/// value / reference as "0.42", or "-" when the reference did not run.
std::string ratio_text(double value, double reference) {
    if (!(reference > 0.0))
        return "-";
    char text[32];
    std::snprintf(text, sizeof text, "%.2f", value / reference);
    return text;
}

/// Runs every builder on one scene and prints a table row per builder.
/// Returns the number of rays whose hits differ from the first builder's.
size_t run_scene(aacbvh_context *ctx, const Scene &scene, const Options &opt) {
    const size_t triangles = scene.triangle_count();
    const std::vector<aacbvh_ray> rays = make_rays(scene, opt.ray_count);
    std::vector<aacbvh_hit> reference, hits(rays.size());
    bool have_reference = false;
    size_t mismatches = 0;
    double reference_ms = NAN, reference_sah = NAN;  // of kReference on this scene

    for (const BuilderInfo &info : opt.builders) {
        const std::string where = scene.name + " / " + info.name;
        if (info.builder == AACBVH_BUILDER_LOCALLY_ORDERED && !opt.builders_chosen &&
            opt.lo_max_triangles != 0 && triangles > opt.lo_max_triangles) {
            std::printf("%-18s %10zu %-16s  skipped: over %llu triangles (--lo-max-triangles)\n",
                        scene.name.c_str(), triangles, info.name,
                        static_cast<unsigned long long>(opt.lo_max_triangles));
            std::fflush(stdout);
            continue;
        }

        aacbvh_bvh *bvh = nullptr;
        check(aacbvh_bvh_create(ctx, &bvh), nullptr, "aacbvh_bvh_create", where);
        try {
            check(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, info.builder), bvh,
                  "setting the builder", where);
            check(aacbvh_bvh_set_triangles(bvh, scene.vertices.data(), scene.vertex_count(),
                                           3 * sizeof(float), scene.indices.data(), triangles),
                  bvh, "aacbvh_bvh_set_triangles", where);

            std::vector<double> times_ms;
            double total_s = 0.0;
            for (int run = 0; run < opt.runs && (run == 0 || total_s < opt.time_budget_s); ++run) {
                const auto start = std::chrono::steady_clock::now();
                const aacbvh_status status = aacbvh_bvh_build(bvh);
                const double seconds =
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
                check(status, bvh, "aacbvh_bvh_build", where);
                times_ms.push_back(1e3 * seconds);
                total_s += seconds;
            }

            aacbvh_stats stats;
            std::memset(&stats, 0, sizeof stats);
            stats.struct_size = sizeof stats;
            check(aacbvh_bvh_get_stats(bvh, &stats), bvh, "aacbvh_bvh_get_stats", where);

            std::string ray_note = "-";
            if (!rays.empty()) {
                check(aacbvh_bvh_intersect(bvh, rays.data(), hits.data(), rays.size()), bvh,
                      "aacbvh_bvh_intersect", where);
                size_t hit_count = 0, differ = 0, rounding = 0;
                for (size_t i = 0; i < hits.size(); ++i) {
                    hit_count += hits[i].prim_id != AACBVH_INVALID_ID;
                    if (!have_reference || hits[i].t == reference[i].t)
                        continue;
                    // Closest-hit distances agree whatever the tree, except
                    // where overlapping coplanar triangles give distances an
                    // ulp or so apart and a tree finds the other one first.
                    const double a = hits[i].t, b = reference[i].t;
                    if (std::isfinite(a) && std::isfinite(b) &&
                        std::fabs(a - b) <= kRelativeTolerance * std::max(std::fabs(a), std::fabs(b))) {
                        ++rounding;
                        continue;
                    }
                    if (differ++ == 0)
                        std::fprintf(stderr,
                                     "aacbvh-demo: %s: ray %zu (org %.9g %.9g %.9g, dir %.9g %.9g %.9g): "
                                     "t = %.9g (primitive %u), first builder t = %.9g (primitive %u)\n",
                                     where.c_str(), i, rays[i].org[0], rays[i].org[1], rays[i].org[2],
                                     rays[i].dir[0], rays[i].dir[1], rays[i].dir[2], hits[i].t,
                                     hits[i].prim_id, reference[i].t, reference[i].prim_id);
                }
                if (!have_reference) {
                    reference = hits;
                    have_reference = true;
                    ray_note = "ref " + std::to_string(hit_count) + "/" + std::to_string(hits.size());
                } else if (differ != 0) {
                    ray_note = std::to_string(differ) + " DIFFER";
                } else {
                    ray_note = rounding == 0 ? "same" : "same (" + std::to_string(rounding) + " within 1e-5)";
                }
                mismatches += differ;
            }

            const double per_tri = triangles ? 1.0 / static_cast<double>(triangles) : 0.0;
            const double median_ms = median(times_ms);
            if (info.builder == kReference) {
                reference_ms = median_ms;
                reference_sah = stats.sah_cost;
            }
            std::printf("%-18s %10zu %-16s %4zu %10.2f %10.2f %10.2f %8s %9.2f %9s %9llu %9llu %5u %7.1f %7.1f  %s\n",
                        scene.name.c_str(), triangles, info.name, times_ms.size(), median_ms,
                        *std::min_element(times_ms.begin(), times_ms.end()),
                        *std::max_element(times_ms.begin(), times_ms.end()),
                        ratio_text(median_ms, reference_ms).c_str(), stats.sah_cost,
                        ratio_text(stats.sah_cost, reference_sah).c_str(),
                        static_cast<unsigned long long>(stats.node_count),
                        static_cast<unsigned long long>(stats.leaf_count), stats.max_depth,
                        static_cast<double>(stats.memory_bytes) * per_tri,
                        static_cast<double>(stats.build_peak_bytes) * per_tri, ray_note.c_str());
            std::fflush(stdout);
        } catch (const Failure &) {
            aacbvh_bvh_destroy(bvh);
            throw;
        }
        aacbvh_bvh_destroy(bvh);
    }
    return mismatches;
}

/// What the table's columns mean, printed under it for readers new to BVHs.
void print_legend(const Options &opt, uint32_t threads) {
    std::printf(
        "\ncolumns:\n"
        "  triangles       triangles in the scene\n"
        "  builder         the BVH builder (AACBVH_BUILDER_*); sweep-sah, top-down full-sweep\n"
        "                  SAH, is the quality reference and runs first\n"
        "  runs            builds timed (at most --runs %d; fewer once a builder's builds\n"
        "                  on a scene took --time-budget %.0f s)\n"
        "  median/min/max ms  wall time of aacbvh_bvh_build over those runs, %u thread(s)\n"
        "  ms/sweep        median build time / sweep-sah's on the same scene: 0.25 builds\n"
        "                  4 times as fast (- when sweep-sah did not run)\n"
        "  SAH cost        the tree's expected cost of tracing a ray through it (1.2 per node\n"
        "                  visited, 1 per triangle tested, for rays crossing the scene at\n"
        "                  random): lower means faster rays\n"
        "  SAH/sweep       SAH cost / sweep-sah's on the same scene: 1.05 is a tree 5%% more\n"
        "                  expensive to trace, below 1 a better one than sweep-sah's\n"
        "  nodes, leaves, depth  size of the binary tree and its longest root-to-leaf path\n"
        "  B/tri, peak/tri bytes per triangle the finished BVH holds, and the build held at\n"
        "                  its peak\n"
        "  rays            the correctness check of %zu random rays: a scene's first row\n"
        "                  shows its hits (ref hits/rays), the others 'same' when every\n"
        "                  closest hit agrees with it; 'N DIFFER' fails the demo\n"
        "Reading it: a good builder for a given budget has a low ms/sweep and a SAH/sweep\n"
        "near 1; AAC aims at sweep-sah's tree quality in a fraction of its build time.\n",
        opt.runs, opt.time_budget_s, threads, opt.ray_count);
}

} // namespace

int main(int argc, char **argv) {
    Options opt;
    bool help = false;
    if (!parse_options(argc, argv, opt, help))
        return 2;
    if (help) {
        usage(stdout);
        return 0;
    }

    // Which scenes: the command line, else a directory of OBJ files, else generated.
    std::vector<std::string> paths = opt.paths;
    if (paths.empty() && !opt.procedural) {
        const char *env = std::getenv("AACBVH_SCENES");
        paths = default_scene_paths(env ? env : AACBVH_SCENES_DIR);
    }

    aacbvh_context *ctx = nullptr;
    const aacbvh_status status = aacbvh_context_create(opt.threads, &ctx);
    if (status != AACBVH_OK) {
        std::fprintf(stderr, "aacbvh-demo: aacbvh_context_create(%u) failed: %s\n", opt.threads,
                     aacbvh_status_string(status));
        return 1;
    }
    std::printf("libaacbvh %s, %u thread(s), up to %d run(s) per build, %zu check rays\n",
                aacbvh_version_string(), aacbvh_context_thread_count(ctx), opt.runs, opt.ray_count);
    std::printf("%-18s %10s %-16s %4s %10s %10s %10s %8s %9s %9s %9s %9s %5s %7s %7s  %s\n", "scene",
                "triangles", "builder", "runs", "median ms", "min ms", "max ms", "ms/sweep", "SAH cost",
                "SAH/sweep", "nodes", "leaves", "depth", "B/tri", "peak/tri", "rays");
    std::fflush(stdout);

    const auto start = std::chrono::steady_clock::now();
    size_t mismatches = 0;
    int exit_code = 0;
    try {
        if (paths.empty()) {
            ProceduralConfig config;
            if (opt.small) {
                config.terrain_cells = 48;
                config.sphere_count = 8;
                config.sphere_rings = 12;
            }
            mismatches += run_scene(ctx, make_procedural_scene(config), opt);
        }
        for (const std::string &path : paths) {
            Scene scene;
            std::string err;
            if (!load_obj(path, scene, err)) {
                std::fprintf(stderr, "aacbvh-demo: %s\n", err.c_str());
                exit_code = 1;
                break;
            }
            mismatches += run_scene(ctx, scene, opt);
        }
    } catch (const Failure &) {
        exit_code = 1;
    }
    const uint32_t threads = aacbvh_context_thread_count(ctx);
    aacbvh_context_destroy(ctx);
    print_legend(opt, threads);

    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (exit_code == 0 && mismatches != 0) {
        std::fprintf(stderr,
                     "aacbvh-demo: %zu closest-hit distances differ between builders of one scene\n",
                     mismatches);
        exit_code = 1;
    }
    std::printf("%s in %.1f s\n", exit_code == 0 ? "done" : "FAILED", seconds);
    return exit_code;
}
