// The node box test is at least as conservative as the triangle test: when
// intersect_triangle() (lib/trace/triangle_intersect.h) hits a triangle at t, the
// box test (lib/trace/ray_box.h) of the triangle's bounding box must pass it with
// the window [tmin, tmax] and with [tmin, t] (traversal shrinks tmax to the
// best hit), and report an entry distance <= t. Both within 1e-5 (|t| + L / |dir|): the
// triangle's own t is off by ulps (more for slivers), and the tolerance
// documented at aacbvh_bvh_intersect() allows ties that close. Random and adversarial cases: axis-aligned
// triangles (flat boxes), rays aimed exactly at vertices and edges, direction
// components of +-0 and denormals, axis-parallel rays, far from the origin.
// The same for ray_box_from_zero() (the wide kernels' test for windows from
// 0 on), and the bound its exit scale rests on (test_exit_scale_bound).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <cfloat>
#include <cmath>
#include <cstdio>

#include "core/box.h"
#include "trace/ray_box.h"
#include "trace/triangle_intersect.h"

#include "xorshift_rng.h"

namespace {

using namespace aacbvh;

using Rng = XorshiftRng;

struct Counts {
    uint64_t rays = 0, hits = 0, axis_aligned_hits = 0, on_surface = 0, from_zero = 0;
};

Box box_of(const float *p0, const float *p1, const float *p2) {
    Box b = Box::empty();
    b.extend(p0);
    b.extend(p1);
    b.extend(p2);
    return b;
}

/// One ray against one triangle; fails the test if the box would cull a hit.
void check(const float org[3], const float dir[3], const float *p[3], float tmin, float tmax, Counts &counts,
           bool axis_aligned) {
    ++counts.rays;
    const TriangleRay tr = make_triangle_ray(org, dir);
    float t, u, v;
    if (!intersect_triangle(tr, p[0], p[1], p[2], tmin, tmax, t, u, v)) return;
    ++counts.hits;
    counts.axis_aligned_hits += axis_aligned;
    const BoxRay br = make_box_ray(org, dir);
    const Box box = box_of(p[0], p[1], p[2]);
    float t_entry = NAN, t_point = NAN, ta = NAN, tb = NAN;
    const bool window = ray_box_conservative(br, box, tmin, tmax, t_entry);
    // Traversal shrinks tmax to the best hit so far: [tmin, t] must pass too.
    // The documented tolerance of t: 1e-5 (|t| + L / |dir|), L the largest
    // distance from the origin to a vertex.
    double L = 0.0, dl = 0.0;
    for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) L = std::fmax(L, std::fabs(double(p[j][k]) - org[k]));
    for (int k = 0; k < 3; ++k) dl += double(dir[k]) * dir[k];
    dl = std::sqrt(dl);
    const float slack = float(1e-5 * (std::fabs(double(t)) + L / dl));
    const bool point = ray_box_conservative(br, box, tmin, t + slack, t_point);
    const unsigned pair = ray_box_pair_conservative(br, box, box, tmin, tmax, ta, tb);
    // The entry distance may exceed t by the triangle's own rounding of t
    // (ulps; more for slivers): pruning against it only drops ties within
    // the tolerance documented at aacbvh_bvh_intersect().
    bool ok = window && t_entry <= t + slack && point && pair == 3u && ta <= t + slack && tb <= t + slack;
    // The wide kernels' test for windows from 0 on (exits through inv_far):
    // the same guarantees, and never a later entry.
    bool from_zero = true;
    if (tmin >= 0.0f) {
        float z_entry = NAN, z_point = NAN;
        from_zero = ray_box_from_zero(br, box, tmin, tmax, z_entry) && z_entry == t_entry &&
                    ray_box_from_zero(br, box, tmin, t + slack, z_point) && z_point == t_point;
        ++counts.from_zero;
    }
    ok = ok && from_zero;
    if (!ok) {
        // A ray starting on the surface: the triangle's t carries an absolute
        // error of about eps * L / |dir| (L: distance to the vertices), which
        // the box's relative widening does not cover. Counted, not failed:
        // the exact distance is 0 within rounding either way.
        if (std::fabs(double(t)) <= 1e-5 * L / dl) {
            ++counts.on_surface;
            return;
        }
    }
    if (!ok)
        fail_msg("box culls a triangle hit at t = %.9g (window %d entry %.9g, [t, t] %d, pair %u, from zero %d)\n"
                 "  org %a %a %a dir %a %a %a tmin %a tmax %a\n  p0 %a %a %a\n  p1 %a %a %a\n  p2 %a %a %a",
                 double(t), int(window), double(t_entry), int(point), pair, int(from_zero), double(org[0]), double(org[1]),
                 double(org[2]), double(dir[0]), double(dir[1]), double(dir[2]), double(tmin), double(tmax),
                 double(p[0][0]), double(p[0][1]), double(p[0][2]), double(p[1][0]), double(p[1][1]),
                 double(p[1][2]), double(p[2][0]), double(p[2][1]), double(p[2][2]));
}

