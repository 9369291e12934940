/* A game-engine loop over libaacbvh, in C99: a mesh is deformed every frame
 * (bent, twisted and rippled in place), the BVH is refitted, and it is rebuilt
 * when refits have let its SAH cost grow past a threshold:
 *
 *     each frame:  move vertices in place
 *                  aacbvh_bvh_refit(bvh)
 *                  aacbvh_bvh_get_stats(bvh, &s)
 *                  if (s.sah_cost > threshold * s.built_sah_cost) aacbvh_bvh_build(bvh)
 *
 * built_sah_cost is the cost right after the last build, sah_cost the cost now,
 * so their ratio is how much worse refitting has made the tree. At the end, the
 * refitted tree must answer rays as a fresh build over the same vertices does.
 * Prints per-frame refit, stats and rebuild times and the cost drift.
 *
 * Then the same animation again under three policies side by side: refit
 * only, refit then one pass of aacbvh_bvh_optimize() (since 1.2), and a
 * rebuild every frame; a table of time per frame and SAH over a fresh
 * build's, and with --svg FILE a plot of that ratio over the frames.
 *
 * usage: animated [--frames N] [--threads N] [--threshold R] [--builder NAME]
 *                 [--triangles N] [--amplitude A] [--svg FILE] [--verbose] [scene.obj]
 */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <aacbvh/aacbvh.h>

#include "random.h"
#include "scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define PI 3.14159265358979323846

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return 1e3 * (double)ts.tv_sec + 1e-6 * (double)ts.tv_nsec;
}

/* A bumpy upright tube (a tentacle) of about `triangles` triangles, 4 units
 * tall: rings x segments quads, closed around. */
static int make_tube(size_t triangles, scene_mesh *m) {
    size_t segments = (size_t)sqrt((double)triangles / 8.0);
    size_t rings, r, s;
    float *v;
    uint32_t *t;
    if (segments < 8) segments = 8;
    rings = triangles / (2 * segments);
    if (rings < 2) rings = 2;
    m->vertex_count = (rings + 1) * segments;
    m->triangle_count = 2 * rings * segments;
    m->vertices = v = (float *)malloc(3 * m->vertex_count * sizeof(float));
    m->indices = t = (uint32_t *)malloc(3 * m->triangle_count * sizeof(uint32_t));
    if (!v || !t) return 0;
    for (r = 0; r <= rings; ++r) {
        double h = (double)r / (double)rings;
        for (s = 0; s < segments; ++s, v += 3) {
            double a = 2.0 * PI * (double)s / (double)segments;
            double radius = 0.5 * (1.0 - 0.6 * h) * (1.0 + 0.08 * sin(7.0 * a) * sin(23.0 * h));
            v[0] = (float)(radius * cos(a));
            v[1] = (float)(4.0 * h);
            v[2] = (float)(radius * sin(a));
        }
    }
    for (r = 0; r < rings; ++r)
        for (s = 0; s < segments; ++s, t += 6) {
            uint32_t a = (uint32_t)(r * segments + s), b = (uint32_t)(r * segments + (s + 1) % segments);
            uint32_t c = a + (uint32_t)segments, d = b + (uint32_t)segments;
            t[0] = a, t[1] = b, t[2] = d;
            t[3] = a, t[4] = d, t[5] = c;
        }
    return 1;
}

/* Bounds of the rest pose, for the deformation and the check rays. */
typedef struct bounds {
    float lo[3], hi[3];
} bounds;

static bounds mesh_bounds(const float *v, size_t n) {
    bounds b;
    scene_bounds(v, n, b.lo, b.hi);
    return b;
}

/* The pose at time t: with h the height in [0, 1] above the base, each vertex
 * is twisted about the vertical axis by up to 180 degrees (times amplitude),
 * bent sideways by up to 90 degrees about the base, and rippled. */
