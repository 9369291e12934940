// aacbvh-hit-accuracy: how exact are the hit distances, ours against Embree's.
//
// For every scene: primary rays from the benchmark's camera (rays.h) and
// diffuse rays from their hits, traced with libaacbvh and, when compiled in
// (AACBVH_BENCH_HAVE_EMBREE), with Embree 3's own scene and rtcIntersect1. For
// every hit, the exact distance is the double-precision ray-plane distance to
// the triangle the library reported,
//     n = (p1 - p0) x (p2 - p0),  t_exact = (p0 - org) . n / (dir . n),
// and the relative error is |t - t_exact| / |t_exact| (hits with t_exact == 0 or
// a ray nearly parallel to the plane, |cos| < 1e-6, are left out). Prints the
// largest error, the 99.9th and 99th percentiles and the median per scene, ray
// kind and library, how often the two libraries disagree, and the single-thread
// trace times (median of --runs), as Markdown tables.
//
//   aacbvh-hit-accuracy [options]      (aacbvh-hit-accuracy --help)
#include <aacbvh/aacbvh.h>

#include "cli.h"
#include "rays.h"
#include "scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#ifdef AACBVH_BENCH_HAVE_EMBREE
#include <embree3/rtcore.h>

#include "embree_ray.h"
#endif

#ifndef AACBVH_SCENES_DIR
#define AACBVH_SCENES_DIR ""
#endif

using namespace bench;

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Two libraries' hits on the same triangle whose t differ by more than this,
/// relative to Embree's t, are counted.
constexpr double kAgreeTolerance = 1e-4;
/// Hits of rays more nearly parallel to the triangle's plane are not measured.
constexpr double kMinCos = 1e-6;

// The two ray kinds measured, in rays.h's numbering.
constexpr int kKinds[] = {kPrimary, kDiffuse};
constexpr int kKindCount = 2;

struct Options {
    std::vector<std::string> scenes;
    uint32_t size = 362;  // 362 x 362 = 131 044 primary rays
    int runs = 3;
    int layout = AACBVH_LAYOUT_BINARY;
    int triangles = AACBVH_TRIANGLES_REFERENCED;
    bool embree = true;
    std::string markdown;
};

bool embree_compiled() {
#ifdef AACBVH_BENCH_HAVE_EMBREE
    return true;
#else
    return false;
#endif
}

std::string embree_label() {
#ifdef AACBVH_BENCH_HAVE_EMBREE
    return "Embree " + std::to_string(RTC_VERSION_MAJOR) + "." + std::to_string(RTC_VERSION_MINOR) + "." +
           std::to_string(RTC_VERSION_PATCH);
#else
    return "Embree (not compiled in)";
#endif
}

void usage(FILE *out) {
    std::fprintf(out,
        "usage: aacbvh-hit-accuracy [options]\n"
        "How exact the hit distances t are: for every hit, the relative error against\n"
        "the double-precision ray-plane distance to the triangle the library reported,\n"
        "for libaacbvh and Embree 3 (%s), on primary rays and diffuse\n"
        "rays from their hits; also the single-thread time to trace each ray set.\n"
        "\n"
        "options:\n"
        "  --scenes LIST     comma-separated OBJ paths, names of OBJ files in the scenes\n"
        "                    directory, 'procedural' (about 240 K triangles) or\n"
        "                    'procedural-small' (about 3 K); default: sponza_dabrovic and\n"
        "                    conference from %s, else 'procedural'\n"
        "  --size N          primary rays: an N x N image (default 362, about 131 K rays)\n"
        "  --runs N          timed passes over each ray set; the median is reported (default 3)\n"
        "  --layout L        AACBVH_PARAM_TRAVERSAL_LAYOUT: binary (default) or wide4\n"
        "  --triangles S     AACBVH_PARAM_TRIANGLE_STORAGE: referenced (default) or copied\n"
        "  --no-embree       leave Embree out\n"
        "  --markdown FILE   also write the report to FILE\n"
        "  -h, --help        this text\n",
        embree_compiled() ? embree_label().c_str() : "not compiled in",
        AACBVH_SCENES_DIR[0] ? AACBVH_SCENES_DIR : "(no scenes directory compiled in)");
}

