// Tests of the benchmark's ray-cost counter (ray_cost.h): counts on a hand-built
// tree where every step and test is known, the SAH formula, the tree checker,
// and agreement of the counting tracer with aacbvh_bvh_intersect on a library tree.
#include "bench_test.h"
#include "random.h"
#include "ray_cost.h"
#include "rays.h"

#include <aacbvh/aacbvh.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

using namespace bench;

namespace {

aacbvh_ray make_ray(float ox, float oy, float oz, float dx, float dy, float dz, float tmin = 0.0f,
                    float tmax = std::numeric_limits<float>::infinity()) {
    aacbvh_ray r;
    r.org[0] = ox; r.org[1] = oy; r.org[2] = oz;
    r.dir[0] = dx; r.dir[1] = dy; r.dir[2] = dz;
    r.tmin = tmin;
    r.tmax = tmax;
    return r;
}

aacbvh_node make_node(float x0, float y0, float z0, float x1, float y1, float z1, uint32_t first, uint32_t count) {
    aacbvh_node n;
    n.lower[0] = x0; n.lower[1] = y0; n.lower[2] = z0;
    n.upper[0] = x1; n.upper[1] = y1; n.upper[2] = z1;
    n.first = first;
    n.count = count;
    return n;
}

// Two triangles covering x + y <= 1 of the unit square, at z = 1 (triangle 0)
// and z = 2 (triangle 1); one leaf each under one root.
const std::vector<float> kVertices = {0, 0, 1, 1, 0, 1, 0, 1, 1, 0, 0, 2, 1, 0, 2, 0, 1, 2};
const std::vector<uint32_t> kIndices = {0, 1, 2, 3, 4, 5};

FlatTree two_leaf_tree() {
    FlatTree t;
    t.nodes = {make_node(0, 0, 1, 1, 1, 2, 1, 0),   // root: children 1 and 2
               make_node(0, 0, 1, 1, 1, 1, 0, 1),   // leaf: slot 0 = triangle 0
               make_node(0, 0, 2, 1, 1, 2, 1, 1)};  // leaf: slot 1 = triangle 1
    t.prim_indices = {0, 1};
    return t;
}

void test_hand_built_counts() {
    const FlatTree tree = two_leaf_tree();
    const CostTracer tracer(tree, kVertices.data(), kIndices.data(), 2);

    {   // Hits triangle 0 first: root (1) + both children (2) steps, 1 test; the
        // far leaf is dropped since its entry (t = 2) lies beyond the hit (t = 1).
        RayCount c;
        const CountedHit h = tracer.closest(make_ray(0.25f, 0.25f, 0, 0, 0, 1), c);
        CHECK(h.prim_id == 0);
        CHECK(std::fabs(h.t - 1.0f) < 1e-6f);
        CHECK(c.steps == 3);
        CHECK(c.tests == 1);
    }
    {   // Through both leaf boxes, missing both triangles (x + y > 1): 3 steps, 2 tests.
        RayCount c;
        const CountedHit h = tracer.closest(make_ray(0.75f, 0.75f, 0, 0, 0, 1), c);
        CHECK(h.prim_id == AACBVH_INVALID_ID);
        CHECK(c.steps == 3);
        CHECK(c.tests == 2);
    }
    {   // Misses the root's box: 1 step, no test.
        RayCount c;
        CHECK(tracer.closest(make_ray(5, 5, 0, 0, 0, 1), c).prim_id == AACBVH_INVALID_ID);
        CHECK(c.steps == 1);
        CHECK(c.tests == 0);
    }
    {   // From above: the second child is the near one; it is hit first.
        RayCount c;
        const CountedHit h = tracer.closest(make_ray(0.25f, 0.25f, 3, 0, 0, -1), c);
        CHECK(h.prim_id == 1);
        CHECK(std::fabs(h.t - 1.0f) < 1e-6f);
        CHECK(c.steps == 3);
        CHECK(c.tests == 1);
    }
    {   // tmin past the first leaf: its box is tested (and missed), the second leaf hit.
        RayCount c;
        const CountedHit h = tracer.closest(make_ray(0.25f, 0.25f, 0, 0, 0, 1, 1.5f), c);
        CHECK(h.prim_id == 1);
        CHECK(c.steps == 3);
        CHECK(c.tests == 1);
    }
    {   // Any hit stops at the first triangle.
        RayCount c;
        CHECK(tracer.any(make_ray(0.25f, 0.25f, 0, 0, 0, 1), c));
        CHECK(c.steps == 3);
        CHECK(c.tests == 1);
    }
    {   // A shadow ray ending before the root's box: 1 step, not occluded.
        RayCount c;
        CHECK(!tracer.any(make_ray(0.25f, 0.25f, 0, 0, 0, 1, 0.0f, 0.5f), c));
        CHECK(c.steps == 1);
        CHECK(c.tests == 0);
    }
    {   // Means over a ray set: (3 + 3 + 1) / 3 steps, (1 + 2 + 0) / 3 tests.
        const std::vector<aacbvh_ray> rays = {make_ray(0.25f, 0.25f, 0, 0, 0, 1), make_ray(0.75f, 0.75f, 0, 0, 0, 1),
                                              make_ray(5, 5, 0, 0, 0, 1)};
        const CostSummary s = measure_closest(tracer, rays);
        CHECK(s.rays == 3);
        CHECK(s.hits == 1);
        CHECK(std::fabs(s.steps - 7.0 / 3.0) < 1e-12);
        CHECK(std::fabs(s.tests - 1.0) < 1e-12);
        CHECK(std::fabs(s.total() - 10.0 / 3.0) < 1e-12);
    }
}

void test_sah_and_checker() {
    FlatTree tree = two_leaf_tree();
    // Root area 6 (unit cube), each leaf area 2 with one primitive: (1.2 * 6 + 2 + 2) / 6.
    CHECK(std::fabs(sah_cost(tree) - (1.2 * 6 + 4) / 6) < 1e-12);
    CHECK(flat_tree_bytes(tree) == 3 * 32 + 2 * 4);
    std::string err;
    CHECK(check_tree(tree, 2, err));
    tree.nodes[2].first = 0;  // slot 0 in two leaves, slot 1 in none
    CHECK(!check_tree(tree, 2, err));
    tree = two_leaf_tree();
    tree.nodes[1].upper[2] = 3;  // a child sticking out of the root
    CHECK(!check_tree(tree, 2, err));
}

// The counting tracer against the library's own traversal, on a library tree.
void test_against_library() {
    // A 16 x 16 grid of quads, gently waved, two triangles each.
    const int n = 16;
    std::vector<float> v;
    std::vector<uint32_t> idx;
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) {
            v.push_back(float(x));
            v.push_back(float(y));
            v.push_back(0.3f * std::sin(0.7f * x) * std::cos(0.5f * y));
        }
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const uint32_t a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
            idx.insert(idx.end(), {a, b, d, a, d, c});
        }
    const size_t tris = idx.size() / 3;
    aacbvh_context *ctx = nullptr;
    aacbvh_bvh *bvh = nullptr;
    CHECK(aacbvh_context_create(1, &ctx) == AACBVH_OK);
    CHECK(aacbvh_bvh_create(ctx, &bvh) == AACBVH_OK);
    CHECK(aacbvh_bvh_set_triangles(bvh, v.data(), v.size() / 3, 12, idx.data(), tris) == AACBVH_OK);
    CHECK(aacbvh_bvh_build(bvh) == AACBVH_OK);
    FlatTree tree;
    std::string err;
    CHECK(fetch_tree(bvh, tree, err));
    CHECK(check_tree(tree, tris, err));
    aacbvh_stats stats{};
    stats.struct_size = sizeof(stats);
    CHECK(aacbvh_bvh_get_stats(bvh, &stats) == AACBVH_OK);
    CHECK(std::fabs(sah_cost(tree) - stats.sah_cost) < 1e-4 * stats.sah_cost);

    std::vector<aacbvh_ray> rays;
    SplitMix64 random(12345);
    auto uniform = [&] { return random.uniform_float(); };
    for (int i = 0; i < 2000; ++i)
        rays.push_back(make_ray(uniform() * n, uniform() * n, 2.0f, uniform() - 0.5f, uniform() - 0.5f, -1.0f));
    std::vector<aacbvh_hit> hits(rays.size());
    CHECK(aacbvh_bvh_intersect(bvh, rays.data(), hits.data(), rays.size()) == AACBVH_OK);
    const CostTracer tracer(tree, v.data(), idx.data(), tris);
    std::vector<CountedHit> counted;
    const CostSummary s = measure_closest(tracer, rays, &counted);
    size_t disagree = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        if ((counted[i].prim_id == AACBVH_INVALID_ID) != (hits[i].prim_id == AACBVH_INVALID_ID)) ++disagree;
        else if (hits[i].prim_id != AACBVH_INVALID_ID && std::fabs(counted[i].t - hits[i].t) > 1e-4f) ++disagree;
    }
    CHECK(disagree <= 2);  // edge hits may differ between the two triangle tests
    CHECK(s.steps >= 1.0);
    CHECK(s.tests >= 1.0);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
}

}  // namespace

