// The closest-hit child order on hand-made trees (lib/trace/traversal.cpp):
// the child entered nearer is visited first; when both are entered at the
// same distance (the ray starts inside both boxes) the smaller box comes
// first, whichever side it is on. The order shows in the work a query does:
// the hit found in the first child prunes the other child's subtree.
//
// The trees: the root's children are a small leaf S (one triangle at z = 1)
// and a large inner node L (a leaf with a triangle at z = 10, whose box
// starts at z = 9.9, and a leaf off the ray's path), on either side. From
// the origin along +z, both root children hold the origin: smaller first
// finds z = 1 and never tests the far triangle (1 triangle test); larger
// first tests the far one too (2). From z = -20 the large box is entered
// first (t = 15 against 19.5), and its far triangle is tested before the
// small box is reached (2 tests), although the small box is smaller.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <cmath>
#include <vector>

#include "bvh/bvh.h"
#include "core/geometry.h"
#include "trace/traversal.h"

namespace {

// Triangles: 0 at z = 1 around the axis (in S), 1 at z = 10 around the axis,
// 2 at z = -4.5 but at x in [5, 6], off the ray's path (both in L).
const float kVertices[] = {
    -0.5f, -0.5f, 1.0f,  0.5f, -0.5f, 1.0f,  0.0f, 0.5f, 1.0f,   // 0
    -9.0f, -9.0f, 10.0f, 9.0f, -9.0f, 10.0f, 0.0f, 9.0f, 10.0f,  // 1
    5.0f,  -0.5f, -4.5f, 6.0f, -0.5f, -4.5f, 5.5f, 0.5f, -4.5f,  // 2
};

aacbvh::Node node(float x0, float y0, float z0, float x1, float y1, float z1, uint32_t first, uint32_t count) {
    aacbvh::Node n;
    n.box.lo[0] = x0;
    n.box.lo[1] = y0;
    n.box.lo[2] = z0;
    n.box.hi[0] = x1;
    n.box.hi[1] = y1;
    n.box.hi[2] = z1;
    n.first = first;
    n.count = count;
    return n;
}

/// The tree with S on the left (small_left) or on the right. Leaf slots:
/// 0 -> triangle 0, 1 -> triangle 1, 2 -> triangle 2.
aacbvh::Bvh make_tree(bool small_left) {
    aacbvh::Bvh bvh;
    bvh.nodes.resize(5);
    bvh.prim_ids.resize(3);
    for (uint32_t i = 0; i < 3; ++i) bvh.prim_ids[i] = i;
    const aacbvh::Node small = node(-1, -1, -0.5f, 1, 1, 1, 0, 1);
    const aacbvh::Node large = node(-10, -10, -5, 10, 10, 20, 3, 0);
    bvh.nodes[0] = node(-10, -10, -5, 10, 10, 20, 1, 0);
    bvh.nodes[1] = small_left ? small : large;
    bvh.nodes[2] = small_left ? large : small;
    bvh.nodes[3] = node(-9, -9, 9.9f, 9, 9, 10.1f, 1, 1); // triangle 1
    bvh.nodes[4] = node(5, -0.5f, -4.6f, 6, 0.5f, -4.4f, 2, 1); // triangle 2, off the path
    return bvh;
}

aacbvh::Geometry make_geometry() {
    aacbvh::Geometry g;
    g.kind = aacbvh::GeometryKind::Triangles;
    g.vertices = kVertices;
    g.vertex_count = 9;
    g.vertex_stride = 3 * sizeof(float);
    g.indices = nullptr;
    g.primitive_count = 3;
    return g;
}

/// Traces from (0, 0, z0) along +z; returns the triangle tests made and
/// checks the hit (triangle 0 at t = 1 - z0 either way).
uint64_t triangle_tests(const aacbvh::Bvh &bvh, float z0) {
    const aacbvh::Geometry g = make_geometry();
    aacbvh_ray ray = {{0.0f, 0.0f, z0}, 0.0f, {0.0f, 0.0f, 1.0f}, INFINITY};
    aacbvh_hit hit;
    aacbvh::TraversalCounters counters;
    aacbvh::intersect_ray(bvh, g, ray, hit, &counters);
    assert_int_equal(hit.prim_id, 0);
    assert_true(hit.t == 1.0f - z0);
    return counters.primitive_tests;
}

/// Both children hold the origin (a tie at tmin): the smaller box first, on
/// either side.
void test_tie_goes_to_the_smaller_box(void **) {
    for (bool small_left : {true, false}) {
        const aacbvh::Bvh bvh = make_tree(small_left);
        const uint64_t tests = triangle_tests(bvh, 0.0f);
        if (tests != 1)
            fail_msg("origin inside both children, small box on the %s: %llu triangle tests, want 1 (small box first)",
                     small_left ? "left" : "right", (unsigned long long)tests);
    }
}

/// Outside both: the nearer entry first, although it is the larger box.
void test_nearer_entry_first(void **) {
    for (bool small_left : {true, false}) {
        const aacbvh::Bvh bvh = make_tree(small_left);
        const uint64_t tests = triangle_tests(bvh, -20.0f);
        if (tests != 2)
            fail_msg("from z = -20, small box on the %s: %llu triangle tests, want 2 (the nearer, larger box first)",
                     small_left ? "left" : "right", (unsigned long long)tests);
    }
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tie_goes_to_the_smaller_box),
        cmocka_unit_test(test_nearer_entry_first),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
