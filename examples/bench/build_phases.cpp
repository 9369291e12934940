// aacbvh-build-phases: where a build's time goes at each thread count.
// A build reports its progress at fixed milestones (0.1 after the input pass,
// 0.3 after the AAC builders' Morton sort, 0.8 after the builder, 1.0 after the
// traversal layouts); a progress callback stamps the time it first sees each,
// so the build splits into four phases without touching the library:
//   input    boxes, centroid bounds, invalid primitives   [0, 0.1)
//   sort     Morton codes and their radix sort (AAC)      [0.1, 0.3)
//   cluster  the builder's own work (AAC: gather, recursion, top split)  [0.3, 0.8)
//   layout   binary emit, 8-wide nodes, triangle packets  [0.8, 1.0]
// (builders without a sort report no 0.3: their sort column is 0 and the
// cluster column holds all of [0.1, 0.8)). Each build uses a fresh handle
// (fresh memory, as aacbvh-bench times builds; --keep-build-memory rebuilds
// one handle that keeps its build memory instead), and the table prints the
// median of each phase over the runs, per scene, builder and context thread
// count, with the speedup over the first thread count. Every thread count
// must give the first count's tree (the same SAH bits); the exit status is 1
// when a build fails or a tree differs. Speed is reported, never asserted.
//
//   aacbvh-build-phases [--scenes LIST] [--builders LIST] [--threads LIST] [--runs N]
//                       [--keep-build-memory]
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
#include "scene.h"

#ifndef AACBVH_SCENES_DIR
#define AACBVH_SCENES_DIR ""
#endif

namespace {

using namespace bench;
using Clock = std::chrono::steady_clock;

struct Options {
    std::vector<std::string> scenes;
    std::vector<aacbvh_builder> builders{AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST};
    std::vector<uint32_t> threads;
    int runs = 7;
    bool keep_build_memory = false;
};

void usage(const char *argv0) {
    std::fprintf(stderr,
                 "usage: %s [--scenes LIST] [--builders LIST] [--threads LIST] [--runs N]\n"
                 "       [--keep-build-memory]\n"
                 "  --scenes LIST    comma-separated OBJ paths, names of OBJ files in the scenes\n"
                 "                   directory, 'shared' (every *.obj there), 'procedural' or\n"
                 "                   'procedural-small'; default: every *.obj in %s,\n"
                 "                   else 'procedural'\n"
                 "  --builders LIST  builder names (aacbvh_builder_name), default aac-hq,aac-fast\n"
                 "  --threads LIST   context thread counts, e.g. 1,2 (default 1 and this machine's\n"
                 "                   hardware threads); speedups are over the first\n"
                 "  --runs N         timed builds per scene, builder and thread count (default 7)\n"
                 "  --keep-build-memory  rebuild one handle with AACBVH_PARAM_KEEP_BUILD_MEMORY\n"
                 "                   (per-frame rebuilds: memory reused; one untimed build first)\n"
                 "                   instead of building a fresh handle each time\n",
                 argv0, AACBVH_SCENES_DIR[0] ? AACBVH_SCENES_DIR : "(none)");
}

bool parse(int argc, char **argv, Options &o) {
    for (int i = 1; i < argc; ++i) {
        const Parsed shared = parse_shared_option(argc, argv, i, o.scenes, o.threads, o.runs);
        if (shared == Parsed::Bad) return false;
        if (shared == Parsed::Taken) continue;
        const bool has_value = i + 1 < argc;
        if (!std::strcmp(argv[i], "--builders") && has_value) {
            o.builders.clear();
            for (const std::string &name : split(argv[++i], ',')) {
                aacbvh_builder b;
                if (aacbvh_builder_from_name(name.c_str(), &b) != AACBVH_OK) return false;
                o.builders.push_back(b);
            }
            if (o.builders.empty()) return false;
        } else if (!std::strcmp(argv[i], "--keep-build-memory")) {
            o.keep_build_memory = true;
        } else {
            return false;
        }
    }
    if (o.threads.empty()) o.threads = default_thread_counts();
    return true;
}

constexpr int kPhaseCount = 4;
const char *const kPhaseNames[kPhaseCount] = {"input", "sort", "cluster", "layout"};
constexpr double kMilestones[kPhaseCount] = {0.1, 0.3, 0.8, 1.0};

/// The times at which a build's progress first reached each milestone.
struct Stamps {
    Clock::time_point start;
    Clock::time_point reached[kPhaseCount];
    bool seen[kPhaseCount] = {};
};

bool stamp(void *user, double fraction) {
    Stamps &s = *static_cast<Stamps *>(user);
    const Clock::time_point now = Clock::now();
    // Only the highest milestone reached: a builder that skips 0.3 reports
    // 0.8 next, and its time belongs to the cluster phase, not the sort.
    for (int i = kPhaseCount; i-- > 0;)
        if (fraction >= kMilestones[i]) {
            if (!s.seen[i]) {
                s.seen[i] = true;
                s.reached[i] = now;
            }
            break;
        }
    return true;
}

double ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
}