// Overlap on hand-made trees: children [0, 1.5] and [0.5, 2] along x of a
// 2 x 1 x 1 root share [0.5, 1.5] x [0, 1] x [0, 1], area 6 of the root's 10
// and volume 1 of its 2; touching children share a face (area 2, no volume);
// disjoint ones nothing; a second level adds its own share.
void test_overlap() {
    auto two_children = [](float l1, float r0) {
        FlatTree t;
        t.nodes = {make_node(0, 0, 0, 2, 1, 1, 1, 0), make_node(0, 0, 0, l1, 1, 1, 0, 1),
                   make_node(r0, 0, 0, 2, 1, 1, 1, 1)};
        t.prim_indices = {0, 1};
        return t;
    };
    Overlap o = overlap_of(two_children(1.5f, 0.5f));
    CHECK(std::fabs(o.area - 0.6) < 1e-12);
    CHECK(std::fabs(o.volume - 0.5) < 1e-12);
    o = overlap_of(two_children(1.0f, 1.0f));
    CHECK(std::fabs(o.area - 0.2) < 1e-12);
    CHECK(o.volume == 0.0);
    o = overlap_of(two_children(0.75f, 1.25f));
    CHECK(o.area == 0.0 && o.volume == 0.0);

    // The left child splits again into [0, 1] and [0.5, 1.5] (share 0.5 x 1 x 1:
    // area 2 * (0.5 + 1 + 0.5) = 4, volume 0.5): totals (6 + 4) / 10 and 1.5 / 2.
    FlatTree t;
    t.nodes = {make_node(0, 0, 0, 2, 1, 1, 1, 0),     make_node(0, 0, 0, 1.5f, 1, 1, 3, 0),
               make_node(0.5f, 0, 0, 2, 1, 1, 2, 1),  make_node(0, 0, 0, 1, 1, 1, 0, 1),
               make_node(0.5f, 0, 0, 1.5f, 1, 1, 1, 1)};
    t.prim_indices = {0, 1, 2};
    o = overlap_of(t);
    CHECK(std::fabs(o.area - 1.0) < 1e-12);
    CHECK(std::fabs(o.volume - 0.75) < 1e-12);

    // A flat root has no volume to compare with.
    FlatTree flat;
    flat.nodes = {make_node(0, 0, 0, 2, 1, 0, 1, 0), make_node(0, 0, 0, 1.5f, 1, 0, 0, 1),
                  make_node(0.5f, 0, 0, 2, 1, 0, 1, 1)};
    flat.prim_indices = {0, 1};
    o = overlap_of(flat);
    CHECK(std::fabs(o.area - 0.5) < 1e-12);  // (2 * 1 * 1) / (2 * 2 * 1)
    CHECK(std::isnan(o.volume));
}

