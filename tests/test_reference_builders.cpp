// Unit tests of the reference builders (lib/build/reference/: sweep and binned
// SAH, locally-ordered, PLOC): every builder gives a
// valid full binary tree on random, clustered and degenerate inputs; the
// locally-ordered builder matches naive greedy clustering; the sweep SAH's top
// split is the best axis-aligned split found by brute force; results do not
// depend on the thread count; cancellation stops every builder.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// cmocka.h declares its functions extern "C" only on Windows.
extern "C" {
#include <cmocka.h>
}

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <random>
#include <vector>

#include "build/aac/aac_builder.h"
#include "build/reference/reference_builders.h"
#include "box_input.h"
#include "test_support.h" // TS_UNDER_SANITIZER

using namespace aacbvh;

namespace {

using Builder = std::function<void(const BuildInput &, BuildContext &, BinaryTree &)>;

struct NamedBuilder {
    const char *name;
    Builder build;
};

const NamedBuilder kBuilders[] = {
    {"sweep_sah", [](const BuildInput &in, BuildContext &ctx, BinaryTree &out) { build_sweep_sah(in, ctx, out); }},
    {"binned_sah", [](const BuildInput &in, BuildContext &ctx, BinaryTree &out) { build_binned_sah(in, ctx, out); }},
    {"locally_ordered", [](const BuildInput &in, BuildContext &ctx, BinaryTree &out) { build_locally_ordered(in, ctx, out); }},
    {"ploc_r1", [](const BuildInput &in, BuildContext &ctx, BinaryTree &out) { build_ploc(in, 1, ctx, out); }},
    {"ploc_r16", [](const BuildInput &in, BuildContext &ctx, BinaryTree &out) { build_ploc(in, 16, ctx, out); }},
};

/// Caller-side primitive index of input entry i: distinct from i so that a
/// builder that forgets to map prim_ids is caught.
uint32_t prim_id_of(uint32_t i) { return 3 * i + 7; }

BuildInput make_input(const std::vector<Box> &boxes) { return aacbvh_test::box_input(boxes, prim_id_of); }

std::vector<Box> random_boxes(uint32_t n, uint32_t seed, float max_size = 0.1f) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(0.0f, 1.0f), size(0.0f, max_size);
    std::vector<Box> boxes(n);
    for (Box &b : boxes) {
        for (int k = 0; k < 3; ++k) {
            b.lo[k] = pos(rng);
            b.hi[k] = b.lo[k] + size(rng);
        }
    }
    return boxes;
}

/// Points (zero-size boxes) scattered around a few centres, some coinciding.
std::vector<Box> clustered_points(uint32_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-100.0f, 100.0f);
    std::normal_distribution<float> scatter(0.0f, 0.5f);
    float centres[5][3];
    for (auto &c : centres)
        for (float &x : c) x = pos(rng);
    std::vector<Box> boxes(n);
    for (uint32_t i = 0; i < n; ++i) {
        const float *c = centres[rng() % 5];
        const bool exact = rng() % 4 == 0;
        for (int k = 0; k < 3; ++k) boxes[i].lo[k] = boxes[i].hi[k] = c[k] + (exact ? 0.0f : scatter(rng));
    }
    return boxes;
}

std::vector<Box> identical_boxes(uint32_t n) {
    return std::vector<Box>(n, Box{{1.0f, 2.0f, 3.0f}, {1.5f, 2.0f, 4.0f}});
}

bool same_box(const Box &a, const Box &b) {
    for (int k = 0; k < 3; ++k)
        if (a.lo[k] != b.lo[k] || a.hi[k] != b.hi[k]) return false;
    return true;
}

