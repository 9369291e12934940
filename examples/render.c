/* render: the program a user of libaacbvh might write first, in C99. It loads
 * an OBJ file (or, without one or when the file is missing, generates the
 * examples' terrain-and-spheres scene), builds a BVH with the default
 * parameters on every core, traces one primary ray per pixel from a camera
 * that frames the scene's bounds and one shadow ray per lit hit toward a point
 * light, shades with Lambert's cosine law from each hit triangle's geometric
 * normal, and writes a PNG.
 *
 *     usage: render [--width W] [--height H] [--output FILE] [scene.obj]
 *
 * Rays go to the library in bands of rows, a few hundred thousand per call:
 * one call spreads them over the context's threads, and the band bounds memory.
 */
#include <aacbvh/aacbvh.h>

#include "png_write.h"
#include "scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { kMaxSide = 16384, kRaysPerCall = 1 << 18 };

typedef struct vec3 {
    float x, y, z;
} vec3;

static vec3 v3(float x, float y, float z) {
    vec3 v;
    v.x = x, v.y = y, v.z = z;
    return v;
}
static vec3 load3(const float *p) { return v3(p[0], p[1], p[2]); }
static vec3 add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static vec3 sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static vec3 scale(vec3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static float dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static vec3 cross(vec3 a, vec3 b) { return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
static vec3 normalize(vec3 a) {
    float len = sqrtf(dot(a, a));
    return len > 0.0f ? scale(a, 1.0f / len) : a;
}
static void store3(float *p, vec3 v) {
    p[0] = v.x, p[1] = v.y, p[2] = v.z;
}

/* A pinhole camera: pixel (x, y) looks along forward + sx * right + sy * up. */
typedef struct camera {
    vec3 eye, forward, right, up;
    float half_width, half_height; /* tangents of the half field of view */
} camera;

/* Looks at the centre of the scene's bounds from above and in front (+z, with
 * y up as in the usual OBJ scenes), just far enough back that all eight
 * corners of the bounds are in the picture. The light sits above and to the
 * left, well outside the bounds. */
static camera frame_bounds(const float lower[3], const float upper[3], uint32_t width, uint32_t height,
                           vec3 *light) {
    const float half_fov_y = 0.35f; /* radians: a 40 degree vertical field of view */
    vec3 lo = load3(lower), hi = load3(upper), centre = scale(add(lo, hi), 0.5f);
    float size = sqrtf(dot(sub(hi, lo), sub(hi, lo))), distance = 0.0f;
    int corner;
    camera c;
    c.forward = normalize(v3(-0.55f, -0.6f, -1.0f));
    c.right = normalize(cross(c.forward, v3(0.0f, 1.0f, 0.0f)));
    c.up = cross(c.right, c.forward);
    c.half_height = tanf(half_fov_y);
    c.half_width = c.half_height * (float)width / (float)height;
    for (corner = 0; corner < 8; ++corner) {
        /* A corner at (x, y) across and z deep from the centre is in view from
         * `distance` back when |x| <= half_width * (distance + z), likewise y. */
        vec3 q = sub(v3(corner & 1 ? hi.x : lo.x, corner & 2 ? hi.y : lo.y, corner & 4 ? hi.z : lo.z), centre);
        float z = dot(q, c.forward), need_x = fabsf(dot(q, c.right)) / c.half_width - z;
        float need_y = fabsf(dot(q, c.up)) / c.half_height - z;
        if (need_x > distance) distance = need_x;
        if (need_y > distance) distance = need_y;
    }
    if (!(size > 0.0f)) size = 1.0f; /* a point: any distance will do */
    distance = 1.04f * distance + 0.01f * size;
    c.eye = sub(centre, scale(c.forward, distance));
    *light = add(centre, scale(normalize(v3(-0.6f, 1.0f, 0.4f)), 2.0f * size));
    return c;
}

static void primary_ray(const camera *c, uint32_t x, uint32_t y, uint32_t width, uint32_t height, aacbvh_ray *r) {
    float sx = (2.0f * ((float)x + 0.5f) / (float)width - 1.0f) * c->half_width;
    float sy = (1.0f - 2.0f * ((float)y + 0.5f) / (float)height) * c->half_height;
    store3(r->org, c->eye);
    store3(r->dir, normalize(add(c->forward, add(scale(c->right, sx), scale(c->up, sy)))));
    r->tmin = 0.0f;
    r->tmax = INFINITY;
}

/* The hit triangle's unit normal, turned toward the side the ray came from. */
static vec3 facing_normal(const scene_mesh *m, uint32_t prim_id, vec3 ray_dir) {
    const uint32_t *t = m->indices + 3 * (size_t)prim_id;
    vec3 a = load3(m->vertices + 3 * (size_t)t[0]), b = load3(m->vertices + 3 * (size_t)t[1]);
    vec3 n = normalize(cross(sub(b, a), sub(load3(m->vertices + 3 * (size_t)t[2]), a)));
    return dot(n, ray_dir) > 0.0f ? scale(n, -1.0f) : n;
}

/* Linear light to an 8-bit sRGB-like value (gamma 2.2). */
static unsigned char to_byte(float linear) {
    float v = powf(linear > 0.0f ? (linear < 1.0f ? linear : 1.0f) : 0.0f, 1.0f / 2.2f);
    return (unsigned char)(255.0f * v + 0.5f);
}

typedef struct counts {
    size_t hits, lit;
} counts;

/* Traces and shades rows [y0, y1) into image; the arrays hold (y1 - y0) * width. */
static aacbvh_status render_band(const aacbvh_bvh *bvh, const scene_mesh *m, const camera *c, vec3 light,
                                 float offset, uint32_t width, uint32_t height, uint32_t y0, uint32_t y1,
                                 aacbvh_ray *rays, aacbvh_hit *hits, aacbvh_ray *shadow, size_t *shadow_pixel,
                                 uint8_t *occluded, float *lambert, unsigned char *image, counts *n) {
    const size_t count = (size_t)(y1 - y0) * width;
    size_t i, shadow_count = 0;
    aacbvh_status status;
    uint32_t x, y;
    for (y = y0; y < y1; ++y)
        for (x = 0; x < width; ++x) primary_ray(c, x, y, width, height, &rays[(size_t)(y - y0) * width + x]);
    status = aacbvh_bvh_intersect(bvh, rays, hits, count);
    if (status != AACBVH_OK) return status;

    /* A shadow ray from each hit that faces the light (the others are in their
     * own shadow), started a little off the surface so it cannot hit its own
     * triangle, and ending at the light (t = 1 in units of its direction). */
    for (i = 0; i < count; ++i) {
        vec3 dir = load3(rays[i].dir), normal, p, to_light;
        lambert[i] = 0.0f;
        if (hits[i].prim_id == AACBVH_INVALID_ID) continue;
        ++n->hits;
        normal = facing_normal(m, hits[i].prim_id, dir);
        p = add(add(load3(rays[i].org), scale(dir, hits[i].t)), scale(normal, offset));
        to_light = sub(light, p);
        lambert[i] = dot(normal, normalize(to_light));
        if (lambert[i] <= 0.0f) continue;
        store3(shadow[shadow_count].org, p);
        store3(shadow[shadow_count].dir, to_light);
        shadow[shadow_count].tmin = 0.0f;
        shadow[shadow_count].tmax = 1.0f;
        shadow_pixel[shadow_count++] = i;
    }
    status = aacbvh_bvh_occluded(bvh, shadow, occluded, shadow_count);
    if (status != AACBVH_OK) return status;
    for (i = 0; i < shadow_count; ++i) {
        if (occluded[i]) lambert[shadow_pixel[i]] = 0.0f;
        else ++n->lit;
    }

    for (i = 0; i < count; ++i) {
        unsigned char *px = image + 3 * ((size_t)y0 * width + i);
        float r, g, b;
        if (hits[i].prim_id == AACBVH_INVALID_ID) {
            /* Sky: lighter toward the horizon. */
            float up = rays[i].dir[1] > 0.0f ? rays[i].dir[1] : 0.0f;
            r = 0.60f - 0.35f * up, g = 0.72f - 0.30f * up, b = 0.90f - 0.15f * up;
        } else {
            /* A light grey surface: ambient light from the sky plus the point light. */
            float shade = 0.12f + 0.88f * (lambert[i] > 0.0f ? lambert[i] : 0.0f);
            r = 0.80f * shade, g = 0.78f * shade, b = 0.72f * shade;
        }
        px[0] = to_byte(r), px[1] = to_byte(g), px[2] = to_byte(b);
    }
    return AACBVH_OK;
}

static int parse_side(const char *text, uint32_t *out) {
    char *end;
    long v = text ? strtol(text, &end, 10) : 0;
    if (!text || *end != '\0' || v < 1 || v > kMaxSide) return 0;
    *out = (uint32_t)v;
    return 1;
}

static void usage(FILE *out) {
    fprintf(out,
            "usage: render [--width W] [--height H] [--output FILE] [scene.obj]\n"
            "Ray traces an OBJ scene (without one, or when the file is missing, a generated\n"
            "terrain with spheres) with a BVH from libaacbvh: one primary ray per pixel, one\n"
            "shadow ray toward a point light per lit hit, Lambert shading; writes a PNG.\n"
            "\n"
            "  --width W      image width in pixels (default 640, at most %d)\n"
            "  --height H     image height in pixels (default 480, at most %d)\n"
            "  --output FILE  the PNG to write (default render.png)\n"
            "  -h, --help     this text\n",
            kMaxSide, kMaxSide);
}

int main(int argc, char **argv) {
    uint32_t width = 640, height = 480, rows, y;
    const char *path = NULL, *output = "render.png", *png_error;
    scene_mesh mesh = {NULL, 0, NULL, 0};
    aacbvh_context *ctx = NULL;
    aacbvh_bvh *bvh = NULL;
    aacbvh_status status = AACBVH_OK;
    aacbvh_ray *rays = NULL, *shadow = NULL;
    aacbvh_hit *hits = NULL;
    size_t *shadow_pixel = NULL, band;
    uint8_t *occluded = NULL;
    float *lambert = NULL, lower[3], upper[3], offset;
    unsigned char *image = NULL;
    counts n = {0, 0};
    camera cam;
    vec3 light;
    char err[512];
    int i, result = 1;

    for (i = 1; i < argc; ++i) {
        const char *arg = argv[i], *next = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
            usage(stdout);
            return 0;
        } else if (strcmp(arg, "--width") == 0 || strcmp(arg, "--height") == 0) {
            if (!parse_side(next, arg[2] == 'w' ? &width : &height)) {
                fprintf(stderr, "render: %s takes a whole number from 1 to %d\n", arg, kMaxSide);
                return 2;
            }
            ++i;
        } else if (strcmp(arg, "--output") == 0 && next) {
            output = argv[++i];
        } else if (arg[0] != '-' && !path) {
            path = arg;
        } else {
            usage(stderr);
            return 2;
        }
    }

    if (path) {
        FILE *probe = fopen(path, "rb");
        if (probe) {
            fclose(probe);
        } else {
            fprintf(stderr, "render: cannot open %s; rendering the generated scene instead\n", path);
            path = NULL;
        }
    }
    if (path ? !scene_mesh_load_obj(path, &mesh, err, sizeof err) : !scene_mesh_procedural(NULL, &mesh)) {
        fprintf(stderr, "render: %s\n", path ? err : "out of memory generating the scene");
        return 1;
    }
    if (mesh.triangle_count == 0) {
        fprintf(stderr, "render: %s has no triangles\n", path ? path : "the scene");
        goto done;
    }

    /* The library's defaults: AAC-HQ, binary layout; 0 threads = one per core. */
    if ((status = aacbvh_context_create(0, &ctx)) != AACBVH_OK || (status = aacbvh_bvh_create(ctx, &bvh)) != AACBVH_OK ||
        (status = aacbvh_bvh_set_triangles(bvh, mesh.vertices, mesh.vertex_count, 3 * sizeof(float), mesh.indices,
                                           mesh.triangle_count)) != AACBVH_OK ||
        (status = aacbvh_bvh_build(bvh)) != AACBVH_OK)
        goto done;
    printf("libaacbvh %s: %s, %zu triangles, BVH built on %u thread(s)\n", aacbvh_version_string(),
           path ? path : "generated scene", mesh.triangle_count, aacbvh_context_thread_count(ctx));

    scene_bounds(mesh.vertices, mesh.vertex_count, lower, upper);
    cam = frame_bounds(lower, upper, width, height, &light);
    rows = (uint32_t)((kRaysPerCall + width - 1) / width);
    if (rows > height) rows = height;
    band = (size_t)rows * width;
    rays = (aacbvh_ray *)malloc(band * sizeof *rays);
    shadow = (aacbvh_ray *)malloc(band * sizeof *shadow);
    hits = (aacbvh_hit *)malloc(band * sizeof *hits);
    shadow_pixel = (size_t *)malloc(band * sizeof *shadow_pixel);
    occluded = (uint8_t *)malloc(band);
    lambert = (float *)malloc(band * sizeof *lambert);
    image = (unsigned char *)malloc((size_t)width * height * 3);
    if (!rays || !shadow || !hits || !shadow_pixel || !occluded || !lambert || !image) {
        fprintf(stderr, "render: out of memory for a %ux%u image\n", (unsigned)width, (unsigned)height);
        goto done;
    }
    /* Shadow rays start this far off the surface: a millionth of the scene's size. */
    offset = 1e-6f * ((upper[0] - lower[0]) + (upper[1] - lower[1]) + (upper[2] - lower[2]));
    for (y = 0; y < height; y += rows) {
        status = render_band(bvh, &mesh, &cam, light, offset, width, height, y, y + rows < height ? y + rows : height,
                             rays, hits, shadow, shadow_pixel, occluded, lambert, image, &n);
        if (status != AACBVH_OK) goto done;
    }
    png_error = png_write_rgb(output, image, width, height);
    if (png_error) {
        fprintf(stderr, "render: %s: %s\n", output, png_error);
        goto done;
    }
    printf("wrote %s: %ux%u, %zu of %zu pixels hit, %zu of them lit\n", output, (unsigned)width, (unsigned)height,
           n.hits, (size_t)width * height, n.lit);
    result = 0;
done:
    if (status != AACBVH_OK)
        fprintf(stderr, "render: %s %s\n", aacbvh_status_string(status), bvh ? aacbvh_bvh_last_error(bvh) : "");
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    scene_mesh_free(&mesh);
    free(rays);
    free(shadow);
    free(hits);
    free(shadow_pixel);
    free(occluded);
    free(lambert);
    free(image);
    return result;
}
