// The 8-wide traversal's kernels (lib/trace/wide8_traversal.h): plain C++,
// SSE2, AVX2 and AVX-512, each forced in turn on every kernel this CPU can
// run, must answer every ray bit for bit like the binary traversal reading
// the caller's triangles: every generated scene kind (coplanar stacks, zero-area
// and wide-range triangles included), a watertight grid moved 1e5 away from
// the origin, boxes, and tests/test_support's rays (axis-parallel
// directions, origins on planes, odd windows, invalid rays), with packet
// leaves (copied triangles) and slot leaves (referenced), 1 and 2 threads
// (2 only under ThreadSanitizer; fewer rays on the densest scenes under a
// sanitizer, see test_every_scene_kind).
// Linked statically (see CMakeLists.txt) so it can switch the kernel.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
extern "C" {
#include <cmocka.h>
}

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "aacbvh/aacbvh.h"
#include "test_support.h"
#include "trace/wide8_traversal.h"

namespace {

constexpr size_t kRays = TS_RAYS(3000);
const aacbvh::TraceKernel kKernels[] = {aacbvh::TraceKernel::Scalar, aacbvh::TraceKernel::Sse2,
                                        aacbvh::TraceKernel::Avx2, aacbvh::TraceKernel::Avx512};

aacbvh_bvh *make(aacbvh_context *ctx, aacbvh_layout layout, aacbvh_triangle_storage storage, aacbvh_builder builder) {
    aacbvh_bvh *bvh = nullptr;
    TS_EXPECT_STATUS(aacbvh_bvh_create(ctx, &bvh), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRAVERSAL_LAYOUT, layout), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_TRIANGLE_STORAGE, storage), AACBVH_OK);
    TS_EXPECT_STATUS(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, builder), AACBVH_OK);
    return bvh;
}

/// The binary reference and the default 8-wide handle (AAC-HQ, triangles
/// copied) over `mesh`, built.
void make_built_pair(aacbvh_context *ctx, const ts_mesh &mesh, aacbvh_bvh *&ref, aacbvh_bvh *&wide) {
    ref = make(ctx, AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED, AACBVH_BUILDER_AAC_HQ);
    wide = make(ctx, AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_COPIED, AACBVH_BUILDER_AAC_HQ);
    for (aacbvh_bvh *b : {ref, wide}) {
        ts_set_mesh(b, &mesh);
        TS_EXPECT_STATUS(aacbvh_bvh_build(b), AACBVH_OK);
    }
}

/// Every available kernel against the binary reference on the same rays.
/// Returns how many kernels ran.
int compare_kernels(const aacbvh_bvh *reference, const aacbvh_bvh *wide, const aacbvh_ray *rays, size_t count,
                    const char *what) {
    const aacbvh::TraceKernel original = aacbvh::trace_kernel();
    int ran = 0;
    for (aacbvh::TraceKernel k : kKernels) {
        if (!aacbvh::set_trace_kernel(k)) continue;
        char label[256];
        std::snprintf(label, sizeof label, "%s, kernel %s", what, aacbvh::trace_kernel_name(k));
        ts_compare_answers(reference, wide, rays, count, label);
        ++ran;
    }
    assert_true(aacbvh::set_trace_kernel(original));
    return ran;
}

/// Under ThreadSanitizer 2 threads only: one thread has no race to find
/// (the Release and AddressSanitizer stages run both).
constexpr uint32_t kFirstThreads = TS_UNDER_TSAN ? 2 : 1;