bool parse_args(int argc, char **argv, Options &opt) {
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> const char * {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "aacbvh-hit-accuracy: %s needs a value\n", a.c_str());
                return nullptr;
            }
            return argv[++i];
        };
        uint64_t v = 0;
        if (a == "-h" || a == "--help") {
            usage(stdout);
            std::exit(0);
        } else if (a == "--scenes") {
            const char *s = next();
            if (!s) return false;
            for (const std::string &p : split(s, ',')) opt.scenes.push_back(p);
        } else if (a == "--size") {
            const char *s = next();
            if (!s || !parse_uint(s, v) || v < 1 || v > 16384) {
                std::fprintf(stderr, "aacbvh-hit-accuracy: --size takes 1 to 16384\n");
                return false;
            }
            opt.size = uint32_t(v);
        } else if (a == "--runs") {
            const char *s = next();
            if (!s || !parse_uint(s, v) || v < 1 || v > 1000) {
                std::fprintf(stderr, "aacbvh-hit-accuracy: --runs takes 1 to 1000\n");
                return false;
            }
            opt.runs = int(v);
        } else if (a == "--layout") {
            const char *s = next();
            if (!s) return false;
            if (std::string(s) == "binary") opt.layout = AACBVH_LAYOUT_BINARY;
            else if (std::string(s) == "wide4") opt.layout = AACBVH_LAYOUT_WIDE4;
            else {
                std::fprintf(stderr, "aacbvh-hit-accuracy: --layout takes binary or wide4\n");
                return false;
            }
        } else if (a == "--triangles") {
            const char *s = next();
            if (!s) return false;
            if (std::string(s) == "referenced") opt.triangles = AACBVH_TRIANGLES_REFERENCED;
            else if (std::string(s) == "copied") opt.triangles = AACBVH_TRIANGLES_COPIED;
            else {
                std::fprintf(stderr, "aacbvh-hit-accuracy: --triangles takes referenced or copied\n");
                return false;
            }
        } else if (a == "--no-embree") {
            opt.embree = false;
        } else if (a == "--markdown") {
            const char *s = next();
            if (!s) return false;
            opt.markdown = s;
        } else {
            std::fprintf(stderr, "aacbvh-hit-accuracy: unknown argument %s (see --help)\n", a.c_str());
            return false;
        }
    }
    if (!embree_compiled()) opt.embree = false;
    return true;
}

std::string scene_path(const std::string &name) {
    return std::string(AACBVH_SCENES_DIR) + "/" + name;
}

bool file_exists(const std::string &path) { return std::ifstream(path).good(); }

/// Resolves a --scenes entry to a loaded scene.
bool load_scene(const std::string &spec, Scene &scene, std::string &err) {
    return load_scene_spec(spec, AACBVH_SCENES_DIR, scene, err);
}

