// The closest-hit child order on hand-made trees, in every layout (the binary
// traversal in lib/trace/traversal.cpp, WIDE4 and WIDE8 with each kernel),
// the rule of lib/trace/child_order.h: the child entered nearer is visited
// first; children that hold the ray's origin (entered at tmin) come first,
// by their exit distance, the box left sooner first; of equal keys the
// smaller box first, whichever side it is on. The order shows in the work a
// query does: the hit found in the first child prunes the other child's
// subtree.
//
// The first trees: the root's children are a small leaf S (one triangle at
// z = 1) and a large inner node L (a leaf with a triangle at z = 10, whose
// box starts at z = 9.9, and a leaf off the ray's path), on either side,
// both boxes ending at z = 20. From the origin along +z, both root children
// hold the origin and are left at the same distance: smaller first finds
// z = 1 and never tests the far triangle (1 triangle test); larger first
// tests the far one too (2). From z = -20 the large box is entered first
// (t = 15 against 19.5), and its far triangle is tested before the small box
// is reached (2 tests), although the small box is smaller.
// test_every_layout_visits_alike makes such cases survive the wide layouts'
// collapse (see make_wide_case()) and asks every layout for the same count
// of triangle tests, with a second case where the larger box around the
// origin is left sooner and holds the nearer hit: the exit decides, not the
// size.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "bvh/bvh.h"
#include "bvh/wide8_bvh.h"
#include "bvh/wide_bvh.h"
#include "core/geometry.h"
#include "core/scheduler.h"
#include "trace/child_order.h"
#include "trace/traversal.h"
#include "trace/wide8_traversal.h"
#include "trace/wide_traversal.h"

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
    const aacbvh::Node small = node(-1, -1, -0.5f, 1, 1, 20, 0, 1);
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

/// Both children hold the origin and are left at the same distance (a tie
/// of keys): the smaller box first, on either side.
void test_tie_goes_to_the_smaller_box(void **) {
    for (bool small_left : {true, false}) {
        const aacbvh::Bvh bvh = make_tree(small_left);
        const uint64_t tests = triangle_tests(bvh, 0.0f);
        if (tests != 1)
            fail_msg("origin inside both children, same exit, small box on the %s: %llu triangle tests, want 1 "
                     "(small box first)",
                     small_left ? "left" : "right", (unsigned long long)tests);
    }
}