/// Checks the output contract: a full binary tree over exactly the input's
/// primitives, each leaf reached once, n - 1 inner nodes with ids in [n, 2n),
/// every inner box the union of its children's boxes.
void check_tree(const BuildInput &in, const BinaryTree &tree) {
    const uint32_t n = uint32_t(in.size());
    assert_int_equal(tree.leaf_count(), n);
    assert_true(tree.boxes.size() >= 2 * size_t(n) - 1);
    // Leaves: a permutation of the input with matching boxes.
    std::vector<int> seen_prim(n, 0);
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t pid = tree.prim_ids[i];
        assert_true(pid >= 7 && (pid - 7) % 3 == 0);
        const uint32_t src = (pid - 7) / 3;
        assert_true(src < n);
        assert_int_equal(seen_prim[src]++, 0);
        assert_true(same_box(tree.boxes[i], in.boxes[src]));
    }
    if (n == 1) {
        assert_int_equal(tree.root, 0);
        return;
    }
    assert_true(tree.root >= n && tree.root < 2 * n);
    std::vector<int> visits(2 * size_t(n), 0);
    std::vector<uint32_t> stack{tree.root};
    uint32_t inner = 0, leaves = 0;
    while (!stack.empty()) {
        const uint32_t id = stack.back();
        stack.pop_back();
        assert_true(id < 2 * n);
        assert_int_equal(visits[id]++, 0);
        if (tree.is_leaf(id)) {
            ++leaves;
            continue;
        }
        ++inner;
        const uint32_t l = tree.left(id), r = tree.right(id);
        assert_true(l < 2 * n && r < 2 * n && l != r);
        assert_true(tree.boxes[id].contains(tree.boxes[l]));
        assert_true(tree.boxes[id].contains(tree.boxes[r]));
        assert_true(same_box(tree.boxes[id], unite(tree.boxes[l], tree.boxes[r])));
        stack.push_back(l);
        stack.push_back(r);
    }
    assert_int_equal(leaves, n);
    assert_int_equal(inner, n - 1);
}

void build_and_check(const NamedBuilder &b, const std::vector<Box> &boxes, BinaryTree *out = nullptr) {
    const BuildInput in = make_input(boxes);
    Scheduler s(1);
    BuildContext ctx(s, nullptr, nullptr);
    BinaryTree tree;
    b.build(in, ctx, tree);
    check_tree(in, tree);
    if (out) *out = std::move(tree);
}

void test_random_boxes(void **) {
    for (const NamedBuilder &b : kBuilders)
        for (uint32_t n : {1u, 2u, 3u, 1000u, 20000u}) build_and_check(b, random_boxes(n, n + 1));
}

void test_clustered_points(void **) {
    for (const NamedBuilder &b : kBuilders)
        for (uint32_t n : {1u, 2u, 3u, 1000u, 20000u}) build_and_check(b, clustered_points(n, n + 2));
}

void test_identical_boxes(void **) {
    for (const NamedBuilder &b : kBuilders) {
        // Exact clustering of identical boxes grows about as n^1.75: 20,000
        // took 15 s under ThreadSanitizer (on one thread: no race to find) and
        // 7 s under AddressSanitizer. Under a sanitizer the locally-ordered
        // builder gets 5,000; the Release stage runs 20,000.
        const bool exact = std::strcmp(b.name, "locally_ordered") == 0;
        const uint32_t largest = TS_UNDER_SANITIZER && exact ? 5000u : 20000u;
        for (uint32_t n : {1u, 2u, 3u, 1000u, largest}) build_and_check(b, identical_boxes(n));
    }
}

/// Depth of the tree (edges on the longest root-to-leaf path).
uint32_t tree_depth(const BinaryTree &tree) {
    uint32_t depth = 0;
    std::vector<std::pair<uint32_t, uint32_t>> stack{{tree.root, 0}};
    while (!stack.empty()) {
        const auto [id, d] = stack.back();
        stack.pop_back();
        depth = std::max(depth, d);
        if (!tree.is_leaf(id)) {
            stack.push_back({tree.left(id), d + 1});
            stack.push_back({tree.right(id), d + 1});
        }
    }
    return depth;
}

