// CompactTopology (lib/bvh/compact_topology.h), the binary tree's shape in
// one byte per node: for every builder and leaf size it must give back each
// node's first and count, and its walk the figures that measure_tree()
// gives, the same bits at any thread count. The 8-wide tree refitted from
// its packets must box every child slot as the refitted binary node behind
// it. And the default handle keeps the shape only, answering get_nodes,
// stats and rays as a handle that keeps the nodes does.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <cmath>
#include <cstring>
#include <vector>

#include "bvh/bvh_refit.h"
#include "bvh/bvh_stats.h"
#include "bvh/compact_topology.h"
#include "bvh/wide8_bvh.h"
#include "bvh_object.h"
#include "core/scheduler.h"
#include "random_soup.h"

namespace {

using aacbvh_test::random_soup;

/// Triangles along a line, each a little bigger than the last: a deep tree.
std::vector<float> chain(size_t triangles) {
    std::vector<float> v(9 * triangles);
    for (size_t t = 0; t < triangles; ++t) {
        const float x = float(t) * float(t) * 1e-3f, s = 1.0f + float(t);
        const float tri[9] = {x, 0, 0, x + s, 0, 0, x, s, 0};
        std::memcpy(&v[9 * t], tri, sizeof tri);
    }
    return v;
}

bool same_box(const aacbvh::Box &a, const aacbvh::Box &b) {
    for (int k = 0; k < 3; ++k)
        if (a.lo[k] != b.lo[k] || a.hi[k] != b.hi[k]) return false;
    return true;
}

bool near(double a, double b) { return std::fabs(a - b) <= 1e-12 * std::fabs(a); }

void check_tree(const aacbvh::Bvh &tree, const aacbvh::Geometry &geometry, const char *what) {
    aacbvh::Scheduler one(1), three(3);
    aacbvh::CompactTopology topology;
    if (!topology.encode(tree, one)) fail_msg("%s: not encoded", what);
    assert_int_equal(topology.node_count(), tree.nodes.size());
    if (tree.nodes.size() >= 4 * size_t(aacbvh::CompactTopology::kTaskNodes)) assert_true(topology.task_depth() > 0);

    aacbvh::Array<aacbvh::Node> nodes;
    topology.decode(nodes);
    for (size_t i = 0; i < tree.nodes.size(); ++i)
        if (nodes[i].first != tree.nodes[i].first || nodes[i].count != tree.nodes[i].count)
            fail_msg("%s: node %zu decodes as %u+%u, was %u+%u", what, i, nodes[i].first, nodes[i].count,
                     tree.nodes[i].first, tree.nodes[i].count);

    const aacbvh::TreeFigures want = aacbvh::measure_tree(tree, one);
    aacbvh::TreeFigures first_figures;
    for (aacbvh::Scheduler *s : {&one, &three}) {
        const aacbvh::TreeFigures f = topology.walk(
            [&](uint32_t first, uint32_t count) {
                aacbvh::Box b = aacbvh::Box::empty();
                for (uint32_t k = 0; k < count; ++k) b.extend(geometry.primitive_box(tree.prim_ids[first + k]));
                return b;
            },
            *s);
        if (f.leaf_count != want.leaf_count || f.max_depth != want.max_depth)
            fail_msg("%s: walk gives %llu leaves, depth %u; measure_tree %llu, %u", what,
                     (unsigned long long)f.leaf_count, f.max_depth, (unsigned long long)want.leaf_count, want.max_depth);
        if (!near(want.areas.inner_area, f.areas.inner_area) ||
            !near(want.areas.leaf_area_prims, f.areas.leaf_area_prims) || want.areas.root_area != f.areas.root_area)
            fail_msg("%s: walk's areas %.17g %.17g %.17g, measure_tree's %.17g %.17g %.17g", what, f.areas.inner_area,
                     f.areas.leaf_area_prims, f.areas.root_area, want.areas.inner_area, want.areas.leaf_area_prims,
                     want.areas.root_area);
        if (s == &one)
            first_figures = f;
        else if (std::memcmp(&first_figures.areas, &f.areas, sizeof f.areas) != 0)
            fail_msg("%s: the walk's areas differ between 1 and 3 threads", what);
    }
}

/// The 8-wide tree refitted from its packets has, in every child slot, the
/// box of the binary node behind it as refit_tree() makes it.
void check_packet_refit(const aacbvh::Bvh &tree, const aacbvh::Geometry &geometry, const std::vector<float> &mesh,
                        const char *what) {
    aacbvh::Scheduler scheduler(3);
    aacbvh::Wide8Bvh wide;
    wide.build(tree, &geometry, scheduler);
    std::vector<float> moved(mesh);
    for (size_t i = 0; i < moved.size(); ++i) moved[i] += 0.03f * std::sin(float(i) * 0.7f);
    aacbvh::Geometry g = geometry;
    g.vertices = moved.data();
    aacbvh::Bvh refitted{aacbvh::Array<aacbvh::Node>(tree.nodes), aacbvh::Array<uint32_t>(tree.prim_ids)};
    aacbvh::refit_tree(refitted, g, scheduler);
    wide.refit_from_packets(g, scheduler);
    const aacbvh::Array<uint32_t> &sources = wide.sources();
    for (size_t w = 0; w < wide.node_count(); ++w)
        for (int k = 0; k < 8; ++k) {
            const uint32_t s = sources[8 * w + k];
            const aacbvh::Wide8Node &node = wide.nodes()[w];
            if (s == aacbvh::Wide8Node::kEmptyChild) {
                if (!(node.box[0][k] > node.box[1][k])) fail_msg("%s: unused slot %zu.%d not empty", what, w, k);
                continue;
            }
            const aacbvh::Box &b = refitted.nodes[s].box;
            for (int a = 0; a < 3; ++a)
                if (node.box[2 * a][k] != b.lo[a] || node.box[2 * a + 1][k] != b.hi[a])
                    fail_msg("%s: slot %zu.%d is not binary node %u's box after the refit", what, w, k, s);
        }
}

void check_build(const std::vector<float> &mesh, aacbvh_builder builder, int leaf, const char *name,
                 aacbvh::Scheduler &scheduler) {
    aacbvh::BvhObject object(scheduler);
    object.set_triangles(mesh.data(), mesh.size() / 3, 3 * sizeof(float), nullptr, mesh.size() / 9);
    object.set_param_int(AACBVH_PARAM_BUILDER, builder);
    object.set_param_int(AACBVH_PARAM_MAX_LEAF_SIZE, leaf);
    object.set_param_int(AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_BINARY);
    object.build();
    char what[64];
    snprintf(what, sizeof what, "%s, builder %d, leaf %d", name, int(builder), leaf);
    const aacbvh::Bvh tree = object.binary_tree();
    check_tree(tree, object.geometry(), what);
    check_packet_refit(tree, object.geometry(), mesh, what);
}

void test_every_builder_round_trips(void **) {
    aacbvh::Scheduler scheduler(2);
    const std::vector<float> soup = random_soup(6000, 5), line = chain(3000);
    const aacbvh_builder builders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_BINNED_SAH,
                                       AACBVH_BUILDER_SWEEP_SAH};
    for (aacbvh_builder builder : builders)
        for (int leaf : {1, 4, 8}) {
            check_build(soup, builder, leaf, "soup", scheduler);
            check_build(line, builder, leaf, "chain", scheduler);
        }
}