void check_mesh(const ts_mesh &mesh, const char *name, uint64_t seed, size_t ray_count = kRays) {
    for (uint32_t threads = kFirstThreads; threads <= 2; ++threads) {
        aacbvh_context *ctx = nullptr;
        TS_EXPECT_STATUS(aacbvh_context_create(threads, &ctx), AACBVH_OK);
        aacbvh_bvh *ref = make(ctx, AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED, AACBVH_BUILDER_AAC_HQ);
        aacbvh_bvh *packets = make(ctx, AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_COPIED, AACBVH_BUILDER_AAC_HQ);
        aacbvh_bvh *slots = make(ctx, AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_REFERENCED, AACBVH_BUILDER_BINNED_SAH);
        aacbvh_bvh *slots_ref = make(ctx, AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED, AACBVH_BUILDER_BINNED_SAH);
        for (aacbvh_bvh *b : {ref, packets, slots, slots_ref}) {
            ts_set_mesh(b, &mesh);
            TS_EXPECT_STATUS(aacbvh_bvh_build(b), AACBVH_OK);
        }
        aacbvh_ray *rays = ts_make_rays(mesh.vertices, 3 * mesh.vertex_count, ray_count, seed + threads);
        assert_non_null(rays);
        char what[160];
        std::snprintf(what, sizeof what, "%s, packets, %u threads", name, threads);
        assert_true(compare_kernels(ref, packets, rays, ray_count, what) >= 1);
        std::snprintf(what, sizeof what, "%s, slots, %u threads", name, threads);
        compare_kernels(slots_ref, slots, rays, ray_count, what);
        std::free(rays);
        for (aacbvh_bvh *b : {ref, packets, slots, slots_ref}) aacbvh_bvh_destroy(b);
        aacbvh_context_destroy(ctx);
    }
}

void test_kernels_available(void **) {
    // The plain kernel builds everywhere; SSE2 is the x86-64 baseline.
    assert_true(aacbvh::trace_kernel_available(aacbvh::TraceKernel::Scalar));
#if defined(__x86_64__)
    assert_true(aacbvh::trace_kernel_available(aacbvh::TraceKernel::Sse2));
#endif
    assert_true(aacbvh::trace_kernel_available(aacbvh::trace_kernel()));
    std::printf("kernels on this CPU:");
    for (aacbvh::TraceKernel k : kKernels)
        if (aacbvh::trace_kernel_available(k)) std::printf(" %s", aacbvh::trace_kernel_name(k));
    std::printf(" (in use: %s)\n", aacbvh::trace_kernel_name(aacbvh::trace_kernel()));
}

void test_every_scene_kind(void **) {
    for (int kind = 0; kind < TS_SCENE_KIND_COUNT; ++kind) {
        // A ray crosses most of the tree of the identical, same-centroid and
        // wide-range scenes (about 85% of this test's time under a
        // sanitizer): there those trace 300 rays, still more than the 8-wide
        // query's grain of 256.
        const bool dense = kind == TS_SCENE_IDENTICAL || kind == TS_SCENE_SAME_CENTROID ||
                           kind == TS_SCENE_WIDE_RANGE;
        ts_mesh mesh;
        assert_true(ts_make_scene(ts_scene_kind(kind), 1500, 300 + kind, &mesh));
        check_mesh(mesh, ts_scene_name(ts_scene_kind(kind)), 400 + 10 * kind,
                   TS_UNDER_SANITIZER && dense ? 300 : kRays);
        ts_mesh_free(&mesh);
    }
}

void test_far_watertight_grid(void **) {
    ts_mesh mesh;
    assert_true(ts_make_scene(TS_SCENE_GRID, 4000, 17, &mesh));
    for (size_t i = 0; i < 3 * mesh.vertex_count; ++i) mesh.vertices[i] += 1e5f;
    check_mesh(mesh, "grid at 1e5", 18);
    ts_mesh_free(&mesh);
}