/// Identical boxes give the SAH no preference; the top-down builders must
/// still produce a balanced tree rather than a list.
void test_identical_boxes_balanced(void **) {
    for (int k = 0; k < 2; ++k) {
        BinaryTree tree;
        build_and_check(kBuilders[k], identical_boxes(1024), &tree);
        assert_int_equal(tree_depth(tree), 10);
    }
}

/// The clustering of a tree as a sorted list of leaf sets (bit i = input
/// entry i), independent of node ids and child order. n <= 64.
std::vector<uint64_t> leaf_sets(const BinaryTree &tree) {
    std::vector<uint64_t> mask(tree.boxes.size(), 0);
    std::vector<uint64_t> sets;
    std::function<uint64_t(uint32_t)> visit = [&](uint32_t id) -> uint64_t {
        if (tree.is_leaf(id)) return uint64_t(1) << ((tree.prim_ids[id] - 7) / 3);
        const uint64_t m = visit(tree.left(id)) | visit(tree.right(id));
        sets.push_back(m);
        return m;
    };
    visit(tree.root);
    std::sort(sets.begin(), sets.end());
    return sets;
}

/// Naive greedy clustering: repeatedly merge the globally closest pair,
/// O(n^3). Returns false if a minimum was tied (the answer is then not unique).
bool naive_greedy(const std::vector<Box> &input, std::vector<uint64_t> &sets) {
    std::vector<Box> boxes = input;
    std::vector<uint64_t> masks(input.size());
    for (size_t i = 0; i < masks.size(); ++i) masks[i] = uint64_t(1) << i;
    sets.clear();
    while (boxes.size() > 1) {
        float best = INFINITY;
        size_t bi = 0, bj = 0;
        int ties = 0;
        for (size_t i = 0; i < boxes.size(); ++i)
            for (size_t j = i + 1; j < boxes.size(); ++j) {
                const float d = union_half_area(boxes[i], boxes[j]);
                if (d < best) {
                    best = d;
                    bi = i;
                    bj = j;
                    ties = 0;
                } else if (d == best) {
                    ++ties;
                }
            }
        if (ties) return false;
        boxes[bi] = unite(boxes[bi], boxes[bj]);
        masks[bi] |= masks[bj];
        sets.push_back(masks[bi]);
        boxes.erase(boxes.begin() + bj);
        masks.erase(masks.begin() + bj);
    }
    std::sort(sets.begin(), sets.end());
    return true;
}

void test_locally_ordered_matches_greedy(void **) {
    int compared = 0;
    for (uint32_t seed = 0; seed < 300; ++seed) {
        const uint32_t n = 2 + seed % 63;
        // Mixed sizes, including large boxes that contain small ones.
        const std::vector<Box> boxes = random_boxes(n, 1000 + seed, seed % 2 ? 0.05f : 0.5f);
        std::vector<uint64_t> expected;
        if (!naive_greedy(boxes, expected)) continue;
        BinaryTree tree;
        build_and_check(kBuilders[2], boxes, &tree);
        assert_true(leaf_sets(tree) == expected);
        ++compared;
    }
    assert_true(compared >= 250);
}

/// Greedy clustering also matches on clustered points when distances are
/// unique; inputs with ties are skipped.
void test_locally_ordered_matches_greedy_points(void **) {
    int compared = 0;
    for (uint32_t seed = 0; seed < 100; ++seed) {
        std::vector<Box> boxes = random_boxes(40, 5000 + seed, 0.0f);
        std::vector<uint64_t> expected;
        if (!naive_greedy(boxes, expected)) continue;
        BinaryTree tree;
        build_and_check(kBuilders[2], boxes, &tree);
        assert_true(leaf_sets(tree) == expected);
        ++compared;
    }
    assert_true(compared >= 80);
}

double split_cost(const Box &l, uint32_t nl, const Box &r, uint32_t nr) {
    return double(l.half_area()) * nl + double(r.half_area()) * nr;
}