/// A triangle around `centre` of size `size`; kind 0 random, 1..3 flat on
/// axis kind-1 (axis-aligned plane), 4 with an axis-aligned edge.
void make_triangle(Rng &rng, const float centre[3], float size, int kind, float out[3][3]) {
    for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) out[j][k] = centre[k] + size * rng.range(-1.0f, 1.0f);
    if (kind >= 1 && kind <= 3)
        for (int j = 1; j < 3; ++j) out[j][kind - 1] = out[0][kind - 1];
    if (kind == 4) {
        const int axis = int(rng.below(3));
        for (int k = 0; k < 3; ++k)
            if (k != axis) out[1][k] = out[0][k];
    }
}

/// A direction: random, or with some components +-0 or denormal.
void make_direction(Rng &rng, float dir[3], bool &axis_aligned) {
    for (int k = 0; k < 3; ++k) dir[k] = rng.range(-1.0f, 1.0f);
    axis_aligned = false;
    switch (rng.below(5)) {
    case 0: break;
    case 1: { // one axis only: axis-parallel
        const int axis = int(rng.below(3));
        for (int k = 0; k < 3; ++k)
            if (k != axis) dir[k] = (rng.next() & 1) ? 0.0f : -0.0f;
        axis_aligned = true;
        break;
    }
    case 2: // one zero component
        dir[rng.below(3)] = (rng.next() & 1) ? 0.0f : -0.0f;
        break;
    case 3: // denormal components
        dir[rng.below(3)] = float(rng.range(-1.0f, 1.0f) * 1e-40);
        dir[rng.below(3)] = (rng.next() & 1) ? FLT_TRUE_MIN : -FLT_TRUE_MIN;
        break;
    default: // a tiny but normal component
        dir[rng.below(3)] = rng.range(-1.0f, 1.0f) * 1e-30f;
        break;
    }
    if (dir[0] == 0.0f && dir[1] == 0.0f && dir[2] == 0.0f) dir[2] = 1.0f;
}

void run(float offset, float size, uint64_t seed, Counts &counts) {
    Rng rng{seed};
    for (int i = 0; i < 20000; ++i) {
        const float centre[3] = {offset + rng.range(-1.0f, 1.0f), offset + rng.range(-1.0f, 1.0f),
                                 offset + rng.range(-1.0f, 1.0f)};
        float tri[3][3];
        make_triangle(rng, centre, size, int(rng.below(5)), tri);
        const float *p[3] = {tri[0], tri[1], tri[2]};
        for (int r = 0; r < 8; ++r) {
            float dir[3];
            bool axis_aligned;
            make_direction(rng, dir, axis_aligned);
            // Target: a vertex, a point on an edge, or inside.
            float target[3];
            const int j = int(rng.below(3));
            const float s = (r & 1) ? 0.0f : (r & 2) ? 0.5f : rng.unit();
            for (int k = 0; k < 3; ++k) target[k] = tri[j][k] + s * (tri[(j + 1) % 3][k] - tri[j][k]);
            if (r >= 6) {
                float w = rng.unit(), x = rng.unit();
                if (w + x > 1.0f) { w = 1.0f - w; x = 1.0f - x; }
                for (int k = 0; k < 3; ++k)
                    target[k] = (1.0f - w - x) * tri[0][k] + w * tri[1][k] + x * tri[2][k];
            }
            // Origin: behind the target along -dir (so the ray runs through it),
            // exactly on it (t = 0), or with an origin coordinate exactly on
            // the flat box plane.
            float org[3];
            const float back = (r == 3) ? 0.0f : rng.range(0.5f, 4.0f);
            for (int k = 0; k < 3; ++k) org[k] = target[k] - back * dir[k];
            float tmin = 0.0f, tmax = INFINITY;
            switch (rng.below(4)) {
            case 0: break;
            case 1: tmin = -INFINITY; break;
            case 2: tmax = back; break; // a hit exactly at tmax
            default: tmin = back * 0.999f; tmax = back * 1.001f; break;
            }
            check(org, dir, p, tmin, tmax, counts, axis_aligned);
        }
    }
}