using Handle = std::unique_ptr<aacbvh_bvh, void (*)(aacbvh_bvh *)>;

/// A handle holding the scene, set up to build with `builder`.
Handle make_handle(aacbvh_context *context, const Scene &scene, aacbvh_builder builder, bool keep_build_memory) {
    aacbvh_bvh *raw = nullptr;
    if (aacbvh_bvh_create(context, &raw) != AACBVH_OK) return Handle(nullptr, aacbvh_bvh_destroy);
    Handle bvh(raw, aacbvh_bvh_destroy);
    if (aacbvh_bvh_set_param_int(raw, AACBVH_PARAM_BUILDER, builder) != AACBVH_OK ||
        aacbvh_bvh_set_param_int(raw, AACBVH_PARAM_KEEP_BUILD_MEMORY, keep_build_memory) != AACBVH_OK ||
        aacbvh_bvh_set_triangles(raw, scene.vertices.data(), scene.vertex_count(), 12, scene.indices.data(),
                                 scene.triangle_count()) != AACBVH_OK) {
        std::fprintf(stderr, "%s: cannot set up a handle: %s\n", scene.name.c_str(), aacbvh_bvh_last_error(raw));
        bvh.reset();
    }
    return bvh;
}

/// One build of `raw`; fills the phase times (ms) and the total, and the tree's SAH.
bool timed_build(aacbvh_bvh *raw, const Scene &scene, double phases[kPhaseCount], double &total, double &sah) {
    Stamps stamps;
    if (aacbvh_bvh_set_progress_callback(raw, stamp, &stamps) != AACBVH_OK) return false;
    stamps.start = Clock::now();
    if (aacbvh_bvh_build(raw) != AACBVH_OK) {
        std::fprintf(stderr, "%s: build failed: %s\n", scene.name.c_str(), aacbvh_bvh_last_error(raw));
        return false;
    }
    const Clock::time_point end = Clock::now();
    Clock::time_point last = stamps.start;
    for (int i = 0; i < kPhaseCount; ++i) {
        // A milestone the builder never reports ends where the previous one did.
        const Clock::time_point at = stamps.seen[i] ? stamps.reached[i] : last;
        phases[i] = ms(at - last);
        last = at;
    }
    phases[kPhaseCount - 1] += ms(end - last); // handing the result over
    total = ms(end - stamps.start);
    aacbvh_stats stats{};
    stats.struct_size = sizeof stats;
    if (aacbvh_bvh_get_stats(raw, &stats) != AACBVH_OK) {
        std::fprintf(stderr, "%s: no stats: %s\n", scene.name.c_str(), aacbvh_bvh_last_error(raw));
        return false;
    }
    sah = stats.sah_cost;
    return true;
}