double median(std::vector<double> v) {
    if (v.empty()) return kNaN;
    std::sort(v.begin(), v.end());
    const size_t m = v.size() / 2;
    return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

/// A closest hit reduced to what is compared: the triangle and t.
struct Hit {
    uint32_t prim = AACBVH_INVALID_ID;
    float t = std::numeric_limits<float>::infinity();
    bool hit() const { return prim != AACBVH_INVALID_ID; }
};

/// One library's hits of one ray set, and the seconds per timed pass.
struct Trace {
    bool ran = false;
    std::vector<Hit> hits;
    std::vector<double> seconds;
};

struct BvhDeleter {
    void operator()(aacbvh_bvh *b) const { aacbvh_bvh_destroy(b); }
};

// ---- libaacbvh ----

bool trace_ours(const aacbvh_bvh *bvh, const std::vector<aacbvh_ray> &rays, int runs, Trace &out,
                std::string &err) {
    std::vector<aacbvh_hit> hits(rays.size());
    for (int r = 0; r < runs; ++r) {
        const auto t0 = Clock::now();
        if (aacbvh_bvh_intersect(bvh, rays.data(), hits.data(), hits.size()) != AACBVH_OK) {
            err = aacbvh_bvh_last_error(bvh);
            return false;
        }
        out.seconds.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    }
    out.hits.resize(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) {
        out.hits[i].prim = hits[i].prim_id;
        out.hits[i].t = hits[i].t;
    }
    out.ran = true;
    return true;
}

// ---- Embree ----

#ifdef AACBVH_BENCH_HAVE_EMBREE
/// Embree's own scene over the same vertex and index buffers, on a one-thread device.
class EmbreeScene {
  public:
    bool init(const Scene &scene, std::string &err) {
        device_ = rtcNewDevice("threads=1");
        if (!device_) {
            err = "rtcNewDevice failed";
            return false;
        }
        // Shared vertex buffers must be readable 16 bytes past the last vertex's
        // start: 4 floats of padding after the last x, y, z.
        padded_ = scene.vertices;
        padded_.resize(padded_.size() + 4, 0.0f);
        scene_ = rtcNewScene(device_);
        RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, padded_.data(), 0,
                                   3 * sizeof(float), scene.vertex_count());
        rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, scene.indices.data(), 0,
                                   3 * sizeof(uint32_t), scene.triangle_count());
        rtcCommitGeometry(geom);
        rtcAttachGeometry(scene_, geom);
        rtcReleaseGeometry(geom);
        rtcCommitScene(scene_);
        const RTCError e = rtcGetDeviceError(device_);
        if (e != RTC_ERROR_NONE) {
            err = "Embree scene build failed (RTCError " + std::to_string(int(e)) + ")";
            return false;
        }
        return true;
    }

    void trace(const std::vector<aacbvh_ray> &rays, int runs, Trace &out) const {
        out.hits.assign(rays.size(), Hit());
        for (int run = 0; run < runs; ++run) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            const auto t0 = Clock::now();
            for (size_t i = 0; i < rays.size(); ++i) {
                const aacbvh_ray &r = rays[i];
                RTCRayHit rh = embree_ray_hit(r);
                rtcIntersect1(scene_, &context, &rh);
                Hit &h = out.hits[i];
                if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
                    h.prim = rh.hit.primID;
                    h.t = rh.ray.tfar;
                } else {
                    h = Hit();
                }
            }
            out.seconds.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
        }
        out.ran = true;
    }

    ~EmbreeScene() {
        if (scene_) rtcReleaseScene(scene_);
        if (device_) rtcReleaseDevice(device_);
    }

  private:
    RTCDevice device_ = nullptr;
    RTCScene scene_ = nullptr;
    std::vector<float> padded_;
};
#endif

// ---- the exact distance and the error statistics ----

/// The double-precision distance along `ray` to the plane of triangle `prim`;
/// false for a degenerate triangle, a ray nearly parallel to the plane or
/// t_exact == 0 (the hit is then not measured).
bool exact_t(const Scene &scene, const aacbvh_ray &ray, uint32_t prim, double &t_exact) {
    const uint32_t *tri = &scene.indices[3 * size_t(prim)];
    double p[3][3];
    for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 3; ++a) p[k][a] = scene.vertices[3 * size_t(tri[k]) + a];
    const double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
    const double d[3] = {ray.dir[0], ray.dir[1], ray.dir[2]};
    const double dn = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
    const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) *
                       std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0.0) || std::fabs(dn) < kMinCos * len) return false;
    const double po[3] = {p[0][0] - ray.org[0], p[0][1] - ray.org[1], p[0][2] - ray.org[2]};
    t_exact = (po[0] * n[0] + po[1] * n[1] + po[2] * n[2]) / dn;
    return t_exact != 0.0 && std::isfinite(t_exact);
}

struct Worst {
    size_t ray = 0;
    uint32_t prim = AACBVH_INVALID_ID;
    double t = kNaN, t_exact = kNaN;
};

/// The error figures of one library on one ray set.
struct ErrorStats {
    bool ran = false;
    size_t rays = 0, hits = 0, measured = 0;
    double max = kNaN, p999 = kNaN, p99 = kNaN, median = kNaN;
    double seconds = kNaN;  // median of the timed passes
    Worst worst;
};

/// The value at quantile q of sorted values (nearest rank).
double quantile(const std::vector<double> &sorted, double q) {
    if (sorted.empty()) return kNaN;
    size_t rank = size_t(std::ceil(q * double(sorted.size())));
    rank = std::min(std::max<size_t>(rank, 1), sorted.size());
    return sorted[rank - 1];
}