static void deform(const float *rest, float *out, size_t n, const bounds *b, double t, double amplitude) {
    double cx = 0.5 * (b->lo[0] + b->hi[0]), cz = 0.5 * (b->lo[2] + b->hi[2]);
    double height = b->hi[1] - b->lo[1] > 0 ? b->hi[1] - b->lo[1] : 1.0;
    double twist_max = amplitude * PI * sin(0.7 * t), bend_max = amplitude * 0.5 * PI * sin(t);
    size_t i;
    for (i = 0; i < n; ++i) {
        double x = rest[3 * i] - cx, y = rest[3 * i + 1] - b->lo[1], z = rest[3 * i + 2] - cz;
        double h = y / height;
        double twist = twist_max * h, ct = cos(twist), st = sin(twist);
        double tx = ct * x - st * z, tz = st * x + ct * z;
        double bend = bend_max * h * h, cb = cos(bend), sb = sin(bend);
        double bx = cb * tx - sb * y, by = sb * tx + cb * y;
        double ripple = 0.02 * amplitude * height * sin(10.0 * h - 3.0 * t);
        out[3 * i + 0] = (float)(bx + cx + ripple);
        out[3 * i + 1] = (float)(by + b->lo[1]);
        out[3 * i + 2] = (float)(tz + cz + ripple);
    }
}

static int compare_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median, min and max of values[0 .. n), sorting them. */
static void summarize(double *values, size_t n, double *median, double *lo, double *hi) {
    if (n == 0) {
        *median = *lo = *hi = 0.0;
        return;
    }
    qsort(values, n, sizeof *values, compare_double);
    *median = n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
    *lo = values[0];
    *hi = values[n - 1];
}

static int parse_builder(const char *name, aacbvh_builder *out) {
    static const struct { const char *name; aacbvh_builder builder; } names[] = {
        {"aac-hq", AACBVH_BUILDER_AAC_HQ},         {"aac-fast", AACBVH_BUILDER_AAC_FAST},
        {"sweep-sah", AACBVH_BUILDER_SWEEP_SAH},   {"binned-sah", AACBVH_BUILDER_BINNED_SAH},
        {"ploc", AACBVH_BUILDER_PLOC},             {"locally-ordered", AACBVH_BUILDER_LOCALLY_ORDERED},
    };
    size_t i;
    for (i = 0; i < sizeof names / sizeof names[0]; ++i)
        if (strcmp(name, names[i].name) == 0) {
            *out = names[i].builder;
            return 1;
        }
    return 0;
}

static int check(aacbvh_status status, const char *what, const aacbvh_bvh *bvh) {
    if (status == AACBVH_OK) return 1;
    fprintf(stderr, "animated: %s failed: %s %s\n", what, aacbvh_status_string(status),
            bvh ? aacbvh_bvh_last_error(bvh) : "");
    return 0;
}

/* Rays through the refitted tree and through a fresh build over the same
 * vertices must agree: same hit or miss, distances equal up to rounding. */