uint32_t leaf_count_under(const BinaryTree &tree, uint32_t id) {
    if (tree.is_leaf(id)) return 1;
    return leaf_count_under(tree, tree.left(id)) + leaf_count_under(tree, tree.right(id));
}

/// Brute force over every axis-aligned split plane through a centroid.
void test_sweep_sah_top_split_optimal(void **) {
    for (uint32_t seed = 0; seed < 50; ++seed) {
        const uint32_t n = 3 + seed % 20;
        const std::vector<Box> boxes = random_boxes(n, 7000 + seed, 0.4f);
        double best = INFINITY;
        for (int axis = 0; axis < 3; ++axis)
            for (uint32_t t = 0; t < n; ++t) {
                Box l = Box::empty(), r = Box::empty();
                uint32_t nl = 0;
                for (const Box &b : boxes) {
                    if (b.centroid(axis) <= boxes[t].centroid(axis)) {
                        l.extend(b);
                        ++nl;
                    } else {
                        r.extend(b);
                    }
                }
                if (nl == 0 || nl == n) continue;
                best = std::min(best, split_cost(l, nl, r, n - nl));
            }
        BinaryTree tree;
        build_and_check(kBuilders[0], boxes, &tree);
        const uint32_t l = tree.left(tree.root), r = tree.right(tree.root);
        const double cost = split_cost(tree.boxes[l], leaf_count_under(tree, l), tree.boxes[r],
                                       leaf_count_under(tree, r));
        assert_true(std::fabs(cost - best) <= 1e-9 * best);
    }
}

bool same_tree(const BinaryTree &a, const BinaryTree &b) {
    if (a.root != b.root || a.prim_ids != b.prim_ids) return false;
    const uint32_t n = a.leaf_count();
    std::vector<uint32_t> stack{a.root};
    while (!stack.empty()) {
        const uint32_t id = stack.back();
        stack.pop_back();
        if (!same_box(a.boxes[id], b.boxes[id])) return false;
        if (id < n) continue;
        if (a.left(id) != b.left(id) || a.right(id) != b.right(id)) return false;
        stack.push_back(a.left(id));
        stack.push_back(a.right(id));
    }
    return true;
}

void test_thread_count_independent(void **) {
    const BuildInput in = make_input(random_boxes(30000, 99));
    for (const NamedBuilder &b : kBuilders) {
        BinaryTree one, four;
        Scheduler s1(1), s4(4);
        BuildContext c1(s1, nullptr, nullptr), c4(s4, nullptr, nullptr);
        b.build(in, c1, one);
        b.build(in, c4, four);
        assert_true(same_tree(one, four));
    }
}

bool refuse(void *, double) { return false; }

void test_cancellation(void **) {
    const BuildInput in = make_input(random_boxes(20000, 5));
    for (const NamedBuilder &b : kBuilders) {
        Scheduler s(1);
        BuildContext ctx(s, refuse, nullptr);
        bool thrown = false;
        try {
            ctx.report(0.0);
        } catch (const Error &) {
            thrown = true;
        }
        assert_true(thrown);
        thrown = false;
        try {
            BinaryTree tree;
            b.build(in, ctx, tree);
        } catch (const Error &e) {
            thrown = e.status() == AACBVH_ERROR_CANCELLED;
        }
        assert_true(thrown);
    }
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_boxes),
        cmocka_unit_test(test_clustered_points),
        cmocka_unit_test(test_identical_boxes),
        cmocka_unit_test(test_identical_boxes_balanced),
        cmocka_unit_test(test_locally_ordered_matches_greedy),
        cmocka_unit_test(test_locally_ordered_matches_greedy_points),
        cmocka_unit_test(test_sweep_sah_top_split_optimal),
        cmocka_unit_test(test_thread_count_independent),
        cmocka_unit_test(test_cancellation),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