// The in-scene views: as many as asked, the same for the same seed, each eye
// just off one of the two triangles on the side its normal (+z) faces, looking
// into that hemisphere.
void test_views() {
    const float light[3] = {0.5f, 0.5f, 10.0f};
    const std::vector<Camera> a = make_views(kVertices, kIndices, 16, light, 2.0f, 7);
    const std::vector<Camera> b = make_views(kVertices, kIndices, 16, light, 2.0f, 7);
    const std::vector<Camera> c = make_views(kVertices, kIndices, 16, light, 2.0f, 8);
    CHECK(a.size() == 16 && b.size() == 16 && c.size() == 16);
    bool same = true, differs = false, below = false, above = false;
    for (size_t i = 0; i < a.size() && i < b.size() && i < c.size(); ++i) {
        for (int k = 0; k < 3; ++k) {
            same = same && a[i].eye[k] == b[i].eye[k] && a[i].target[k] == b[i].target[k];
            differs = differs || a[i].eye[k] != c[i].eye[k];
        }
        const float *e = a[i].eye;
        CHECK(e[0] >= 0.0f && e[1] >= 0.0f && e[0] + e[1] <= 1.0001f);
        const bool on0 = std::fabs(e[2] - 1.002f) < 1e-5f, on1 = std::fabs(e[2] - 2.002f) < 1e-5f;
        CHECK(on0 || on1);
        below = below || on0;
        above = above || on1;
        CHECK(a[i].target[2] - e[2] >= 0.0f);
        CHECK(a[i].light[2] == 10.0f);
    }
    CHECK(same);
    CHECK(differs);
    CHECK(below && above);  // equal areas: 16 picks land on both
    // No triangle of non-zero area: no view, and no endless search.
    const std::vector<float> line = {0, 0, 0, 1, 0, 0, 2, 0, 0};
    CHECK(make_views(line, {0, 1, 2}, 4, light, 2.0f, 7).empty());
}

int main() {
    test_overlap();
    test_views();
    test_hand_built_counts();
    test_sah_and_checker();
    test_against_library();
    return bench_test::finish("test_ray_cost");
}
