// extent_scale_of() (lib/core/box.h), the power of two by which the builders,
// the flattening, the wide collapses and the optimiser scale extents before
// weighing areas in single precision: for every exponent a float extent can
// have, normal or denormal, the scale is a finite power of two, the largest
// extent times it lands in [0.5, 1) (denormal extents: above 2^-24, the most
// 2^126 can lift them), the scaled half area is the double-precision one
// times the scale's square within single precision's rounding, a box scaled
// by a power of two has the same scaled half area bit for bit, and empty,
// point-sized, infinite and NaN bounds get 1.
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

#include "core/box.h"

namespace {

using aacbvh::Box;

bool is_power_of_two(float x) {
    int e = 0;
    return std::isfinite(x) && x > 0.0f && std::frexp(x, &e) == 0.5f;
}

Box box_of(float lo_x, float hi_x, float dy, float dz) {
    return Box{{lo_x, 0.0f, 0.0f}, {hi_x, dy, dz}};
}

void test_every_exponent(void **) {
    for (int e = -149; e <= 127; ++e) {
        // The largest extent 1.5 * 2^e where it is a float (2^e below that),
        // on x; the other two smaller.
        const float largest = e >= -148 ? std::ldexp(1.5f, e) : std::ldexp(1.0f, e);
        const Box b = box_of(-largest, 0.0f, largest * 0.5f, largest * 0.25f);
        const float scale = aacbvh::extent_scale_of(b);
        if (!is_power_of_two(scale)) fail_msg("extent 2^%d: scale %a is not a finite power of two", e, double(scale));
        const float scaled = b.extent(0) * scale;
        if (e >= -126) {
            if (!(scaled >= 0.5f && scaled < 1.0f)) fail_msg("extent 2^%d: scaled to %a", e, double(scaled));
        } else if (!(scaled > 0x1p-24f && scaled < 1.0f)) {
            fail_msg("denormal extent 2^%d: scaled to %a", e, double(scaled));
        }
        // The double-precision half area times scale^2, within single
        // precision's rounding, where the products stay normal floats.
        const double exact = b.area() * 0.5 * double(scale) * double(scale);
        const double area = aacbvh::scaled_half_area(b, scale);
        if (e >= -100 && area != double(float(exact)) && std::fabs(area - exact) > 1e-6 * exact)
            fail_msg("extent 2^%d: scaled half area %a, expected %a", e, area, exact);
    }
}

void test_scale_invariance(void **) {
    // A box and the same box times 2^k have the same scaled half area, bit
    // for bit, for every k that keeps both normal.
    const Box b = box_of(-0.7f, 0.3f, 0.45f, 0.2f);
    const float reference = aacbvh::scaled_half_area(b, aacbvh::extent_scale_of(b));
    for (int k = -100; k <= 100; ++k) {
        Box s = b;
        for (int a = 0; a < 3; ++a) {
            s.lo[a] = std::ldexp(b.lo[a], k);
            s.hi[a] = std::ldexp(b.hi[a], k);
        }
        const float area = aacbvh::scaled_half_area(s, aacbvh::extent_scale_of(s));
        if (area != reference) fail_msg("scaled by 2^%d: %a, at 1: %a", k, double(area), double(reference));
    }
}

void test_degenerate_bounds(void **) {
    const Box cases[] = {
        Box::empty(),
        Box{{1.0f, 2.0f, 3.0f}, {1.0f, 2.0f, 3.0f}},                   // a point
        Box{{-INFINITY, 0.0f, 0.0f}, {1.0f, 1.0f, 1.0f}},              // infinite
        Box{{-FLT_MAX, -FLT_MAX, 0.0f}, {FLT_MAX, FLT_MAX, 1.0f}},     // overflowing extent
        Box{{NAN, 0.0f, 0.0f}, {1.0f, 1.0f, 1.0f}},                    // NaN
    };
    for (const Box &b : cases)
        if (aacbvh::extent_scale_of(b) != 1.0f) fail_msg("expected 1, got %a", double(aacbvh::extent_scale_of(b)));
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_exponent),
        cmocka_unit_test(test_scale_invariance),
        cmocka_unit_test(test_degenerate_bounds),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