void test_boxes(void **) {
    const size_t count = 2000;
    float *boxes = ts_random_boxes(count, 0.2f, 23);
    assert_non_null(boxes);
    aacbvh_context *ctx = nullptr;
    TS_EXPECT_STATUS(aacbvh_context_create(1, &ctx), AACBVH_OK);
    aacbvh_bvh *ref = make(ctx, AACBVH_LAYOUT_BINARY, AACBVH_TRIANGLES_REFERENCED, AACBVH_BUILDER_AAC_HQ);
    aacbvh_bvh *wide = make(ctx, AACBVH_LAYOUT_WIDE8, AACBVH_TRIANGLES_COPIED, AACBVH_BUILDER_AAC_HQ);
    for (aacbvh_bvh *b : {ref, wide}) {
        TS_EXPECT_STATUS(aacbvh_bvh_set_boxes(b, boxes, count, 24), AACBVH_OK);
        TS_EXPECT_STATUS(aacbvh_bvh_build(b), AACBVH_OK);
    }
    aacbvh_ray *rays = ts_make_rays(boxes, 6 * count, kRays, 24);
    assert_non_null(rays);
    compare_kernels(ref, wide, rays, kRays, "boxes");
    std::free(rays);
    aacbvh_bvh_destroy(ref);
    aacbvh_bvh_destroy(wide);
    aacbvh_context_destroy(ctx);
    std::free(boxes);
}

/// Rays from outside the scene's box, answered by the root's node test
/// before the set-up when they miss every child (misses_root(),
/// trace/wide8_kernel.inl): rays along the box's faces, edges and corners,
/// a few float steps inside or outside them, with windows from 0 and from
/// below 0 (the node test's two forms); then the same after a refit has
/// moved and stretched the mesh, so that the box the check starts from is
/// the refit tree's (rays from inside the old box now come from outside).
void test_rays_from_outside(void **) {
    ts_mesh mesh;
    assert_true(ts_make_scene(TS_SCENE_RANDOM, 600, 31, &mesh));
    aacbvh_context *ctx = nullptr;
    TS_EXPECT_STATUS(aacbvh_context_create(1, &ctx), AACBVH_OK);
    aacbvh_bvh *ref = nullptr, *wide = nullptr;
    make_built_pair(ctx, mesh, ref, wide);
    const size_t count = TS_RAYS(4000);
    std::vector<aacbvh_ray> rays(count);
    for (int round = 0; round < 2; ++round) {
        float lo[3], hi[3];
        ts_coords_bounds(mesh.vertices, 3 * mesh.vertex_count, lo, hi);
        ts_rng rng;
        ts_rng_seed(&rng, 700 + round);
        for (aacbvh_ray &r : rays) {
            // A target on the box's surface (each coordinate at a face with
            // probability one half, so edges and corners come up), moved a
            // few float steps in or out, and an origin 1.5 extents back from
            // it along a random direction (mostly outside the box) or along
            // an axis (outside).
            float target[3];
            for (int k = 0; k < 3; ++k) {
                target[k] = ts_rng_range(&rng, lo[k], hi[k]);
                if (ts_rng_below(&rng, 2) == 0) target[k] = ts_rng_below(&rng, 2) == 0 ? lo[k] : hi[k];
                for (uint32_t step = ts_rng_below(&rng, 4); step > 0; --step)
                    target[k] = std::nextafter(target[k], ts_rng_below(&rng, 2) == 0 ? -INFINITY : INFINITY);
            }
            const int axis = int(ts_rng_below(&rng, 4)); // 3: any direction
            for (int k = 0; k < 3; ++k) {
                const float extent = hi[k] - lo[k];
                float d = axis == 3 ? ts_rng_range(&rng, -1.0f, 1.0f) : (k == axis ? 1.0f : 0.0f);
                if (axis != 3 && k == axis && ts_rng_below(&rng, 2) == 0) d = -1.0f;
                r.dir[k] = d;
                r.org[k] = target[k] - 1.5f * (extent > 0.0f ? extent : 1.0f) * d;
            }
            if (r.dir[0] == 0.0f && r.dir[1] == 0.0f && r.dir[2] == 0.0f) r.dir[0] = 1.0f;
            r.tmin = ts_rng_below(&rng, 4) == 0 ? -1.0f : 0.0f;
            r.tmax = ts_rng_below(&rng, 4) == 0 ? 1.5f : INFINITY;
        }
        char what[96];
        std::snprintf(what, sizeof what, "rays from outside the box, %s", round == 0 ? "built" : "after a refit");
        assert_true(compare_kernels(ref, wide, rays.data(), count, what) >= 1);
        // Move the mesh by half its extent and stretch it along x, then refit.
        for (size_t i = 0; i < mesh.vertex_count; ++i) {
            float *v = &mesh.vertices[3 * i];
            v[0] = 2.0f * v[0] + 0.5f * (hi[0] - lo[0]);
            v[1] += 0.5f * (hi[1] - lo[1]);
        }
        for (aacbvh_bvh *b : {ref, wide}) TS_EXPECT_STATUS(aacbvh_bvh_refit(b), AACBVH_OK);
    }
    aacbvh_bvh_destroy(ref);
    aacbvh_bvh_destroy(wide);
    aacbvh_context_destroy(ctx);
    ts_mesh_free(&mesh);
}