static int check_against_fresh_build(aacbvh_context *ctx, const aacbvh_bvh *bvh, const scene_mesh *m,
                                     aacbvh_builder builder) {
    enum { RAYS = 4096 };
    aacbvh_bvh *fresh = NULL;
    aacbvh_ray *rays = (aacbvh_ray *)malloc(RAYS * sizeof *rays);
    aacbvh_hit *a = (aacbvh_hit *)malloc(RAYS * sizeof *a), *b = (aacbvh_hit *)malloc(RAYS * sizeof *b);
    bounds box = mesh_bounds(m->vertices, m->vertex_count);
    splitmix64 rng = {12345};
    size_t i, hits = 0, bad = 0;
    int ok = 0, k;
    if (!rays || !a || !b) goto done;
    /* Origins anywhere in the box grown by its size on each side, aimed at
     * random points of the box: most rays hit, from every direction. */
    for (i = 0; i < RAYS; ++i) {
        for (k = 0; k < 3; ++k) {
            double ext = box.hi[k] - box.lo[k];
            double u = splitmix64_uniform(&rng), w = splitmix64_uniform(&rng);
            rays[i].org[k] = (float)(box.lo[k] - ext + 3.0 * ext * u);
            rays[i].dir[k] = (float)(box.lo[k] + ext * w) - rays[i].org[k];
        }
        rays[i].tmin = 0.0f;
        rays[i].tmax = INFINITY;
    }
    if (!check(aacbvh_bvh_create(ctx, &fresh), "aacbvh_bvh_create", NULL) ||
        !check(aacbvh_bvh_set_param_int(fresh, AACBVH_PARAM_BUILDER, builder), "set builder", fresh) ||
        !check(aacbvh_bvh_set_triangles(fresh, m->vertices, m->vertex_count, 12, m->indices, m->triangle_count),
               "aacbvh_bvh_set_triangles", fresh) ||
        !check(aacbvh_bvh_build(fresh), "aacbvh_bvh_build", fresh) ||
        !check(aacbvh_bvh_intersect(bvh, rays, a, RAYS), "aacbvh_bvh_intersect", bvh) ||
        !check(aacbvh_bvh_intersect(fresh, rays, b, RAYS), "aacbvh_bvh_intersect", fresh))
        goto done;
    for (i = 0; i < RAYS; ++i) {
        int hit_a = a[i].prim_id != AACBVH_INVALID_ID, hit_b = b[i].prim_id != AACBVH_INVALID_ID;
        hits += (size_t)hit_a;
        if (hit_a != hit_b || (hit_a && fabsf(a[i].t - b[i].t) > 1e-5f * fabsf(b[i].t))) ++bad;
    }
    printf("check: %d rays, %zu hits; refitted tree and fresh build %s\n", RAYS, hits,
           bad ? "DIFFER" : "agree");
    ok = bad == 0;
done:
    aacbvh_bvh_destroy(fresh);
    free(rays);
    free(a);
    free(b);
    return ok;
}

/* The three policies compared frame by frame: refit only, refit then one pass
 * of aacbvh_bvh_optimize (since 1.2), and a rebuild every frame. */
enum { POLICY_REFIT, POLICY_REFIT_OPTIMIZE, POLICY_REBUILD, POLICY_COUNT };
static const char *const policy_names[POLICY_COUNT] = {"refit only", "refit + optimize 1 pass", "rebuild"};
static const char *const policy_colors[POLICY_COUNT] = {"#d62728", "#1f77b4", "#2ca02c"};

/* An SVG line plot of ratio[p][0 .. frames): each policy's SAH over a fresh
 * build's, frame by frame. */