bool run_scene(const Scene &scene, const Options &opt) {
    bool ok = true;
    for (aacbvh_builder builder : opt.builders) {
        double first_total = 0.0, first_phase[kPhaseCount] = {}, first_sah = 0.0;
        for (size_t ti = 0; ti < opt.threads.size(); ++ti) {
            aacbvh_context *raw = nullptr;
            if (aacbvh_context_create(opt.threads[ti], &raw) != AACBVH_OK) {
                std::fprintf(stderr, "cannot create a context of %u threads\n", opt.threads[ti]);
                return false;
            }
            std::unique_ptr<aacbvh_context, void (*)(aacbvh_context *)> context(raw, aacbvh_context_destroy);
            std::vector<double> phase_runs[kPhaseCount], totals;
            double sah = 0.0;
            // Kept memory: one handle, rebuilt, its first build untimed.
            Handle kept(nullptr, aacbvh_bvh_destroy);
            if (opt.keep_build_memory) {
                kept = make_handle(raw, scene, builder, true);
                if (!kept || aacbvh_bvh_build(kept.get()) != AACBVH_OK) return false;
            }
            for (int r = 0; r < opt.runs; ++r) {
                double phases[kPhaseCount], total = 0.0;
                Handle fresh(nullptr, aacbvh_bvh_destroy);
                if (!opt.keep_build_memory) fresh = make_handle(raw, scene, builder, false);
                aacbvh_bvh *bvh = opt.keep_build_memory ? kept.get() : fresh.get();
                if (!bvh || !timed_build(bvh, scene, phases, total, sah)) return false;
                for (int i = 0; i < kPhaseCount; ++i) phase_runs[i].push_back(phases[i]);
                totals.push_back(total);
            }
            double med[kPhaseCount];
            for (int i = 0; i < kPhaseCount; ++i) med[i] = median(phase_runs[i]);
            const double total = median(totals);
            if (ti == 0) {
                first_total = total;
                std::copy(med, med + kPhaseCount, first_phase);
                first_sah = sah;
            }
            const bool same = std::memcmp(&sah, &first_sah, sizeof sah) == 0;
            ok = ok && same;
            std::printf("%-18s %-10s %4u", scene.name.c_str(), aacbvh_builder_name(builder), opt.threads[ti]);
            for (int i = 0; i < kPhaseCount; ++i) {
                if (ti == 0 || med[i] <= 0.0)
                    std::printf("  %8.2f       ", med[i]);
                else
                    std::printf("  %8.2f %5.2fx", med[i], first_phase[i] / med[i]);
            }
            std::printf("  %8.2f %5.2fx  %8.2f-%-8.2f%s\n", total, total > 0.0 ? first_total / total : 0.0,
                        *std::min_element(totals.begin(), totals.end()),
                        *std::max_element(totals.begin(), totals.end()), same ? "" : "  TREE DIFFERS");
        }
    }
    return ok;
}

} // namespace

int main(int argc, char **argv) {
    Options opt;
    if (!parse(argc, argv, opt)) {
        usage(argv[0]);
        return 2;
    }
    print_machine_line("aacbvh-build-phases");
    std::printf("%s, default parameters, median of %d builds in ms (speedup over %u thread%s)\n",
                opt.keep_build_memory ? "one handle rebuilt with kept build memory" : "fresh handle per build",
                opt.runs, opt.threads[0], opt.threads[0] == 1 ? "" : "s");
    std::printf("%-18s %-10s %4s", "scene", "builder", "thr");
    for (const char *name : kPhaseNames) std::printf("  %-15s", name);
    std::printf("  %-15s  %s\n", "total", "total min-max");
    const bool ok = for_each_scene(opt.scenes, AACBVH_SCENES_DIR, "aacbvh-build-phases",
                                   [&](const Scene &scene) { return run_scene(scene, opt); });
    return ok ? 0 : 1;
}