ErrorStats measure(const Scene &scene, const std::vector<aacbvh_ray> &rays, const Trace &trace) {
    ErrorStats s;
    if (!trace.ran) return s;
    s.ran = true;
    s.rays = rays.size();
    s.seconds = median(trace.seconds);
    std::vector<double> errors;
    errors.reserve(rays.size());
    double worst = -1.0;
    for (size_t i = 0; i < rays.size(); ++i) {
        const Hit &h = trace.hits[i];
        if (!h.hit()) continue;
        ++s.hits;
        double t_exact = 0.0;
        if (h.prim >= scene.triangle_count() || !exact_t(scene, rays[i], h.prim, t_exact)) continue;
        const double e = std::fabs(double(h.t) - t_exact) / std::fabs(t_exact);
        errors.push_back(e);
        if (e > worst) {
            worst = e;
            s.worst = {i, h.prim, double(h.t), t_exact};
        }
    }
    s.measured = errors.size();
    std::sort(errors.begin(), errors.end());
    if (!errors.empty()) {
        s.max = errors.back();
        s.p999 = quantile(errors, 0.999);
        s.p99 = quantile(errors, 0.99);
        s.median = quantile(errors, 0.5);
    }
    return s;
}

/// Where the two libraries' hits of one ray set disagree.
struct Agreement {
    bool ran = false;
    size_t both_hit = 0;        // rays both libraries hit
    size_t same_prim = 0;       // ... on the same triangle
    size_t t_differs = 0;       // ... with |t_ours - t_embree| > kAgreeTolerance * |t_embree|
    size_t prim_differs = 0;    // rays whose reported triangle differs (hit / miss included)
    size_t hit_miss = 0;        // ... of which one library hit and the other missed
    double max_t_diff = kNaN;   // largest relative t difference on the same triangle
};

Agreement compare(const Trace &ours, const Trace &embree) {
    Agreement a;
    if (!ours.ran || !embree.ran) return a;
    a.ran = true;
    double max_diff = 0.0;
    for (size_t i = 0; i < ours.hits.size(); ++i) {
        const Hit &o = ours.hits[i], &e = embree.hits[i];
        if (o.prim != e.prim) {
            ++a.prim_differs;
            if (o.hit() != e.hit()) ++a.hit_miss;
        }
        if (!o.hit() || !e.hit()) continue;
        ++a.both_hit;
        if (o.prim != e.prim) continue;
        ++a.same_prim;
        const double diff = std::fabs(double(o.t) - double(e.t));
        const double rel = e.t != 0.0f ? diff / std::fabs(double(e.t)) : (diff > 0.0 ? INFINITY : 0.0);
        max_diff = std::max(max_diff, rel);
        if (rel > kAgreeTolerance) ++a.t_differs;
    }
    a.max_t_diff = a.same_prim ? max_diff : kNaN;
    return a;
}

// ---- the report ----

struct KindResult {
    int kind = kPrimary;
    ErrorStats ours, embree;
    Agreement agree;
};

struct SceneResult {
    std::string name;
    size_t triangles = 0;
    KindResult kinds[kKindCount];
};

std::string fmt(const char *format, double v) {
    if (std::isnan(v)) return "–";
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}

std::string count(size_t v) { return std::to_string(v); }

std::string error_cell(double v) {
    if (std::isnan(v)) return "–";
    if (v == 0.0) return "0";
    return fmt("%.2g", v);
}

std::string ours_label(const Options &opt) {
    return std::string("libaacbvh ") + aacbvh_version_string() + " (" +
           (opt.layout == AACBVH_LAYOUT_WIDE4 ? "wide4" : "binary") + ", " +
           (opt.triangles == AACBVH_TRIANGLES_COPIED ? "copied" : "referenced") + ")";
}