static int write_drift_svg(const char *path, double *const ratio[POLICY_COUNT], int frames, const char *title) {
    const double w = 720, h = 400, left = 60, right = 200, top = 40, bottom = 50;
    double ymin = 1.0, ymax = 1.05, x, y;
    int p, f, k;
    FILE *out = fopen(path, "w");
    if (!out) return 0;
    for (p = 0; p < POLICY_COUNT; ++p)
        for (f = 0; f < frames; ++f) {
            if (ratio[p][f] > ymax) ymax = ratio[p][f];
            if (ratio[p][f] < ymin) ymin = ratio[p][f];
        }
    ymax = ceil(ymax * 20.0) / 20.0;
    ymin = floor(ymin * 20.0) / 20.0;
    fprintf(out, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
                 "font-family=\"sans-serif\" font-size=\"12\">\n", w, h);
    fprintf(out, "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n");
    fprintf(out, "<text x=\"%.0f\" y=\"22\" font-size=\"14\" font-weight=\"bold\">SAH drift: %s</text>\n", left,
            title);
#define PX(fr) (left + (w - left - right) * ((frames > 1 ? (double)(fr) / (frames - 1) : 0.5)))
#define PY(v) (h - bottom - (h - top - bottom) * (((v) - ymin) / (ymax - ymin)))
    for (k = 0; k <= 4; ++k) {
        double v = ymin + (ymax - ymin) * k / 4.0;
        y = PY(v);
        fprintf(out, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>\n", left, y,
                w - right, y);
        fprintf(out, "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\">%.3f</text>\n", left - 6, y + 4, v);
    }
    fprintf(out, "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">frame (1 to %d)</text>\n",
            0.5 * (left + w - right), h - 15, frames);
    fprintf(out, "<text transform=\"translate(15 %.1f) rotate(-90)\" text-anchor=\"middle\">SAH / fresh build's SAH</text>\n",
            0.5 * (top + h - bottom));
    for (p = 0; p < POLICY_COUNT; ++p) {
        fprintf(out, "<polyline fill=\"none\" stroke-width=\"2\" stroke=\"%s\" points=\"", policy_colors[p]);
        for (f = 0; f < frames; ++f) fprintf(out, "%s%.1f,%.1f", f ? " " : "", PX(f), PY(ratio[p][f]));
        fprintf(out, "\"/>\n");
        x = w - right + 15;
        y = top + 20 + 20 * p;
        fprintf(out, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"%s\" stroke-width=\"2\"/>\n", x,
                y - 4, x + 20, y - 4, policy_colors[p]);
        fprintf(out, "<text x=\"%.1f\" y=\"%.1f\">%s</text>\n", x + 26, y, policy_names[p]);
    }
#undef PX
#undef PY
    fprintf(out, "</svg>\n");
    return fclose(out) == 0;
}

/* Runs the animation again with one handle per policy on the same vertex
 * buffer; prints per policy the time a frame and the SAH over the fresh
 * build's (the rebuild policy's tree that frame), and writes the plot. */