/// Runs of eight rays that the AVX2 kernel traces together for their
/// closest hits (intersect_packet(), trace/wide8_kernel_x86.inl): from one
/// eye, inside or outside the scene, through eight neighbouring pixels, at
/// pixel spacings from a ten-thousandth to a tenth of the scene. Some runs
/// are made hard lane by lane: a short or empty window, a window that
/// starts late or after it ends, a lane that repeats another, a direction
/// component of zero (its sign kept, so the run keeps its octant), and, in
/// some runs, a window from below 0 or a lane of another octant (the kernel
/// then traces the run ray by ray). Runs from one eye whose directions have
/// no zero component take the kernel's test of a node against the whole
/// run first (packet_candidates()): its bounds over the lanes' directions,
/// windows (tmin) and reaches must keep every child a lane enters (a bound
/// from one lane alone fails here). Every kernel must answer each ray like
/// the binary traversal, closest hit and occlusion, on every scene kind, with
/// packet leaves; then the same for runs of shadow rays (fill_shadow_runs()),
/// which the AVX2 kernel's any-hit queries trace together.
void fill_pixel_runs(const float lo[3], const float hi[3], ts_rng &rng, std::vector<aacbvh_ray> &rays) {
    for (size_t run = 0; run + 8 <= rays.size(); run += 8) {
        float eye[3], dir[3], step[3];
        const float spacing = std::pow(10.0f, ts_rng_range(&rng, -4.0f, -1.0f));
        for (int k = 0; k < 3; ++k) {
            const float extent = hi[k] - lo[k] > 0.0f ? hi[k] - lo[k] : 1.0f;
            eye[k] = ts_rng_range(&rng, lo[k] - 0.5f * extent, hi[k] + 0.5f * extent);
            dir[k] = ts_rng_range(&rng, lo[k], hi[k]) - eye[k];
            step[k] = ts_rng_range(&rng, -1.0f, 1.0f) * spacing * extent;
        }
        for (int i = 0; i < 8; ++i) {
            aacbvh_ray &r = rays[run + i];
            for (int k = 0; k < 3; ++k) {
                r.org[k] = eye[k];
                r.dir[k] = dir[k] + float(i) * step[k];
            }
            if (r.dir[0] == 0.0f && r.dir[1] == 0.0f && r.dir[2] == 0.0f) r.dir[0] = 1.0f;
            r.tmin = 0.0f;
            r.tmax = INFINITY;
        }
        if (ts_rng_below(&rng, 2) == 0) continue; // a plain run
        for (int i = 0; i < 8; ++i) {
            aacbvh_ray &r = rays[run + i];
            switch (ts_rng_below(&rng, 10)) {
            case 0: r.tmax = ts_rng_range(&rng, 0.0f, 1.0f); break;
            case 1: r.tmax = 0.0f; break;
            case 2: r.tmin = ts_rng_range(&rng, 0.0f, 0.8f); break;
            case 3: r.tmin = 0.9f; r.tmax = 0.5f; break;
            case 4: if (i > 0) r = rays[run + ts_rng_below(&rng, uint32_t(i))]; break;
            case 5: r.dir[ts_rng_below(&rng, 3)] = std::copysign(0.0f, r.dir[0] + r.dir[1] + r.dir[2]); break;
            case 6: if (ts_rng_below(&rng, 4) == 0) r.tmin = -1.0f; break;
            case 7: if (ts_rng_below(&rng, 4) == 0) r.dir[ts_rng_below(&rng, 3)] *= -1.0f; break;
            default: break;
            }
            if (r.dir[0] == 0.0f && r.dir[1] == 0.0f && r.dir[2] == 0.0f) r.dir[0] = 1.0f;
        }
    }
}