/// Trees big enough to be walked by tasks (CompactTopology::task_depth()
/// above 0), balanced and deep.
void test_walks_split_into_tasks(void **) {
    aacbvh::Scheduler scheduler(2);
    const std::vector<float> soup = random_soup(60000, 6), line = chain(20000);
    check_build(soup, AACBVH_BUILDER_AAC_HQ, 1, "big soup", scheduler);
    check_build(soup, AACBVH_BUILDER_BINNED_SAH, 4, "big soup", scheduler);
    check_build(line, AACBVH_BUILDER_AAC_FAST, 1, "long chain", scheduler);
}

/// The default handle keeps the shape only: its nodes come back the same as
/// a handle that keeps them, after a build, a refit and an optimisation,
/// and a change of layout at refit goes back to keeping them.
void test_default_handle_keeps_the_shape(void **) {
    aacbvh::Scheduler scheduler(2);
    std::vector<float> soup = random_soup(20000, 9);
    aacbvh::BvhObject compact(scheduler), kept(scheduler);
    for (aacbvh::BvhObject *o : {&compact, &kept}) aacbvh_test::set_soup(*o, soup);
    kept.set_param_int(AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_BINARY);
    compact.build();
    kept.build();
    assert_true(compact.compact());
    assert_false(kept.compact());
    auto check = [&](const char *what) {
        const aacbvh::Bvh a = compact.binary_tree(), b = kept.binary_tree();
        assert_int_equal(a.nodes.size(), b.nodes.size());
        for (size_t i = 0; i < a.nodes.size(); ++i)
            if (a.nodes[i].first != b.nodes[i].first || a.nodes[i].count != b.nodes[i].count ||
                !same_box(a.nodes[i].box, b.nodes[i].box))
                fail_msg("%s: node %zu differs", what, i);
        aacbvh_stats sa{}, sb{};
        compact.stats(sa);
        kept.stats(sb);
        assert_int_equal(sa.node_count, sb.node_count);
        if (!near(sb.sah_cost, sa.sah_cost)) fail_msg("%s: SAH %.17g against %.17g", what, sa.sah_cost, sb.sah_cost);
        // Without the binary nodes, the handle holds less than a node per node.
        // Without the binary nodes the handle holds less than their 32 bytes
        // each plus 45 bytes a triangle (kept, they alone would exceed it).
        if (compact.compact()) assert_true(sa.memory_bytes < 32 * sa.node_count + 45 * soup.size() / 9);
    };
    check("built");
    aacbvh_stats before{};
    compact.stats(before);
    compact.refit(); // nothing moved: the same tree, the drift exactly 1
    aacbvh_stats after{};
    compact.stats(after);
    assert_true(after.sah_cost == before.sah_cost && after.built_sah_cost == after.sah_cost);
    for (size_t i = 0; i < soup.size(); ++i) soup[i] += 0.05f * std::sin(float(i));
    compact.refit();
    kept.refit();
    check("refitted");
    compact.optimize(2);
    kept.optimize(2);
    assert_true(compact.compact());
    check("optimised");
    // Node by node: the first partial copy makes the nodes and keeps them
    // (counted in memory_bytes) until the tree changes.
    {
        const aacbvh::Bvh whole = compact.binary_tree();
        aacbvh_stats lean{}, kept_nodes{}, refitted{};
        compact.stats(lean);
        for (size_t i = 0; i < whole.nodes.size(); i += 97) {
            aacbvh::Node node;
            compact.copy_nodes(i, 1, &node);
            if (std::memcmp(&node, &whole.nodes[i], sizeof node) != 0) fail_msg("node %zu copied alone differs", i);
        }
        compact.stats(kept_nodes);
        assert_true(kept_nodes.memory_bytes >= lean.memory_bytes + 32 * lean.node_count);
        std::vector<aacbvh::Node> all(whole.nodes.size());
        compact.copy_nodes(0, all.size(), all.data());
        assert_memory_equal(all.data(), whole.nodes.data(), all.size() * sizeof(aacbvh::Node));
        compact.refit();
        compact.stats(refitted);
        assert_int_equal(refitted.memory_bytes, lean.memory_bytes);
    }
    compact.set_param_int(AACBVH_PARAM_TRAVERSAL_LAYOUT, AACBVH_LAYOUT_WIDE4);
    compact.refit();
    assert_false(compact.compact());
    check("4-wide after refit");
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_builder_round_trips),
        cmocka_unit_test(test_walks_split_into_tasks),
        cmocka_unit_test(test_default_handle_keeps_the_shape),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