static int compare_policies(aacbvh_context *ctx, scene_mesh *m, const float *rest, const bounds *rest_box, int frames,
                            double amplitude, aacbvh_builder builder, const char *svg_path, const char *title) {
    aacbvh_bvh *h[POLICY_COUNT] = {NULL, NULL, NULL};
    double *ms[POLICY_COUNT] = {NULL, NULL, NULL}, *ratio[POLICY_COUNT] = {NULL, NULL, NULL};
    double *scratch = (double *)malloc((size_t)frames * sizeof(double));
    int ok = 0, p, f;
    if (!scratch) goto done;
    deform(rest, m->vertices, m->vertex_count, rest_box, 0.0, amplitude);
    for (p = 0; p < POLICY_COUNT; ++p) {
        ms[p] = (double *)malloc((size_t)frames * sizeof(double));
        ratio[p] = (double *)malloc((size_t)frames * sizeof(double));
        if (!ms[p] || !ratio[p]) goto done;
        if (!check(aacbvh_bvh_create(ctx, &h[p]), "aacbvh_bvh_create", NULL) ||
            !check(aacbvh_bvh_set_param_int(h[p], AACBVH_PARAM_BUILDER, builder), "set builder", h[p]) ||
            !check(aacbvh_bvh_set_param_int(h[p], AACBVH_PARAM_KEEP_BUILD_MEMORY, 1), "keep build memory", h[p]) ||
            !check(aacbvh_bvh_set_triangles(h[p], m->vertices, m->vertex_count, 12, m->indices, m->triangle_count),
                   "aacbvh_bvh_set_triangles", h[p]) ||
            !check(aacbvh_bvh_build(h[p]), "aacbvh_bvh_build", h[p]))
            goto done;
    }
    for (f = 0; f < frames; ++f) {
        double t = 2.0 * PI * 2.0 * (double)(f + 1) / (double)frames, sah[POLICY_COUNT], t0;
        aacbvh_stats st;
        deform(rest, m->vertices, m->vertex_count, rest_box, t, amplitude);
        for (p = 0; p < POLICY_COUNT; ++p) {
            aacbvh_status s;
            t0 = now_ms();
            if (p == POLICY_REBUILD) {
                s = aacbvh_bvh_build(h[p]);
            } else {
                s = aacbvh_bvh_refit(h[p]);
                if (s == AACBVH_OK && p == POLICY_REFIT_OPTIMIZE) s = aacbvh_bvh_optimize(h[p], 1);
            }
            ms[p][f] = now_ms() - t0;
            st.struct_size = sizeof st;
            if (!check(s, policy_names[p], h[p]) || !check(aacbvh_bvh_get_stats(h[p], &st), "get_stats", h[p]))
                goto done;
            sah[p] = st.sah_cost;
        }
        for (p = 0; p < POLICY_COUNT; ++p) ratio[p][f] = sah[POLICY_REBUILD] > 0 ? sah[p] / sah[POLICY_REBUILD] : 1.0;
    }
    printf("\npolicies, frame by frame (SAH over the fresh build's, which is the rebuild policy's):\n");
    printf("%-26s %12s %12s %12s %10s %10s\n", "policy", "ms/frame med", "x rebuild", "SAH/fresh med", "max", "last");
    {
        double rebuild_med, lo, hi;
        memcpy(scratch, ms[POLICY_REBUILD], (size_t)frames * sizeof(double));
        summarize(scratch, (size_t)frames, &rebuild_med, &lo, &hi);
        for (p = 0; p < POLICY_COUNT; ++p) {
            double med, rmed, rmax;
            memcpy(scratch, ms[p], (size_t)frames * sizeof(double));
            summarize(scratch, (size_t)frames, &med, &lo, &hi);
            memcpy(scratch, ratio[p], (size_t)frames * sizeof(double));
            summarize(scratch, (size_t)frames, &rmed, &lo, &rmax);
            printf("%-26s %12.3f %12.3f %12.3f %10.3f %10.3f\n", policy_names[p], med,
                   rebuild_med > 0 ? med / rebuild_med : 0.0, rmed, rmax, ratio[p][frames - 1]);
        }
    }
    if (svg_path) {
        if (!write_drift_svg(svg_path, ratio, frames, title)) {
            fprintf(stderr, "animated: cannot write %s\n", svg_path);
            goto done;
        }
        printf("wrote %s\n", svg_path);
    }
    ok = 1;
done:
    for (p = 0; p < POLICY_COUNT; ++p) {
        aacbvh_bvh_destroy(h[p]);
        free(ms[p]);
        free(ratio[p]);
    }
    free(scratch);
    return ok;
}