/// Runs of eight shadow rays, as a renderer makes them for the hits of
/// neighbouring pixels: from eight points of one triangle (where the rays
/// start on the surface they leave) toward one light, windows [0, 1) up to
/// the light. A quarter of the lanes get a short, late or open window or a
/// direction component of zero (its sign kept).
void fill_shadow_runs(const ts_mesh &mesh, const float lo[3], const float hi[3], ts_rng &rng,
                      std::vector<aacbvh_ray> &rays) {
    float light[3];
    for (int k = 0; k < 3; ++k) {
        const float extent = hi[k] - lo[k] > 0.0f ? hi[k] - lo[k] : 1.0f;
        light[k] = ts_rng_range(&rng, lo[k] - 0.5f * extent, hi[k] + 0.5f * extent);
    }
    const uint32_t triangles = uint32_t(mesh.triangle_count);
    for (size_t run = 0; run + 8 <= rays.size(); run += 8) {
        const uint32_t *tri = &mesh.indices[3 * size_t(ts_rng_below(&rng, triangles))];
        const float *v0 = &mesh.vertices[3 * size_t(tri[0])], *v1 = &mesh.vertices[3 * size_t(tri[1])],
                    *v2 = &mesh.vertices[3 * size_t(tri[2])];
        for (int i = 0; i < 8; ++i) {
            aacbvh_ray &r = rays[run + i];
            float b1 = ts_rng_range(&rng, 0.0f, 1.0f), b2 = ts_rng_range(&rng, 0.0f, 1.0f);
            if (b1 + b2 > 1.0f) {
                b1 = 1.0f - b1;
                b2 = 1.0f - b2;
            }
            for (int k = 0; k < 3; ++k) {
                r.org[k] = v0[k] + b1 * (v1[k] - v0[k]) + b2 * (v2[k] - v0[k]);
                r.dir[k] = light[k] - r.org[k];
            }
            if (r.dir[0] == 0.0f && r.dir[1] == 0.0f && r.dir[2] == 0.0f) r.dir[0] = 1.0f;
            r.tmin = 0.0f;
            r.tmax = 0.9999f;
            if (ts_rng_below(&rng, 4) != 0) continue;
            switch (ts_rng_below(&rng, 4)) {
            case 0: r.tmax = ts_rng_range(&rng, 0.0f, 0.1f); break;
            case 1: r.tmin = ts_rng_range(&rng, 0.0f, 1e-3f); break;
            case 2: r.dir[ts_rng_below(&rng, 3)] = std::copysign(0.0f, r.dir[0] + r.dir[1] + r.dir[2]); break;
            default: r.tmax = INFINITY; break;
            }
            if (r.dir[0] == 0.0f && r.dir[1] == 0.0f && r.dir[2] == 0.0f) r.dir[0] = 1.0f;
        }
    }
}

