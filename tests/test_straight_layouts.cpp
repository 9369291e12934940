// The default layout made straight from the builder's tree
// (BvhObject::straight_to_compact(), bvh/chosen_tree.h) against the same
// layout made from the emitted binary nodes (testing::straight_layouts off):
// the 8-wide nodes, the packets and their owners, the kept shape and its
// task parts, the primitive order and the statistics must be the same bytes,
// for every builder, leaf size and thread count, on random and degenerate
// inputs, and after the build's own optimisation passes.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <cstring>
#include <vector>

#include "bvh_object.h"
#include "core/scheduler.h"
#include "random_soup.h"

namespace {

using aacbvh::BvhObject;
using aacbvh::Scheduler;

template <class T> bool same_bytes(const T *a, const T *b, size_t count) {
    return count == 0 || std::memcmp(a, b, count * sizeof(T)) == 0;
}

void build(BvhObject &object, const std::vector<float> &soup, aacbvh_builder builder, int max_leaf, int passes,
           bool straight) {
    aacbvh::testing::straight_layouts.store(straight);
    aacbvh_test::set_soup(object, soup);
    object.set_param_int(AACBVH_PARAM_BUILDER, builder);
    object.set_param_int(AACBVH_PARAM_MAX_LEAF_SIZE, max_leaf);
    object.set_param_int(AACBVH_PARAM_OPTIMIZE_PASSES, passes);
    object.build();
    aacbvh::testing::straight_layouts.store(true);
}

void compare(const std::vector<float> &soup, aacbvh_builder builder, int max_leaf, int passes, unsigned threads,
             const char *what) {
    Scheduler scheduler(threads);
    BvhObject straight(scheduler), emitted(scheduler);
    aacbvh::testing::largest_plan_bytes.store(0);
    build(straight, soup, builder, max_leaf, passes, true);
    const uint64_t plan = aacbvh::testing::largest_plan_bytes.load();
    build(emitted, soup, builder, max_leaf, passes, false);
    char label[160];
    snprintf(label, sizeof label, "%s, builder %d, leaves of %d, %d passes, %u threads", what, int(builder), max_leaf,
             passes, threads);

    assert_true(straight.compact());
    assert_true(emitted.compact());
    const aacbvh::Wide8Bvh &a = straight.wide8(), &b = emitted.wide8();
    if (a.node_count() != b.node_count()) fail_msg("%s: %zu wide nodes, %zu", label, a.node_count(), b.node_count());
    if (!same_bytes(a.nodes(), b.nodes(), a.node_count())) fail_msg("%s: the wide nodes differ", label);
    const size_t packets = a.packet_owners().size();
    if (packets != b.packet_owners().size()) fail_msg("%s: %zu packets, %zu", label, packets, b.packet_owners().size());
    if (!same_bytes(a.packets(), b.packets(), packets)) fail_msg("%s: the packets differ", label);
    if (a.packet_owners() != b.packet_owners()) fail_msg("%s: the packets' owners differ", label);
    if (!a.sources().empty() || !b.sources().empty()) fail_msg("%s: a compact handle kept its sources", label);

    const aacbvh::CompactTopology &ta = straight.topology(), &tb = emitted.topology();
    if (ta.shape() != tb.shape()) fail_msg("%s: the shapes differ (%zu, %zu nodes)", label, ta.shape().size(), tb.shape().size());
    if (ta.task_depth() != tb.task_depth() || ta.part_fields() != tb.part_fields())
        fail_msg("%s: the walk's parts differ", label);
    if (straight.primitive_indices() != emitted.primitive_indices()) fail_msg("%s: the primitive orders differ", label);

    aacbvh_stats sa, sb;
    straight.stats(sa);
    emitted.stats(sb);
    if (sa.sah_cost != sb.sah_cost || sa.built_sah_cost != sb.built_sah_cost || sa.node_count != sb.node_count ||
        sa.leaf_count != sb.leaf_count || sa.max_depth != sb.max_depth)
        fail_msg("%s: the statistics differ (SAH %.9g / %.9g)", label, sa.sah_cost, sb.sah_cost);
    // No binary nodes: at most the packet choices' 5 bytes a primitive
    // (twice with the optimiser's saved copy) above the emitted way's peak,
    // and the collapse plan's scratch (bvh/collapse_plan.h), which the
    // straight way holds beside the builder's tree and the emitted way after
    // it. On one thread only: with more, the builders' scratch at the peak
    // depends on which tasks overlap.
    const uint64_t choices = uint64_t(passes > 0 ? 10 : 5) * (soup.size() / 9);
    if (threads == 1 && sa.build_peak_bytes > sb.build_peak_bytes + choices + plan)
        fail_msg("%s: peak %llu bytes, emitted way %llu", label, (unsigned long long)sa.build_peak_bytes,
                 (unsigned long long)sb.build_peak_bytes);
}

const aacbvh_builder kBuilders[] = {AACBVH_BUILDER_AAC_HQ,  AACBVH_BUILDER_AAC_FAST,   AACBVH_BUILDER_AAC,
                                    AACBVH_BUILDER_SWEEP_SAH, AACBVH_BUILDER_BINNED_SAH, AACBVH_BUILDER_PLOC};

void test_random_soups(void **) {
    for (size_t count : {size_t(1), size_t(2), size_t(3), size_t(17), size_t(300), size_t(5000)})
        for (aacbvh_builder builder : kBuilders)
            for (int max_leaf : {1, 4, 8, 17})
                compare(aacbvh_test::random_soup(count, unsigned(count) + 11u), builder, max_leaf, 0, 1, "soup");
}

/// Big enough for tasks everywhere: the emit's (16 K primitives), the
/// collapse's (subtrees under 4 K), the sweep's and the shape's parts.
void test_big_soup_threads(void **) {
    const std::vector<float> soup = aacbvh_test::random_soup(70000, 5);
    for (aacbvh_builder builder : {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_BINNED_SAH})
        for (unsigned threads : {1u, 3u}) compare(soup, builder, 8, 0, threads, "70 K soup");
    compare(soup, AACBVH_BUILDER_AAC_FAST, 32, 0, 2, "70 K soup");
}

/// Leaves of 255 primitives and the largest sizes the shape holds.
void test_large_leaves(void **) {
    const std::vector<float> soup = aacbvh_test::random_soup(3000, 9);
    for (int max_leaf : {32, 64, 255}) compare(soup, AACBVH_BUILDER_AAC_HQ, max_leaf, 0, 1, "large leaves");
}

/// All triangles the same, and all on one line: ties everywhere.
void test_degenerate(void **) {
    std::vector<float> same(9 * 4000), line(9 * 4000);
    for (size_t t = 0; t < 4000; ++t)
        for (int i = 0; i < 3; ++i) {
            const float x = float(t) * 1e-3f;
            const float s[3] = {float(i == 1), float(i == 2), 0.0f};
            const float l[3] = {x + float(i) * 1e-4f, 0.0f, 0.0f};
            for (int a = 0; a < 3; ++a) {
                same[9 * t + 3 * i + a] = s[a];
                line[9 * t + 3 * i + a] = l[a];
            }
        }
    for (aacbvh_builder builder : kBuilders) {
        compare(same, builder, 4, 0, 2, "identical triangles");
        compare(line, builder, 4, 0, 2, "triangles on a line");
        // Leaves of more primitives than a packet leaf's choice covers
        // (SubtreeCounts::kSmall): one leaf each, and a packet leaf each.
        compare(same, builder, 64, 0, 1, "identical triangles, leaves of 64");
    }
}

/// The build's optimisation passes change the tree before the layout.
void test_after_optimize_passes(void **) {
    const std::vector<float> soup = aacbvh_test::random_soup(6000, 21);
    compare(soup, AACBVH_BUILDER_AAC_FAST, 8, 2, 1, "optimised");
    compare(soup, AACBVH_BUILDER_AAC_HQ, 4, 1, 3, "optimised");
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_soups),
        cmocka_unit_test(test_big_soup_threads),
        cmocka_unit_test(test_large_leaves),
        cmocka_unit_test(test_degenerate),
        cmocka_unit_test(test_after_optimize_passes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
