// Tests of the benchmark's ray-cost counter (ray_cost.h): counts on a hand-built
// tree where every step and test is known, the SAH formula, the tree checker,
// and agreement of the counting tracer with aacbvh_bvh_intersect on a library tree.
#include "bench_test.h"
#include "random.h"
#include "ray_cost.h"

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

int main() {
    test_hand_built_counts();
    test_sah_and_checker();
    test_against_library();
    return bench_test::finish("test_ray_cost");
}