void test_pixel_runs(void **) {
    const size_t count = TS_RAYS(4000) & ~size_t(7);
    for (int kind = 0; kind < TS_SCENE_KIND_COUNT; ++kind) {
        ts_mesh mesh;
        assert_true(ts_make_scene(ts_scene_kind(kind), 1500, 900 + kind, &mesh));
        aacbvh_context *ctx = nullptr;
        TS_EXPECT_STATUS(aacbvh_context_create(1, &ctx), AACBVH_OK);
        aacbvh_bvh *ref = nullptr, *wide = nullptr;
        make_built_pair(ctx, mesh, ref, wide);
        float lo[3], hi[3];
        ts_coords_bounds(mesh.vertices, 3 * mesh.vertex_count, lo, hi);
        ts_rng rng;
        ts_rng_seed(&rng, 950 + kind);
        std::vector<aacbvh_ray> rays(count);
        fill_pixel_runs(lo, hi, rng, rays);
        char what[96];
        std::snprintf(what, sizeof what, "runs of eight pixels, %s", ts_scene_name(ts_scene_kind(kind)));
        assert_true(compare_kernels(ref, wide, rays.data(), count, what) >= 1);
        if (mesh.triangle_count != 0) {
            fill_shadow_runs(mesh, lo, hi, rng, rays);
            std::snprintf(what, sizeof what, "runs of eight shadow rays, %s", ts_scene_name(ts_scene_kind(kind)));
            assert_true(compare_kernels(ref, wide, rays.data(), count, what) >= 1);
        }
        aacbvh_bvh_destroy(ref);
        aacbvh_bvh_destroy(wide);
        aacbvh_context_destroy(ctx);
        ts_mesh_free(&mesh);
    }
}

