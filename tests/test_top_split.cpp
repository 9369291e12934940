// The SAH partition of AAC's root clusters (build/aac/top_split.h) on
// hand-made clusters whose best partition is known.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <algorithm>
#include <vector>

#include "build/aac/top_split.h"

namespace {

using aacbvh::BinaryTree;
using aacbvh::Box;
using aacbvh::SubtreeChoices;

/// Leaves 0..3 (unused here) and inner nodes 4..7 standing for clusters:
/// node 4 + i has box boxes[i] and holds prims[i] primitives.
BinaryTree clusters(const std::vector<Box> &boxes, const std::vector<uint32_t> &prims,
                    SubtreeChoices &choices) {
    BinaryTree t;
    t.resize(4);
    choices.resize(4);
    for (uint32_t i = 0; i < 4; ++i) {
        t.boxes[i] = Box{{0, 0, 0}, {0, 0, 0}};
        t.prim_ids[i] = i;
        t.boxes[4 + i] = boxes[i];
        choices.set(i, {0.0, prims[i], 1});
    }
    return t;
}

Box cube_at(float x, float y) { return Box{{x, y, 0}, {x + 1, y + 1, 1}}; }

// Two pairs far apart along x, listed interleaved: the split separates them by
// x, whatever the input order, and sorts them along x.
void test_separates_far_groups(void **) {
    SubtreeChoices choices;
    const BinaryTree t = clusters({cube_at(10, 0), cube_at(0, 0), cube_at(11, 0), cube_at(1, 0)}, {1, 1, 1, 1},
                                  choices);
    uint32_t ids[] = {4, 5, 6, 7};
    assert_int_equal(aacbvh::sah_partition(t, choices.table(), ids, 4), 2);
    assert_int_equal(ids[0], 5);  // x = 0
    assert_int_equal(ids[1], 7);  // x = 1
    assert_int_equal(ids[2], 4);  // x = 10
    assert_int_equal(ids[3], 6);  // x = 11
}

// Primitive counts weigh the sides: along y, a heavy cluster at y = 0 and three
// light ones at y = 2, 4, 6, all of one x. Areas (half): a cube 3; the light
// three together 1 x 5 x 1: 11. Splitting the heavy one off costs 3 * 100 +
// 11 * 3 = 333; any other cut puts it with a light one (7 * 101 at least).
void test_counts_weigh(void **) {
    SubtreeChoices choices;
    const BinaryTree t = clusters({cube_at(0, 4), cube_at(0, 0), cube_at(0, 6), cube_at(0, 2)}, {1, 100, 1, 1},
                                  choices);
    uint32_t ids[] = {4, 5, 6, 7};
    assert_int_equal(aacbvh::sah_partition(t, choices.table(), ids, 4), 1);
    assert_int_equal(ids[0], 5);
    std::sort(ids + 1, ids + 4);
    assert_int_equal(ids[1], 4);
    assert_int_equal(ids[2], 6);
    assert_int_equal(ids[3], 7);
}

// Fewer than two clusters: nothing to split.
void test_too_few(void **) {
    SubtreeChoices choices;
    const BinaryTree t = clusters({cube_at(0, 0), cube_at(1, 0), cube_at(2, 0), cube_at(3, 0)}, {1, 1, 1, 1}, choices);
    uint32_t ids[] = {4};
    assert_int_equal(aacbvh::sah_partition(t, choices.table(), ids, 1), 1);
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_separates_far_groups),
        cmocka_unit_test(test_counts_weigh),
        cmocka_unit_test(test_too_few),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