int main(int argc, char **argv) {
    int frames = 120, threads = 0, verbose = 0, result = 1, i;
    double threshold = 1.25, amplitude = 1.0;
    size_t triangles = 500000;
    const char *scene = NULL, *builder_name = "aac-fast", *svg_path = NULL;
    aacbvh_builder builder = AACBVH_BUILDER_AAC_FAST;
    scene_mesh m;
    char err[512];
    float *rest = NULL;
    bounds rest_box;
    aacbvh_context *ctx = NULL;
    aacbvh_bvh *bvh = NULL;
    aacbvh_stats s;
    double *refit_ms = NULL, *stats_ms = NULL, *rebuild_ms = NULL, *drift = NULL, *animate_ms = NULL;
    double med, lo, hi, t0, t1, first_build_ms, max_drift = 1.0;
    size_t rebuilds = 0;

    memset(&m, 0, sizeof m);
    for (i = 1; i < argc; ++i) {
        const char *arg = argv[i], *next = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(arg, "--frames") == 0 && next) frames = atoi(argv[++i]);
        else if (strcmp(arg, "--threads") == 0 && next) threads = atoi(argv[++i]);
        else if (strcmp(arg, "--threshold") == 0 && next) threshold = atof(argv[++i]);
        else if (strcmp(arg, "--amplitude") == 0 && next) amplitude = atof(argv[++i]);
        else if (strcmp(arg, "--triangles") == 0 && next) triangles = (size_t)strtoull(argv[++i], NULL, 10);
        else if (strcmp(arg, "--svg") == 0 && next) svg_path = argv[++i];
        else if (strcmp(arg, "--builder") == 0 && next) {
            builder_name = argv[++i];
            if (!parse_builder(builder_name, &builder)) {
                fprintf(stderr, "animated: unknown builder %s\n", builder_name);
                return 2;
            }
        } else if (strcmp(arg, "--verbose") == 0 || strcmp(arg, "-v") == 0) verbose = 1;
        else if (arg[0] != '-' && !scene) scene = arg;
        else {
            fprintf(stderr, "usage: animated [--frames N] [--threads N] [--threshold R] [--builder NAME]\n"
                            "                [--triangles N] [--amplitude A] [--svg FILE] [--verbose] [scene.obj]\n");
            return 2;
        }
    }
    if (frames < 1 || threads < 0 || !(threshold >= 1.0)) {
        fprintf(stderr, "animated: need frames >= 1, threads >= 0, threshold >= 1\n");
        return 2;
    }

    if (scene ? !scene_mesh_load_obj(scene, &m, err, sizeof err) : !make_tube(triangles, &m)) {
        fprintf(stderr, "animated: %s\n", scene ? err : "out of memory generating the mesh");
        goto done;
    }
    rest = (float *)malloc(m.vertex_count * 3 * sizeof(float));
    refit_ms = (double *)malloc((size_t)frames * sizeof(double));
    stats_ms = (double *)malloc((size_t)frames * sizeof(double));
    rebuild_ms = (double *)malloc((size_t)frames * sizeof(double));
    drift = (double *)malloc((size_t)frames * sizeof(double));
    animate_ms = (double *)malloc((size_t)frames * sizeof(double));
    if (!rest || !refit_ms || !stats_ms || !rebuild_ms || !drift || !animate_ms) {
        fprintf(stderr, "animated: out of memory\n");
        goto done;
    }
    memcpy(rest, m.vertices, m.vertex_count * 3 * sizeof(float));
    rest_box = mesh_bounds(rest, m.vertex_count);

    if (!check(aacbvh_context_create((uint32_t)threads, &ctx), "aacbvh_context_create", NULL) ||
        !check(aacbvh_bvh_create(ctx, &bvh), "aacbvh_bvh_create", NULL) ||
        !check(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), "set builder", bvh) ||
        /* Rebuilds reuse the memory the previous build freed (no fresh pages). */
        !check(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_KEEP_BUILD_MEMORY, 1), "keep build memory", bvh) ||
        /* The engine owns the vertex buffer and moves the vertices in place. */
        !check(aacbvh_bvh_set_triangles(bvh, m.vertices, m.vertex_count, 12, m.indices, m.triangle_count),
               "aacbvh_bvh_set_triangles", bvh))
        goto done;
    t0 = now_ms();
    if (!check(aacbvh_bvh_build(bvh), "aacbvh_bvh_build", bvh)) goto done;
    first_build_ms = now_ms() - t0;
    s.struct_size = sizeof s;
    if (!check(aacbvh_bvh_get_stats(bvh, &s), "aacbvh_bvh_get_stats", bvh)) goto done;
    printf("libaacbvh %s: %s, %zu triangles, %u thread(s), builder %s, rebuild when cost > %.2f x built\n",
           aacbvh_version_string(), scene ? scene : "generated tube", m.triangle_count,
           aacbvh_context_thread_count(ctx), builder_name, threshold);
    printf("first build: %.2f ms, SAH cost %.2f, %llu nodes, %.1f bytes/triangle held, %.1f at the build's peak\n",
           first_build_ms, s.sah_cost, (unsigned long long)s.node_count,
           (double)s.memory_bytes / (double)m.triangle_count, (double)s.build_peak_bytes / (double)m.triangle_count);
    if (verbose) printf("frame   refit ms   stats ms  drift  rebuild ms\n");

    for (i = 0; i < frames; ++i) {
        double t = 2.0 * PI * 2.0 * (double)(i + 1) / (double)frames; /* two cycles over the run */
        double rebuild = 0.0;
        t0 = now_ms();
        deform(rest, m.vertices, m.vertex_count, &rest_box, t, amplitude);
        animate_ms[i] = now_ms() - t0;

        t0 = now_ms();
        if (!check(aacbvh_bvh_refit(bvh), "aacbvh_bvh_refit", bvh)) goto done;
        t1 = now_ms();
        if (!check(aacbvh_bvh_get_stats(bvh, &s), "aacbvh_bvh_get_stats", bvh)) goto done;
        refit_ms[i] = t1 - t0;
        stats_ms[i] = now_ms() - t1;
        drift[i] = s.built_sah_cost > 0.0 ? s.sah_cost / s.built_sah_cost : 1.0;
        if (drift[i] > max_drift) max_drift = drift[i];

        /* The policy: rebuild once refitting has made the tree too much worse. */
        if (drift[i] > threshold) {
            t0 = now_ms();
            if (!check(aacbvh_bvh_build(bvh), "aacbvh_bvh_build", bvh)) goto done;
            rebuild = rebuild_ms[rebuilds++] = now_ms() - t0;
        }
        if (verbose) {
            printf("%5d %10.3f %10.3f %6.3f", i + 1, refit_ms[i], stats_ms[i], drift[i]);
            if (rebuild > 0.0) printf(" %10.3f", rebuild);
            printf("\n");
        }
    }

    printf("frames: %d, rebuilds: %zu (one per %.1f frames)\n", frames, rebuilds,
           rebuilds ? (double)frames / (double)rebuilds : (double)frames);
    summarize(refit_ms, (size_t)frames, &med, &lo, &hi);
    printf("refit ms:      median %8.3f  min %8.3f  max %8.3f\n", med, lo, hi);
    summarize(stats_ms, (size_t)frames, &med, &lo, &hi);
    printf("get_stats ms:  median %8.3f  min %8.3f  max %8.3f\n", med, lo, hi);
    summarize(rebuild_ms, rebuilds, &med, &lo, &hi);
    printf("rebuild ms:    median %8.3f  min %8.3f  max %8.3f\n", med, lo, hi);
    summarize(animate_ms, (size_t)frames, &med, &lo, &hi);
    printf("animate ms:    median %8.3f (the example's own vertex update, one thread)\n", med);
    summarize(drift, (size_t)frames, &med, &lo, &hi);
    printf("cost drift (sah_cost / built_sah_cost after each refit): median %.3f, max %.3f\n", med, max_drift);

    /* One more frame, refitted only (the loop may have ended on a rebuild), so
     * that the check sees a refitted tree. */
    deform(rest, m.vertices, m.vertex_count, &rest_box, 2.0 * PI * 2.0 * (frames + 0.5) / frames, amplitude);
    if (!check(aacbvh_bvh_refit(bvh), "aacbvh_bvh_refit", bvh)) goto done;
    if (!check_against_fresh_build(ctx, bvh, &m, builder)) goto done;
    {
        char title[256];
        const char *name = scene ? strrchr(scene, '/') : NULL;
        snprintf(title, sizeof title, "%s, %zu triangles, %s", name ? name + 1 : scene ? scene : "generated tube",
                 m.triangle_count, builder_name);
        if (compare_policies(ctx, &m, rest, &rest_box, frames, amplitude, builder, svg_path, title)) result = 0;
    }
done:
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    scene_mesh_free(&m);
    free(rest);
    free(refit_ms);
    free(stats_ms);
    free(rebuild_ms);
    free(drift);
    free(animate_ms);
    return result;
}
