// open_largest_children (lib/bvh/wide_collapse.h), the collapse shared by the
// 4-wide and 8-wide layouts: for every inner node of trees from several
// builders, the children it gives are exactly those of an independent
// opening (the child of largest area, first of equals, opened until the
// width is reached or only leaves remain), and they come in order of surface
// area, largest first, equals in the order they were opened. The wide
// traversals read that order (any-hit queries visit the largest box first;
// closest-hit queries send equal entry distances to the smaller box), so the
// finished 8-wide nodes must show it too, lane by lane.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <algorithm>
#include <cstdio>
#include <vector>

#include "bvh/wide8_bvh.h"
#include "bvh/wide_collapse.h"
#include "bvh_object.h"
#include "core/scheduler.h"
#include "random_soup.h"

namespace {

using aacbvh_test::random_soup;

/// The reference opening, without any ordering: a list in opening order.
std::vector<uint32_t> open_reference(const aacbvh::Bvh &bvh, uint32_t root, size_t width) {
    const auto &n = bvh.nodes;
    if (n[root].is_leaf()) return {root};
    std::vector<uint32_t> kids{n[root].first, n[root].first + 1};
    while (kids.size() < width) {
        size_t best = kids.size();
        for (size_t k = 0; k < kids.size(); ++k)
            if (!n[kids[k]].is_leaf() &&
                (best == kids.size() || n[kids[k]].box.half_area() > n[kids[best]].box.half_area()))
                best = k;
        if (best == kids.size()) break;
        const uint32_t first = n[kids[best]].first;
        kids[best] = first;
        kids.push_back(first + 1);
    }
    return kids;
}

template <int Width>
void check_node(const aacbvh::Bvh &bvh, uint32_t i, const char *what) {
    uint32_t kids[Width];
    const float scale = aacbvh::extent_scale_of(bvh.nodes[0].box);
    const int m = aacbvh::open_largest_children(bvh.nodes.data(), scale, i,
                                                [&](uint32_t j) { return bvh.nodes[j].is_leaf(); }, kids);
    const std::vector<uint32_t> want = open_reference(bvh, i, Width);
    if (size_t(m) != want.size()) fail_msg("%s, width %d, node %u: %d children, want %zu", what, Width, i, m, want.size());
    // Largest first; equal areas in opening order.
    for (int k = 1; k < m; ++k) {
        const float a = bvh.nodes[kids[k - 1]].box.half_area(), b = bvh.nodes[kids[k]].box.half_area();
        if (a < b) fail_msg("%s, width %d, node %u: lane %d has area %g after %g", what, Width, i, k, double(b), double(a));
        if (a == b) {
            const auto pa = std::find(want.begin(), want.end(), kids[k - 1]) - want.begin();
            const auto pb = std::find(want.begin(), want.end(), kids[k]) - want.begin();
            if (pa > pb) fail_msg("%s, width %d, node %u: equal areas out of opening order", what, Width, i);
        }
    }
    std::vector<uint32_t> got(kids, kids + m), sorted_want = want;
    std::sort(got.begin(), got.end());
    std::sort(sorted_want.begin(), sorted_want.end());
    if (got != sorted_want) fail_msg("%s, width %d, node %u: other children than the reference opening's", what, Width, i);
}

void check_tree(const aacbvh::Bvh &bvh, aacbvh::Scheduler &scheduler, const char *what) {
    for (uint32_t i = 0; i < bvh.nodes.size(); ++i) {
        check_node<4>(bvh, i, what);
        check_node<8>(bvh, i, what);
    }
    // The 8-wide tree over the binary leaves: each node's lanes by area.
    aacbvh::Wide8Bvh wide;
    wide.build(bvh, nullptr, scheduler);
    size_t ordered_pairs = 0;
    for (size_t w = 0; w < wide.node_count(); ++w) {
        const aacbvh::Wide8Node &node = wide.nodes()[w];
        float previous = 0.0f;
        for (int k = 0; k < 8 && node.child[k] != aacbvh::Wide8Node::kEmptyChild; ++k) {
            const float area = node.slot_box(k).half_area();
            if (k > 0 && area > previous)
                fail_msg("%s: wide node %zu, lane %d has area %g after %g", what, w, k, double(area), double(previous));
            ordered_pairs += k > 0;
            previous = area;
        }
    }
    assert_true(ordered_pairs > 0);
}

void test_children_by_area(void **) {
    aacbvh::Scheduler scheduler(2);
    const std::vector<float> soup = random_soup(5000, 17);
    const aacbvh_builder builders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_BINNED_SAH,
                                       AACBVH_BUILDER_SWEEP_SAH};
    for (aacbvh_builder builder : builders)
        for (int leaf : {1, 4}) {
            aacbvh::BvhObject object(scheduler);
            aacbvh_test::build_soup(object, soup, builder, leaf);
            char what[64];
            snprintf(what, sizeof what, "builder %d, leaf %d", int(builder), leaf);
            check_tree(object.binary_tree(), scheduler, what);
        }
}

/// Equal areas everywhere (identical triangles): the order is the opening's.
void test_equal_areas(void **) {
    aacbvh::Scheduler scheduler(1);
    std::vector<float> soup = random_soup(1, 5);
    soup.resize(9 * 300);
    for (size_t i = 9; i < soup.size(); ++i) soup[i] = soup[i % 9];
    aacbvh::BvhObject object(scheduler);
    aacbvh_test::build_soup(object, soup, AACBVH_BUILDER_AAC_HQ, 1);
    check_tree(object.binary_tree(), scheduler, "identical triangles");
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_children_by_area),
        cmocka_unit_test(test_equal_areas),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
