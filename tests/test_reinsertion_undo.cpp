// Reinsertion::undo() (optimize/reinsertion.h) puts back exactly the tree a
// round started from: on trees made badly on purpose (random merges of
// random boxes, so a round makes many moves), the children of every inner
// node, the root and the boxes after round() and undo() equal those before,
// and a second round from the restored tree makes the same moves as the
// first. optimize_tree() relies on it to undo a round whose moves together
// raise the cost, instead of keeping a copy of the tree.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <cstring>
#include <random>
#include <vector>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "build/flatten.h"
#include "core/scheduler.h"
#include "optimize/reinsertion.h"

namespace {

using aacbvh::BinaryTree;
using aacbvh::Box;

/// n random small boxes in a unit cube, merged in random pairs.
BinaryTree random_tree(std::mt19937 &rng, uint32_t n) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    BinaryTree t;
    t.resize(n);
    std::vector<uint32_t> open;
    for (uint32_t i = 0; i < n; ++i) {
        const float x = u(rng), y = u(rng), z = u(rng), s = 0.01f * u(rng);
        t.boxes[i] = Box{{x, y, z}, {x + s, y + s, z + s}};
        t.prim_ids[i] = i;
        open.push_back(i);
    }
    uint32_t next = n;
    while (open.size() > 1) {
        const size_t a = rng() % open.size();
        const uint32_t l = open[a];
        open[a] = open.back();
        open.pop_back();
        const size_t b = rng() % open.size();
        const uint32_t r = open[b];
        t.set_children(next, l, r);
        t.boxes[next] = aacbvh::unite(t.boxes[l], t.boxes[r]);
        open[b] = next++;
    }
    t.root = open[0];
    return t;
}

void test_undo_restores_the_tree(void **) {
    std::mt19937 rng(5);
    for (unsigned threads : {1u, 3u})
        for (uint32_t n : {3u, 17u, 500u, 20000u}) {
            aacbvh::Scheduler scheduler(threads);
            aacbvh::BuildContext ctx(scheduler, nullptr, nullptr);
            BinaryTree t = random_tree(rng, n);
            const aacbvh::FlattenRule rule{4, 1.0, 1.0};
            aacbvh::SubtreeChoices choices;
            aacbvh::choose_subtrees(t, rule, ctx, choices);
            const std::vector<uint32_t> children(t.children.begin(), t.children.end());
            const std::vector<Box> boxes(t.boxes.begin(), t.boxes.end());
            const uint32_t root = t.root;

            aacbvh::Reinsertion reinsertion(t, choices, ctx);
            const uint64_t moves = reinsertion.round();
            if (n >= 500) assert_true(moves > 0); // the test means something only if the tree changed
            if (moves > 0)
                assert_false(std::memcmp(children.data(), t.children.data(), children.size() * sizeof(uint32_t)) == 0 &&
                             root == t.root);
            reinsertion.undo();
            assert_int_equal(t.root, root);
            assert_memory_equal(children.data(), t.children.data(), children.size() * sizeof(uint32_t));
            assert_memory_equal(boxes.data(), t.boxes.data(), boxes.size() * sizeof(Box));

            // The same moves again from the restored tree.
            const uint64_t again = reinsertion.round();
            assert_int_equal(again, moves);
            reinsertion.undo();
            assert_memory_equal(children.data(), t.children.data(), children.size() * sizeof(uint32_t));
        }
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_undo_restores_the_tree),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