/// The key of a child holding the origin (trace/child_order.h): below every
/// entry distance at or above tmin >= 0, and increasing with the exit, over
/// exits from +0 to +inf (random bits and the extremes).
void test_inside_keys_order_by_exit(void **) {
    std::vector<float> exits = {0.0f, 0x1p-149f, FLT_MIN, 1e-30f, 0.5f, 1.0f, 1.0000001f, 3e38f, FLT_MAX, INFINITY};
    uint32_t state = 12345u;
    for (int i = 0; i < 2000; ++i) {
        state = state * 1664525u + 1013904223u;
        uint32_t bits = state % 0x7F800001u; // +0 .. +inf
        float x;
        std::memcpy(&x, &bits, sizeof x);
        exits.push_back(x);
    }
    std::sort(exits.begin(), exits.end());
    for (size_t i = 0; i < exits.size(); ++i) {
        const float key = aacbvh::inside_order_key(exits[i]);
        if (!(key < 0.0f) && !(key == 0.0f && std::signbit(key)))
            fail_msg("exit %a: key %a is not negative", double(exits[i]), double(key));
        if (!(key < 0x1p-149f)) fail_msg("exit %a: key %a not below the smallest positive entry", double(exits[i]), double(key));
        if (i > 0 && exits[i] > exits[i - 1] && !(key > aacbvh::inside_order_key(exits[i - 1])))
            fail_msg("exits %a < %a: keys %a, %a not increasing", double(exits[i - 1]), double(exits[i]),
                     double(aacbvh::inside_order_key(exits[i - 1])), double(key));
    }
    assert_true(aacbvh::inside_order_key(0.0f) == -INFINITY);
    // A box that ends exactly at the origin (exit -0) is still inside: its
    // key must stay below tmin, or the traversal would prune it.
    assert_true(aacbvh::inside_order_key(-0.0f) == -INFINITY);
    // Entries above tmin keep their distance; at tmin the exit decides.
    assert_true(aacbvh::child_order_key(2.0f, 5.0f, 1.0f) == 2.0f);
    assert_true(aacbvh::child_order_key(1.0f, 5.0f, 1.0f) < aacbvh::child_order_key(1.0f, 6.0f, 1.0f));
    assert_true(aacbvh::child_order_key(1.0f, 6.0f, 1.0f) < aacbvh::child_order_key(1.5f, 2.0f, 1.0f));
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

// The wide layouts collapse the root's inner children into one node, so the
// tree above would leave no tie there. The tree below keeps one: the root's
// children are S (as above) and T = (X, U). X is an inner node around the
// origin (its box as L's: a leaf with triangle 1 at z = 10 and a leaf with
// triangle 2 off the path); U is a subtree of eight leaves far off the path
// (x from 30 on) whose seven boxes are each larger than X's. The collapse
// opens the largest inner child first: T, then U's seven inner nodes fill
// the root's slots (8 in WIDE8: S, X and six of U's; 4 in WIDE4: S, X and
// U's two halves) before X is opened. In every layout the root then holds S
// and the larger X, both around the origin, and the same rule must decide.
// Leaf slots: 0 -> triangle 0 (S), 1 -> triangle 1, 2 -> triangle 2, 3..10
// -> triangles 3..10 (U's leaves).
struct WideCase {
    std::vector<float> vertices;
    aacbvh::Bvh bvh;
};

/// U's eight triangles: small, at x = 40 + 20 j, z = 0, far off the ray's path.
void append_far_triangles(std::vector<float> &vertices) {
    for (uint32_t j = 0; j < 8; ++j) {
        const float x = 40.0f + 20.0f * float(j);
        const float tri[9] = {x, 0.0f, 0.0f, x + 1.0f, 0.0f, 0.0f, x, 1.0f, 0.0f};
        vertices.insert(vertices.end(), tri, tri + 9);
    }
}

/// U's nodes 7..20 (its two halves, their four quarters, and its eight
/// leaves, slots first_slot..first_slot + 7): boxes over x >= 30 and
/// y in [-100, 100], z in [z_lo, z_hi], each far larger than X's.
void set_far_subtree(aacbvh::Bvh &bvh, float z_lo, float z_hi, uint32_t first_slot) {
    bvh.nodes[7] = node(30, -100, z_lo, 110, 100, z_hi, 9, 0);
    bvh.nodes[8] = node(110, -100, z_lo, 200, 100, z_hi, 11, 0);
    bvh.nodes[9] = node(30, -100, z_lo, 70, 100, z_hi, 13, 0);
    bvh.nodes[10] = node(70, -100, z_lo, 110, 100, z_hi, 15, 0);
    bvh.nodes[11] = node(110, -100, z_lo, 150, 100, z_hi, 17, 0);
    bvh.nodes[12] = node(150, -100, z_lo, 200, 100, z_hi, 19, 0);
    for (uint32_t j = 0; j < 8; ++j) {
        const float x = 40.0f + 20.0f * float(j);
        bvh.nodes[13 + j] = node(x, 0, 0, x + 1, 1, 0, first_slot + j, 1);
    }
}

WideCase make_wide_case(bool small_left) {
    WideCase c;
    c.vertices.assign(kVertices, kVertices + 27);
    append_far_triangles(c.vertices);
    aacbvh::Bvh &bvh = c.bvh;
    bvh.prim_ids.resize(11);
    for (uint32_t i = 0; i < 11; ++i) bvh.prim_ids[i] = i;
    // Nodes, children of an inner node at `first`, `first + 1`:
    //  0 root: 1, 2 = S and T (or T and S)
    //  T: 3 = X, 4 = U
    //  X: 5 (triangle 1), 6 (triangle 2)
    //  U: 7, 8; 7: 9, 10; 8: 11, 12; 9..12: 13..20, leaves (triangles 3..10)
    bvh.nodes.resize(21);
    const aacbvh::Node small = node(-1, -1, -0.5f, 1, 1, 1, 0, 1);
    const uint32_t t_index = small_left ? 2 : 1;
    const aacbvh::Node t_node = node(-10, -100, -100, 200, 100, 100, 3, 0);
    bvh.nodes[0] = node(-10, -100, -100, 200, 100, 100, 1, 0);
    bvh.nodes[small_left ? 1 : 2] = small;
    bvh.nodes[t_index] = t_node;
    bvh.nodes[3] = node(-10, -10, -5, 10, 10, 20, 5, 0);                 // X
    bvh.nodes[4] = node(30, -100, -100, 200, 100, 100, 7, 0);            // U
    bvh.nodes[5] = node(-9, -9, 9.9f, 9, 9, 10.1f, 1, 1);               // triangle 1
    bvh.nodes[6] = node(5, -0.5f, -4.6f, 6, 0.5f, -4.4f, 2, 1);          // triangle 2
    set_far_subtree(bvh, -100, 100, 3); // areas far above X's 2,800
    return c;
}

// The exit case: the same frame, but the box left sooner is the larger one.
// S is now a thin inner node around the axis from z = -0.5 to 30 (area 252)
// over a leaf with triangle 1 at z = 25 and a leaf off the path; X (area
// 1,360) is flat, z from -5 to 2, over the leaf of triangle 0 at z = 1 and a
// leaf off the path. U's boxes are flat too (z from -5 to 2), so T = (X, U)
// is left at z = 2 as X is, and the binary traversal meets the same choice
// at the root (S against T) as the wide layouts do (S against X). From the
// origin: X first (left at t = 2, S at 30) finds t = 1, and S's far leaf
// (entered at 24.9) is pruned: 1 triangle test; S first, the smaller box,
// would test triangle 1 first (2). From z = -20: X is entered first (15
// against 19.5), 1 test either way.
// Leaf slots: 0 -> triangle 0 (in X), 1 -> triangle 1 (in S), 2 -> triangle
// 2 (in S, off the path), 3 -> triangle 3 (in X, off the path), 4..11 ->
// triangles 4..11 (U's leaves).
WideCase make_exit_case(bool small_left) {
    WideCase c;
    const float tris[4][9] = {
        {-0.5f, -0.5f, 1.0f, 0.5f, -0.5f, 1.0f, 0.0f, 0.5f, 1.0f},     // 0: on the path, z = 1
        {-0.5f, -0.5f, 25.0f, 0.5f, -0.5f, 25.0f, 0.0f, 0.5f, 25.0f},  // 1: on the path, z = 25
        {0.6f, 0.6f, -0.4f, 0.9f, 0.6f, -0.4f, 0.75f, 0.9f, -0.4f},   // 2: off the path, in S
        {5.0f, -0.5f, -4.5f, 6.0f, -0.5f, -4.5f, 5.5f, 0.5f, -4.5f},   // 3: off the path, in X
    };
    for (const auto &t : tris) c.vertices.insert(c.vertices.end(), t, t + 9);
    append_far_triangles(c.vertices);
    aacbvh::Bvh &bvh = c.bvh;
    bvh.prim_ids.resize(12);
    for (uint32_t i = 0; i < 12; ++i) bvh.prim_ids[i] = i;
    // Nodes, children of an inner node at `first`, `first + 1`:
    //  0 root: 1, 2 = S and T (or T and S); S: 21, 22; T: 3 = X, 4 = U
    //  X: 5 (triangle 0), 6 (triangle 3)
    //  U: 7, 8; 7: 9, 10; 8: 11, 12; 9..12: 13..20, leaves (triangles 4..11)
    bvh.nodes.resize(23);
    bvh.nodes[0] = node(-10, -100, -5, 200, 100, 30, 1, 0);
    bvh.nodes[small_left ? 1 : 2] = node(-1, -1, -0.5f, 1, 1, 30, 21, 0);    // S
    bvh.nodes[small_left ? 2 : 1] = node(-10, -100, -5, 200, 100, 2, 3, 0); // T
    bvh.nodes[3] = node(-10, -10, -5, 10, 10, 2, 5, 0);                      // X
    bvh.nodes[4] = node(30, -100, -5, 200, 100, 2, 7, 0);                    // U
    bvh.nodes[5] = node(-0.5f, -0.5f, 0.9f, 0.5f, 0.5f, 1.1f, 0, 1);         // triangle 0
    bvh.nodes[6] = node(5, -0.5f, -4.6f, 6, 0.5f, -4.4f, 3, 1);              // triangle 3
    set_far_subtree(bvh, -5, 2, 4); // flat, and still far larger than X
    bvh.nodes[21] = node(-0.5f, -0.5f, 24.9f, 0.5f, 0.5f, 25.1f, 1, 1);     // triangle 1
    bvh.nodes[22] = node(0.6f, 0.6f, -0.45f, 0.9f, 0.9f, -0.35f, 2, 1);     // triangle 2
    return c;
}

aacbvh::Geometry wide_geometry(const WideCase &c) {
    aacbvh::Geometry g = make_geometry();
    g.vertices = c.vertices.data();
    g.vertex_count = c.vertices.size() / 3;
    g.primitive_count = g.vertex_count / 3;
    return g;
}

/// Whether some inner child of a wide root holds `p` in its box (the wide
/// root kept an inner node around the origin: the case has a tie there).
template <class WideNodeT, int kWidth> bool root_keeps_inner_around(const WideNodeT &root, const float p[3]) {
    for (int k = 0; k < kWidth; ++k) {
        if (root.child[k] == WideNodeT::kEmptyChild || root.count[k] != 0) continue;
        bool inside = true;
        for (int a = 0; a < 3; ++a) inside = inside && root.box[2 * a][k] <= p[a] && p[a] <= root.box[2 * a + 1][k];
        if (inside) return true;
    }
    return false;
}

void expect_tests(const char *layout, bool small_left, float z0, uint64_t tests, const aacbvh_hit &hit,
                  uint64_t want) {
    if (hit.prim_id != 0 || !(hit.t == 1.0f - z0))
        fail_msg("%s, small box on the %s, from z = %g: hit %u at %g, want 0 at %g", layout,
                 small_left ? "left" : "right", double(z0), hit.prim_id, double(hit.t), double(1.0f - z0));
    if (tests != want)
        fail_msg("%s, small box on the %s, from z = %g: %llu triangle tests, want %llu", layout,
                 small_left ? "left" : "right", double(z0), (unsigned long long)tests, (unsigned long long)want);
}

/// The same rule in every layout. The first case: from the origin (inside
/// S and X) S, left sooner, first and 1 triangle test; from z = -20 the
/// nearer X first and 2. The exit case: from the origin X, larger but left
/// sooner, first and 1 test; from z = -20 X, entered first, and 1. The
/// binary traversal, WIDE4 and WIDE8 with every kernel this CPU runs, on
/// either side.
void test_every_layout_visits_alike(void **) {
    aacbvh::Scheduler scheduler(1);
    const aacbvh::TraceKernel original = aacbvh::trace_kernel();
    const float origin[3] = {0.0f, 0.0f, 0.0f};
    int wide8_kernels = 0;
    for (int variant = 0; variant < 4; ++variant) {
        const bool small_left = (variant & 1) != 0, exit_case = variant >= 2;
        const WideCase c = exit_case ? make_exit_case(small_left) : make_wide_case(small_left);
        const aacbvh::Geometry g = wide_geometry(c);
        aacbvh::WideBvh wide4;
        wide4.build(c.bvh, scheduler);
        aacbvh::Wide8Bvh wide8;
        wide8.build(c.bvh, nullptr, scheduler);
        assert_false(wide8.has_packets());
        const bool four_keeps = root_keeps_inner_around<aacbvh::WideNode, 4>(wide4.nodes()[0], origin);
        const bool eight_keeps = root_keeps_inner_around<aacbvh::Wide8Node, 8>(wide8.nodes()[0], origin);
        assert_true(four_keeps);
        assert_true(eight_keeps);
        for (float z0 : {0.0f, -20.0f}) {
            const uint64_t want = z0 == 0.0f || exit_case ? 1 : 2;
            const aacbvh_ray ray = {{0.0f, 0.0f, z0}, 0.0f, {0.0f, 0.0f, 1.0f}, INFINITY};
            aacbvh_hit hit;
            aacbvh::TraversalCounters binary;
            aacbvh::intersect_ray(c.bvh, g, ray, hit, &binary);
            expect_tests("binary", small_left, z0, binary.primitive_tests, hit, want);
            aacbvh::TraversalCounters four;
            aacbvh::intersect_ray_wide(wide4, c.bvh, g, ray, hit, nullptr, &four);
            expect_tests("WIDE4", small_left, z0, four.primitive_tests, hit, want);
            for (aacbvh::TraceKernel k :
                 {aacbvh::TraceKernel::Scalar, aacbvh::TraceKernel::Sse2, aacbvh::TraceKernel::Avx2,
                  aacbvh::TraceKernel::Avx512}) {
                if (!aacbvh::set_trace_kernel(k)) continue;
                ++wide8_kernels;
                aacbvh::TraversalCounters eight;
                aacbvh::intersect_ray_wide8_counted(wide8, c.bvh, g, ray, hit, eight);
                char label[64];
                std::snprintf(label, sizeof label, "WIDE8 (%s kernel)", aacbvh::trace_kernel_name(k));
                expect_tests(label, small_left, z0, eight.primitive_tests, hit, want);
            }
            assert_true(aacbvh::set_trace_kernel(original));
        }
    }
    assert_true(wide8_kernels >= 8); // the plain kernel, at least, both cases, sides and origins
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tie_goes_to_the_smaller_box),
        cmocka_unit_test(test_inside_keys_order_by_exit),
        cmocka_unit_test(test_nearer_entry_first),
        cmocka_unit_test(test_every_layout_visits_alike),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
