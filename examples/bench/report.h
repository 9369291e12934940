// The benchmark's results and their outputs: a console table, CSV, JSON, an SVG
// plot (build time against ray cost, a panel per scene), a Markdown report
// (docs/EVALUATION.md), a reader of the JSON (for --replot), and small
// validators of the written files for --self-check.
#pragma once

#include "rays.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

namespace bench {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Build times at one thread count, in milliseconds.
struct BuildTiming {
    uint32_t threads = 1;
    double median_ms = kNaN;
    double min_ms = kNaN;
    double max_ms = kNaN;
    int runs = 0;
};

/// Views with fewer rays of a kind than this are left out of
/// ViewFigures::rel_time_worst_timed: a batch of a few dozen shadow rays (a
/// view whose primary rays mostly miss, or whose hits are mostly in shadow)
/// times the call's overhead and the caches' state more than the tree.
constexpr uint64_t kTimedViewRays = 1024;

/// One ray kind over the in-scene views (issue 17): each view's figure,
/// summarised over the views. "Worst" is the worst view for that figure alone.
struct ViewFigures {
    double steps_mean = kNaN, steps_worst = kNaN;  ///< boxes tested per ray: mean over views, most on one view
    double tests_mean = kNaN, tests_worst = kNaN;  ///< triangle tests per ray: mean over views, most on one view
    double mrays_mean = kNaN, mrays_worst = kNaN;  ///< Mrays/s, 1 thread: all views' rays / all views' time, slowest view
    /// (steps + tests) per ray / sweep SAH's on the same view: geometric mean over views, highest
    double rel_cost_mean = kNaN, rel_cost_worst = kNaN;
    /// trace time / sweep SAH's on the same view: geometric mean over views, highest
    double rel_time_mean = kNaN, rel_time_worst = kNaN;
    /// the highest trace time / sweep SAH's among the views with at least
    /// kTimedViewRays rays of this kind (none: NaN)
    double rel_time_worst_timed = kNaN;
};

/// One view and ray kind as measured, before it is summarised (not written out).
struct ViewSample {
    double steps = kNaN, tests = kNaN;  ///< per ray
    double seconds = kNaN;              ///< median trace time of the view's rays of this kind
    uint64_t rays = 0;
};

/// One builder on one scene.
struct Row {
    std::string builder;   ///< command-line id: "aac-hq", ..., "embree-low", "embree-medium", "embree-scene"
    std::string label;     ///< display name
    std::string status;    ///< "ok", "n/a" (builder not in this library build), "skipped", "error"
    std::string note;      ///< why not ok, or a remark
    std::vector<BuildTiming> timings;  ///< one per thread count that ran
    double sah = kNaN;
    double cost[kRayKindCount] = {kNaN, kNaN, kNaN};      ///< mean steps + tests per ray
    double steps[kRayKindCount] = {kNaN, kNaN, kNaN};     ///< mean traversal steps per ray
    double rel_cost[kRayKindCount] = {kNaN, kNaN, kNaN};  ///< cost / sweep SAH's cost
    double mrays[kRayKindCount] = {kNaN, kNaN, kNaN};     ///< million rays per second, 1 thread
    double bytes_per_triangle = kNaN;
    /// Sibling overlap of the tree (ray_cost.h, overlap_of): by area and by volume.
    double overlap_area = kNaN, overlap_volume = kNaN;
    ViewFigures views[kRayKindCount];  ///< over the scene's in-scene views, when it has some
    std::vector<ViewSample> view_samples[kRayKindCount];  ///< per view, for the summaries

    /// Median build time at `threads`, NaN when that count did not run.
    double build_ms(uint32_t threads) const;
    /// Mean of the three relative costs (the SVG's y), NaN if any is missing.
    double mean_rel_cost() const;
};

struct SceneResult {
    std::string name;
    std::string source;  ///< file path or "generated"
    uint64_t triangles = 0;
    Camera camera{};
    uint32_t width = 0, height = 0;
    uint64_t ray_counts[kRayKindCount] = {0, 0, 0};
    uint32_t views = 0;                     ///< in-scene views (0: none measured)
    uint32_t view_width = 0, view_height = 0;  ///< primary rays per view
    uint64_t view_ray_counts[kRayKindCount] = {0, 0, 0};  ///< over all views
    /// The default tree (AAC-HQ) against Embree's scene on the camera's rays,
    /// passes alternating (embree_bench.h): the median over the rounds of
    /// Embree's time over ours per kind (above 1: we trace faster); NaN when
    /// not measured.
    double head_to_head[kRayKindCount] = {kNaN, kNaN, kNaN};
    std::vector<Row> rows;

    /// Fills every row's `views` from its view_samples, the relative figures
    /// against the sweep-sah row's samples of the same view.
    void summarise_views();

    const Row *find(const std::string &builder) const;
};

struct RunInfo {
    std::string command;
    std::string library_version;
    std::string embree_version;
    std::string cpu;
    unsigned hardware_threads = 0;
    std::vector<uint32_t> threads;  ///< thread counts timed; the first is the table's
    int runs = 0;
    std::string date;
};

/// The console table of one scene.
void print_scene(FILE *out, const SceneResult &scene, const RunInfo &info);

bool write_csv(const std::string &path, const std::vector<SceneResult> &scenes, const RunInfo &info,
               std::string &err);
bool write_json(const std::string &path, const std::vector<SceneResult> &scenes, const RunInfo &info,
                std::string &err);
bool write_svg(const std::string &path, const std::vector<SceneResult> &scenes, const RunInfo &info,
               std::string &err);
bool write_markdown(const std::string &path, const std::vector<SceneResult> &scenes, const RunInfo &info,
                    std::string &err);

/// Reads a file write_json() wrote back into results (--replot: the other
/// outputs again without rerunning the benchmark). Values written as null come
/// back as NaN; the cameras' up vector, not in the file, comes back as +y.
bool read_json(const std::string &path, std::vector<SceneResult> &scenes, RunInfo &info, std::string &err);

/// The Pareto front of points (x[i], y[i]), lower being better on both axes:
/// the indices of the points no other point beats, that is, none has x <= and
/// y <= with one of them strictly less. Sorted by x (then y); of identical
/// points only the first is kept. NaN points are never on the front.
std::vector<size_t> pareto_front(const std::vector<double> &x, const std::vector<double> &y);

/// Validators for --self-check: each reads the file back and checks its syntax
/// (CSV: a header and rows of as many fields; JSON: a complete parse; SVG:
/// balanced elements under one <svg> root). false with a message on failure.
bool check_csv_file(const std::string &path, std::string &err);
bool check_json_file(const std::string &path, std::string &err);
bool check_svg_file(const std::string &path, std::string &err);
bool check_markdown_file(const std::string &path, std::string &err);

/// The CSV's column count (the header's fields).
size_t csv_column_count();

}  // namespace bench