/// A ground of quads (y = 0) under a roof of quads (y = 0.5) that covers
/// x < 0.6 with every fifth quad left out, small triangles strewn between
/// them, and a light above: shadow rays from the ground in scanline order,
/// eight neighbours a run, so that runs in a row are stopped by one roof
/// leaf (the runs of eight remember the last occluder and test it first,
/// LastOccluder in trace/wide8_kernel_x86.inl), pass through a hole, or
/// reach the light from the open side; every third ray's window ends
/// before the roof (the remembered leaf would stop the whole ray, not the
/// window). Two lights: one beyond the roof's edge, and one over the roof,
/// so that the runs around the light's x mix the signs of their directions
/// and their rays go alone under the roof, where they too test the runs'
/// last occluder first (trace_alone()), some of them below a hole in it.
/// Every kernel answers as the binary traversal.
void test_shadow_runs_one_occluder(void **) {
    constexpr int kGround = 24, kRoof = 10;
    std::vector<float> v;
    std::vector<uint32_t> idx;
    auto quad = [&](float x0, float z0, float x1, float z1, float y) {
        const uint32_t base = uint32_t(v.size() / 3);
        const float corners[4][3] = {{x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1}};
        for (const auto &c : corners) v.insert(v.end(), c, c + 3);
        const uint32_t t[6] = {base, base + 1, base + 2, base, base + 2, base + 3};
        idx.insert(idx.end(), t, t + 6);
    };
    for (int i = 0; i < kGround; ++i)
        for (int j = 0; j < kGround; ++j)
            quad(float(i) / kGround, float(j) / kGround, float(i + 1) / kGround, float(j + 1) / kGround, 0.0f);
    for (int i = 0; i < kRoof; ++i)
        for (int j = 0; j < kRoof; ++j)
            if ((i * kRoof + j) % 5 != 3)
                quad(0.6f * i / kRoof, float(j) / kRoof, 0.6f * (i + 1) / kRoof, float(j + 1) / kRoof, 0.5f);
    ts_rng rng;
    ts_rng_seed(&rng, 4242);
    for (int k = 0; k < 300; ++k) { // clutter between ground and roof
        const uint32_t base = uint32_t(v.size() / 3);
        const float c[3] = {ts_rng_range(&rng, 0.0f, 1.0f), ts_rng_range(&rng, 0.1f, 0.45f), ts_rng_range(&rng, 0.0f, 1.0f)};
        for (int corner = 0; corner < 3; ++corner)
            for (int a = 0; a < 3; ++a) v.push_back(c[a] + ts_rng_range(&rng, -0.01f, 0.01f));
        idx.push_back(base);
        idx.push_back(base + 1);
        idx.push_back(base + 2);
    }
    ts_mesh mesh;
    mesh.vertex_count = v.size() / 3;
    mesh.triangle_count = idx.size() / 3;
    mesh.vertices = static_cast<float *>(std::malloc(v.size() * sizeof(float)));
    mesh.indices = static_cast<uint32_t *>(std::malloc(idx.size() * sizeof(uint32_t)));
    assert_non_null(mesh.vertices);
    assert_non_null(mesh.indices);
    std::copy(v.begin(), v.end(), mesh.vertices);
    std::copy(idx.begin(), idx.end(), mesh.indices);

    const float lights[2][3] = {{0.8f, 2.0f, 0.5f}, {0.3f, 2.0f, 0.5f}};
    constexpr int kSide = 64;
    for (const float *light : lights) {
        std::vector<aacbvh_ray> rays(size_t(kSide) * kSide);
        for (int j = 0; j < kSide; ++j)
            for (int i = 0; i < kSide; ++i) {
                aacbvh_ray &r = rays[size_t(j) * kSide + i];
                const float org[3] = {(i + 0.5f) / kSide, 1e-4f, (j + 0.5f) / kSide};
                for (int a = 0; a < 3; ++a) {
                    r.org[a] = org[a];
                    r.dir[a] = light[a] - org[a];
                }
                r.tmin = 0.0f;
                r.tmax = (i + j) % 3 == 0 ? 0.2f : 0.9999f; // 0.2: ends below the roof (t = 0.25)
            }
        // The runs that mix the signs of their directions (those around the
        // light's x) lie under the roof when the light is over it.
        size_t mixed_under_roof = 0;
        for (size_t k = 0; k + 8 <= rays.size(); k += 8) {
            bool mixed = false;
            for (size_t m = k; m < k + 8; ++m)
                for (int a = 0; a < 3; ++a) mixed |= (rays[m].dir[a] < 0.0f) != (rays[k].dir[a] < 0.0f);
            if (mixed && rays[k].org[0] < 0.5f) mixed_under_roof += 8;
        }
        if (light[0] < 0.6f) assert_true(mixed_under_roof >= rays.size() / 16);
        for (uint32_t threads = kFirstThreads; threads <= 2; ++threads) {
            aacbvh_context *ctx = nullptr;
            TS_EXPECT_STATUS(aacbvh_context_create(threads, &ctx), AACBVH_OK);
            aacbvh_bvh *ref = nullptr, *wide = nullptr;
            make_built_pair(ctx, mesh, ref, wide);
            std::vector<uint8_t> occluded(rays.size());
            TS_EXPECT_STATUS(aacbvh_bvh_occluded(ref, rays.data(), occluded.data(), rays.size()), AACBVH_OK);
            size_t stopped = 0, stopped_short = 0;
            for (size_t k = 0; k < rays.size(); ++k) {
                stopped += occluded[k];
                stopped_short += occluded[k] && rays[k].tmax < 0.5f;
            }
            // The scene does what it is for: most full rays under the roof are
            // stopped, the open side and the holes let others through, and the
            // short windows are stopped by clutter at most.
            assert_true(stopped > rays.size() / 4 && stopped < rays.size() * 3 / 4);
            assert_true(stopped_short < stopped / 3);
            char what[96];
            std::snprintf(what, sizeof what, "shadow runs under one roof, light at x = %.1f, %u threads",
                          double(light[0]), threads);
            assert_true(compare_kernels(ref, wide, rays.data(), rays.size(), what) >= 1);
            aacbvh_bvh_destroy(ref);
            aacbvh_bvh_destroy(wide);
            aacbvh_context_destroy(ctx);
        }
    }
    ts_mesh_free(&mesh);
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kernels_available),
        cmocka_unit_test(test_every_scene_kind),
        cmocka_unit_test(test_far_watertight_grid),
        cmocka_unit_test(test_boxes),
        cmocka_unit_test(test_rays_from_outside),
        cmocka_unit_test(test_pixel_runs),
        cmocka_unit_test(test_shadow_runs_one_occluder),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