std::string report(const Options &opt, const std::vector<SceneResult> &results) {
    std::string r;
    r += "# Hit-distance accuracy\n\n";
    r += "CPU: " + cpu_name() + "  \n";
    r += "libaacbvh " + std::string(aacbvh_version_string()) + ", traversal layout " +
         (opt.layout == AACBVH_LAYOUT_WIDE4 ? "wide4" : "binary") + ", triangles " +
         (opt.triangles == AACBVH_TRIANGLES_COPIED ? "copied" : "referenced") + "; " +
         (opt.embree ? embree_label() + " (own scene, default flags, rtcIntersect1)"
                     : embree_compiled() ? std::string("Embree left out (--no-embree)")
                                         : std::string("Embree not compiled in")) +
         "  \n";
    r += "Primary rays: " + std::to_string(opt.size) + " x " + std::to_string(opt.size) +
         " image; diffuse rays: one per primary hit. One thread; trace time is the median of " +
         std::to_string(opt.runs) + " passes.  \n";
    r += "Error of a hit: |t - t_exact| / |t_exact|, t_exact the double-precision ray-plane distance to the "
         "triangle the library reported (hits with |cos| < 1e-6 or t_exact = 0 not measured).\n\n";

    r += "| scene | rays | library | hits | measured | max rel. error | 99.9th pct | 99th pct | median | trace ms | Mrays/s |\n";
    r += "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const SceneResult &s : results) {
        for (const KindResult &k : s.kinds) {
            const ErrorStats *libs[2] = {&k.ours, &k.embree};
            const std::string labels[2] = {ours_label(opt), embree_label()};
            for (int l = 0; l < 2; ++l) {
                const ErrorStats &e = *libs[l];
                if (!e.ran) continue;
                r += "| " + s.name + " | " + ray_kind_name(k.kind) + " (" + count(e.rays) + ") | " + labels[l] +
                     " | " + count(e.hits) + " | " + count(e.measured) + " | " + error_cell(e.max) + " | " +
                     error_cell(e.p999) + " | " + error_cell(e.p99) + " | " + error_cell(e.median) + " | " +
                     fmt("%.1f", 1e3 * e.seconds) + " | " +
                     fmt("%.2f", e.seconds > 0 ? 1e-6 * double(e.rays) / e.seconds : kNaN) + " |\n";
            }
        }
    }

    bool any_agreement = false;
    for (const SceneResult &s : results)
        for (const KindResult &k : s.kinds) any_agreement |= k.agree.ran;
    if (any_agreement) {
        r += "\nOurs against Embree, ray by ray:\n\n";
        r += "| scene | rays | both hit | same triangle | same triangle, t differs > 1e-4 | largest t difference | "
             "triangle differs | of which hit / miss |\n";
        r += "|---|---|---:|---:|---:|---:|---:|---:|\n";
        for (const SceneResult &s : results) {
            for (const KindResult &k : s.kinds) {
                const Agreement &a = k.agree;
                if (!a.ran) continue;
                r += "| " + s.name + " | " + ray_kind_name(k.kind) + " (" + count(k.ours.rays) + ") | " +
                     count(a.both_hit) + " | " + count(a.same_prim) + " | " + count(a.t_differs) + " | " +
                     error_cell(a.max_t_diff) + " | " + count(a.prim_differs) + " | " + count(a.hit_miss) + " |\n";
            }
        }
        r += "\n\"t differs\" and \"largest t difference\" are relative to Embree's t.\n";
    }

    r += "\nLargest errors (ray index, triangle, t reported, t exact):\n\n";
    for (const SceneResult &s : results) {
        for (const KindResult &k : s.kinds) {
            const ErrorStats *libs[2] = {&k.ours, &k.embree};
            const char *names[2] = {"ours", "Embree"};
            for (int l = 0; l < 2; ++l) {
                const ErrorStats &e = *libs[l];
                if (!e.ran || !e.measured) continue;
                char buf[256];
                std::snprintf(buf, sizeof buf, "- %s %s, %s: ray %zu, triangle %u, t %.9g, t_exact %.9g\n",
                              s.name.c_str(), ray_kind_name(k.kind), names[l], e.worst.ray, e.worst.prim,
                              e.worst.t, e.worst.t_exact);
                r += buf;
            }
        }
    }
    return r;
}