void test_box_is_conservative(void **) {
    Counts counts;
    const float placements[][2] = {{0.0f, 1.0f}, {0.0f, 1e-3f}, {1e5f, 1.0f}, {-1e5f, 100.0f},
                                   {1e20f, 1e18f}, {1e-20f, 1e-22f}, {0.0f, 1e-30f}};
    uint64_t seed = 1;
    for (const auto &pl : placements) run(pl[0], pl[1], seed++, counts);
    std::printf("box vs triangle: %llu ray/triangle pairs, %llu hits (%llu axis-parallel), 0 culled, "
                "%llu at t ~ 0 (origin on the surface) not judged\n",
                (unsigned long long)counts.rays, (unsigned long long)counts.hits,
                (unsigned long long)counts.axis_aligned_hits, (unsigned long long)counts.on_surface);
    assert_true(counts.hits > counts.rays / 4);
}

/// The classic trap: a triangle in an axis-aligned plane (a flat box) hit by
/// rays at grazing and exactly-parallel directions, origins on the plane.
void test_flat_boxes(void **) {
    Counts counts;
    Rng rng{99};
    for (int i = 0; i < 50000; ++i) {
        const int axis = int(rng.below(3));
        const float plane = (i & 1) ? 1e5f + rng.range(-1.0f, 1.0f) : rng.range(-1.0f, 1.0f);
        float tri[3][3];
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) tri[j][k] = k == axis ? plane : rng.range(-1.0f, 1.0f) + (i & 1) * 1e5f;
        const float *p[3] = {tri[0], tri[1], tri[2]};
        float target[3];
        const int j = int(rng.below(3));
        const float s = rng.unit();
        for (int k = 0; k < 3; ++k) target[k] = tri[j][k] + s * (tri[(j + 1) % 3][k] - tri[j][k]);
        float dir[3];
        for (int k = 0; k < 3; ++k) dir[k] = rng.range(-1.0f, 1.0f);
        dir[axis] = (i % 3 == 0) ? rng.range(-1e-6f, 1e-6f) : rng.range(-1.0f, 1.0f);
        float org[3];
        const float back = rng.range(0.1f, 10.0f);
        for (int k = 0; k < 3; ++k) org[k] = target[k] - back * dir[k];
        check(org, dir, p, 0.0f, INFINITY, counts, false);
    }
    std::printf("flat boxes: %llu hits of %llu, 0 culled\n", (unsigned long long)counts.hits,
                (unsigned long long)counts.rays);
}

/// The bound behind ray_box_from_zero(): an exit distance computed through
/// inv_far is at least the exact one times 1 + gamma(3), for every exit at
/// or after the origin whose factors stay normal floats (the same premise as
/// the additive widening). The exact distance (plane - org) / dir in double:
/// the difference of two floats is exact there, the quotient rounds once
/// (relative 2^-53, allowed for). Planes, origins and directions from 1e-6
/// to 1e6 and beyond, differences down to one ulp.
void test_exit_scale_bound(void **) {
    const double eps = 0x1p-24, gamma3 = 3.0 * eps / (1.0 - 3.0 * eps);
    assert_true(double(kFarScale) - 1.0 >= 7.0 * eps);
    assert_true(double(kFarScale) - 1.0 <= 16.0 * eps);
    Rng rng{2026};
    const float scales[] = {1e-6f, 1e-3f, 1.0f, 1e3f, 1e6f, 1e12f};
    uint64_t checked = 0;
    for (int i = 0; i < 400000; ++i) {
        const float scale = scales[rng.below(6)];
        const float org = rng.range(-1.0f, 1.0f) * scale;
        float plane = org + rng.range(0.0f, 2.0f) * scales[rng.below(6)];
        if (i % 4 == 0) plane = std::nextafter(org, INFINITY); // one ulp ahead
        const float dir_scale = scales[rng.below(6)];
        float dir = rng.range(0.0f, 1.0f) * dir_scale;
        if (rng.below(2) == 1) {
            dir = -dir;
            plane = org - (plane - org); // behind along the axis, ahead along the ray
        }
        if (dir == 0.0f) continue;
        const float orgs[3] = {org, 0.0f, 0.0f}, dirs[3] = {dir, 1.0f, 1.0f};
        const BoxRay r = make_box_ray(orgs, dirs);
        const float diff = plane - org;
        const float exit = diff * r.inv_far[0];
        if (!std::isnormal(diff) || !std::isnormal(exit) || !std::isnormal(r.inv[0])) continue;
        const double exact = (double(plane) - double(org)) / double(dir);
        if (exact < 0.0) continue;
        ++checked;
        const double need = exact * (1.0 + gamma3) * (1.0 - 0x1p-52);
        if (double(exit) < need)
            fail_msg("exit %a < exact %a (1 + gamma(3)): plane %a org %a dir %a", double(exit), exact,
                     double(plane), double(org), double(dir));
    }
    std::printf("exit scale: %llu exits at or after the origin checked\n", (unsigned long long)checked);
    assert_true(checked > 100000);
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_box_is_conservative),
        cmocka_unit_test(test_flat_boxes),
        cmocka_unit_test(test_exit_scale_bound),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