bool run_scene(const Scene &scene, const Options &opt, aacbvh_context *ctx, SceneResult &res) {
    res.name = scene.name;
    res.triangles = scene.triangle_count();
    const Bounds bounds = vertex_bounds(scene.vertices);
    const Camera camera = camera_for_scene(scene.name, bounds);

    aacbvh_bvh *raw = nullptr;
    if (aacbvh_bvh_create(ctx, &raw) != AACBVH_OK) {
        std::fprintf(stderr, "aacbvh-hit-accuracy: %s: cannot create a BVH: %s\n", scene.name.c_str(),
                     aacbvh_last_error());
        return false;
    }
    std::unique_ptr<aacbvh_bvh, BvhDeleter> bvh(raw);
    if (aacbvh_bvh_set_param_int(raw, AACBVH_PARAM_TRAVERSAL_LAYOUT, opt.layout) != AACBVH_OK ||
        aacbvh_bvh_set_param_int(raw, AACBVH_PARAM_TRIANGLE_STORAGE, opt.triangles) != AACBVH_OK ||
        aacbvh_bvh_set_triangles(raw, scene.vertices.data(), scene.vertex_count(), 3 * sizeof(float),
                                 scene.indices.data(), scene.triangle_count()) != AACBVH_OK ||
        aacbvh_bvh_build(raw) != AACBVH_OK) {
        std::fprintf(stderr, "aacbvh-hit-accuracy: %s: %s\n", scene.name.c_str(), aacbvh_bvh_last_error(raw));
        return false;
    }

    // The rays: primary, then diffuse from our primary hits (both libraries
    // trace the same diffuse rays).
    std::vector<aacbvh_ray> sets[kKindCount];
    Trace ours[kKindCount], embree[kKindCount];
    std::string err;
    sets[0] = make_primary_rays(camera, opt.size, opt.size);
    if (!trace_ours(raw, sets[0], opt.runs, ours[0], err)) {
        std::fprintf(stderr, "aacbvh-hit-accuracy: %s: %s\n", scene.name.c_str(), err.c_str());
        return false;
    }
    {
        std::vector<aacbvh_hit> hits(sets[0].size());
        for (size_t i = 0; i < hits.size(); ++i) {
            hits[i].t = ours[0].hits[i].t;
            hits[i].u = hits[i].v = 0.0f;
            hits[i].prim_id = ours[0].hits[i].prim;
        }
        std::vector<aacbvh_ray> shadow;
        make_secondary_rays(sets[0], hits, scene.vertices, scene.indices, camera, bounds.diagonal(), 0x5EED, shadow,
                            sets[1]);
    }
    if (!trace_ours(raw, sets[1], opt.runs, ours[1], err)) {
        std::fprintf(stderr, "aacbvh-hit-accuracy: %s: %s\n", scene.name.c_str(), err.c_str());
        return false;
    }

#ifdef AACBVH_BENCH_HAVE_EMBREE
    if (opt.embree) {
        EmbreeScene es;
        if (!es.init(scene, err)) {
            std::fprintf(stderr, "aacbvh-hit-accuracy: %s: %s\n", scene.name.c_str(), err.c_str());
            return false;
        }
        for (int k = 0; k < kKindCount; ++k) es.trace(sets[k], opt.runs, embree[k]);
    }
#endif

    for (int k = 0; k < kKindCount; ++k) {
        KindResult &kr = res.kinds[k];
        kr.kind = kKinds[k];
        kr.ours = measure(scene, sets[k], ours[k]);
        kr.embree = measure(scene, sets[k], embree[k]);
        kr.agree = compare(ours[k], embree[k]);
    }
    return true;
}

}  // namespace

int main(int argc, char **argv) {
    Options opt;
    if (!parse_args(argc, argv, opt)) return 2;

    std::vector<std::string> specs = opt.scenes;
    if (specs.empty() && AACBVH_SCENES_DIR[0]) {
        for (const char *name : {"sponza_dabrovic.obj", "conference.obj"})
            if (file_exists(scene_path(name))) specs.push_back(scene_path(name));
    }
    if (specs.empty()) specs.push_back("procedural");

    aacbvh_context *ctx = nullptr;
    if (aacbvh_context_create(1, &ctx) != AACBVH_OK) {
        std::fprintf(stderr, "aacbvh-hit-accuracy: cannot create a context: %s\n", aacbvh_last_error());
        return 1;
    }
    std::vector<SceneResult> results;
    bool ok = true;
    for (const std::string &spec : specs) {
        Scene scene;
        std::string err;
        if (!load_scene(spec, scene, err)) {
            std::fprintf(stderr, "aacbvh-hit-accuracy: %s: %s\n", spec.c_str(), err.c_str());
            ok = false;
            continue;
        }
        std::fprintf(stderr, "[%s] %zu triangles\n", scene.name.c_str(), scene.triangle_count());
        SceneResult res;
        if (run_scene(scene, opt, ctx, res)) results.push_back(res);
        else ok = false;
    }
    aacbvh_context_destroy(ctx);

    const std::string text = report(opt, results);
    std::fputs(text.c_str(), stdout);
    if (!opt.markdown.empty()) {
        std::ofstream f(opt.markdown);
        f << text;
        if (!f) {
            std::fprintf(stderr, "aacbvh-hit-accuracy: cannot write %s\n", opt.markdown.c_str());
            ok = false;
        }
    }
    return ok && !results.empty() ? 0 : 1;
}
