// The full-sweep top over AAC's sub-trees (build/aac/top_rebuild.h), checked
// against independent references: a naive sweep (each node sorts its own
// elements) for the new top, the full-sweep SAH builder for a cut at single
// primitives, and a bottom-up recount (choose_subtrees) for the choices. On
// random soups, clustered soups and adversarial inputs (all boxes equal, flat
// boxes, every centroid on one line).
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <algorithm>
#include <cmath>
#include <vector>

#include "build/aac/aac_builder.h"
#include "build/aac/top_rebuild.h"
#include "build/reference/reference_builders.h"
#include "core/scheduler.h"
#include "xorshift_rng.h"
#include "box_input.h"

namespace {

using aacbvh::BinaryTree;
using aacbvh::Box;
using aacbvh::FlattenRule;
using aacbvh::SubtreeChoice;
using aacbvh::SubtreeChoices;

using aacbvh_test::box_input;

FlattenRule rule_for(const aacbvh::BuildInput &in, uint32_t max_leaf_size = 4) {
    FlattenRule rule{max_leaf_size, 1.2, 1.0};
    rule.extent_scale = aacbvh::extent_scale_of(in.bounds);
    return rule;
}

/// AAC-HQ's tree as clustered (no top rebuild) and its choices.
void build_clustered(const std::vector<Box> &boxes, const FlattenRule &rule, BinaryTree &tree,
                     SubtreeChoices &choices, unsigned threads = 1) {
    aacbvh::Scheduler scheduler(threads);
    aacbvh::BuildContext ctx(scheduler, nullptr, nullptr);
    aacbvh::BuildInput in = box_input(boxes);
    aacbvh::AacConfig config{20, 3.02, 0.4, 1, 2.3, 0.4, 1, 0};
    aacbvh::build_aac(in, config, rule, ctx, tree, choices);
}

struct Elements {
    std::vector<uint32_t> ids;   ///< tree ids of the maximal sub-trees of at most `cut` primitives
    std::vector<uint32_t> top;   ///< tree ids of the inner nodes above them
};

uint32_t prims_of(const BinaryTree &t, const SubtreeChoices &c, uint32_t id) {
    return t.is_leaf(id) ? 1u : c.prims(id - t.leaf_count());
}

void cut_of(const BinaryTree &t, const SubtreeChoices &c, uint32_t id, uint32_t cut, Elements &out) {
    if (t.is_leaf(id) || prims_of(t, c, id) <= cut) {
        out.ids.push_back(id);
        return;
    }
    out.top.push_back(id);
    cut_of(t, c, t.left(id), cut, out);
    cut_of(t, c, t.right(id), cut, out);
}

SubtreeChoice choice_of(const BinaryTree &t, const SubtreeChoices &c, const FlattenRule &rule, uint32_t id) {
    return t.is_leaf(id) ? rule.leaf(t.boxes[id]) : c.get(id - t.leaf_count());
}

/// The reference top: at every node the elements are sorted again on each
/// axis by (centroid, left-to-right position), and the split of least
/// SA(left) N(left) + SA(right) N(right) taken (ties: the more balanced, then
/// the lower axis); returns the node's flattened choice.
SubtreeChoice naive_top(const BinaryTree &t, const SubtreeChoices &c, const FlattenRule &rule,
                        std::vector<uint32_t> elems /* positions into ids */, const std::vector<uint32_t> &ids) {
    if (elems.size() == 1) return choice_of(t, c, rule, ids[elems[0]]);
    const uint32_t count = uint32_t(elems.size());
    double best = INFINITY;
    int best_axis = 0;
    uint32_t best_m = 1;
    std::vector<uint32_t> best_order;
    for (int axis = 0; axis < 3; ++axis) {
        std::vector<uint32_t> order = elems;
        std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
            const float ca = t.boxes[ids[a]].centroid(axis), cb = t.boxes[ids[b]].centroid(axis);
            return ca < cb || (ca == cb && a < b);
        });
        for (uint32_t m = 1; m < count; ++m) {
            Box l = Box::empty(), r = Box::empty();
            uint32_t nl = 0, nr = 0;
            for (uint32_t i = 0; i < m; ++i) {
                l.extend(t.boxes[ids[order[i]]]);
                nl += prims_of(t, c, ids[order[i]]);
            }
            for (uint32_t i = m; i < count; ++i) {
                r.extend(t.boxes[ids[order[i]]]);
                nr += prims_of(t, c, ids[order[i]]);
            }
            const double cost = double(aacbvh::scaled_half_area(l, rule.extent_scale)) * nl +
                                double(aacbvh::scaled_half_area(r, rule.extent_scale)) * nr;
            const bool balanced = std::abs(2 * int64_t(m) - int64_t(count)) < std::abs(2 * int64_t(best_m) - int64_t(count));
            if (cost < best || (cost == best && balanced)) {
                best = cost;
                best_axis = axis;
                best_m = m;
                best_order = order;
            }
        }
    }
    (void)best_axis;
    Box box = Box::empty();
    for (uint32_t e : elems) box.extend(t.boxes[ids[e]]);
    const std::vector<uint32_t> left(best_order.begin(), best_order.begin() + best_m);
    const std::vector<uint32_t> right(best_order.begin() + best_m, best_order.end());
    return rule.inner(box, naive_top(t, c, rule, left, ids), naive_top(t, c, rule, right, ids));
}

/// Every leaf reached once; every inner box the union of its children's.
void check_structure(const BinaryTree &t, uint32_t id, std::vector<uint8_t> &seen) {
    if (t.is_leaf(id)) {
        assert_int_equal(seen[id], 0);
        seen[id] = 1;
        return;
    }
    Box u = t.boxes[t.left(id)];
    u.extend(t.boxes[t.right(id)]);
    assert_memory_equal(&u, &t.boxes[id], sizeof(Box));
    check_structure(t, t.left(id), seen);
    check_structure(t, t.right(id), seen);
}

/// The sub-tree at `root` as a walk meets it: ids and boxes, depth first
/// (the arrays' unused entries left out).
void walk(const BinaryTree &t, uint32_t root, std::vector<uint32_t> &ids, std::vector<Box> &boxes) {
    std::vector<uint32_t> stack{root};
    while (!stack.empty()) {
        const uint32_t id = stack.back();
        stack.pop_back();
        ids.push_back(id);
        boxes.push_back(t.boxes[id]);
        if (t.is_leaf(id)) continue;
        stack.push_back(t.right(id));
        stack.push_back(t.left(id));
    }
}

/// Rebuilds the top of AAC's tree over `boxes` at `cut` and checks it: the
/// root's cost is the reference's where that is lower, else the tree is
/// untouched; the sub-trees below the cut are untouched; the choices agree
/// with a recount from scratch. Returns whether the top was replaced.
bool check_rebuild(const std::vector<Box> &boxes, uint32_t cut, uint32_t max_leaf_size = 4) {
    const FlattenRule rule = rule_for(box_input(boxes), max_leaf_size);
    BinaryTree tree;
    SubtreeChoices choices;
    build_clustered(boxes, rule, tree, choices);
    const uint32_t n = tree.leaf_count();
    const BinaryTree before_tree{tree.boxes, tree.children, tree.prim_ids, tree.root};
    Elements cut_before;
    cut_of(tree, choices, tree.root, cut, cut_before);
    const double old_cost = tree.is_leaf(tree.root) ? 0.0 : choices.cost(tree.root - n);
    std::vector<uint32_t> all(cut_before.ids.size());
    for (uint32_t i = 0; i < all.size(); ++i) all[i] = i;
    const double want = cut_before.ids.size() >= 3 ? naive_top(tree, choices, rule, all, cut_before.ids).cost : old_cost;

    aacbvh::Scheduler scheduler(1);
    aacbvh::BuildContext ctx(scheduler, nullptr, nullptr);
    const bool replaced = aacbvh::rebuild_top(tree, choices.table(), rule, cut, ctx);

    if (float(want) < float(old_cost)) {
        assert_true(replaced);
    } else {
        assert_false(replaced);
    }
    std::vector<uint32_t> ids_before, ids_after;
    std::vector<Box> boxes_before, boxes_after;
    if (!replaced) {
        walk(before_tree, before_tree.root, ids_before, boxes_before);
        walk(tree, tree.root, ids_after, boxes_after);
        assert_true(ids_before == ids_after);
        assert_memory_equal(boxes_before.data(), boxes_after.data(), boxes_before.size() * sizeof(Box));
        return false;
    }
    // The new top: the reference's cost, never above the old one's.
    const double got = choices.cost(tree.root - n);
    if (std::fabs(got - want) > 1e-6 * want) fail_msg("root cost %.9g, the reference's %.9g", got, want);
    assert_true(float(got) < float(old_cost));
    // The same elements below the same top ids (a walk from the new root
    // meets only old top ids until it reaches an element, and every element
    // once), the sub-trees below untouched.
    std::vector<uint8_t> is_element(2 * size_t(n), 0), is_top(2 * size_t(n), 0), met(2 * size_t(n), 0);
    for (uint32_t id : cut_before.ids) is_element[id] = 1;
    for (uint32_t id : cut_before.top) is_top[id] = 1;
    std::vector<uint32_t> stack{tree.root};
    while (!stack.empty()) {
        const uint32_t id = stack.back();
        stack.pop_back();
        assert_int_equal(met[id], 0);
        met[id] = 1;
        if (is_element[id]) continue;
        assert_int_equal(is_top[id], 1);
        stack.push_back(tree.left(id));
        stack.push_back(tree.right(id));
    }
    for (uint32_t id : cut_before.ids) assert_int_equal(met[id], 1);
    for (uint32_t id : cut_before.top) assert_int_equal(met[id], 1);
    for (uint32_t id : cut_before.ids) {
        walk(before_tree, id, ids_before, boxes_before);
        walk(tree, id, ids_after, boxes_after);
    }
    assert_true(ids_before == ids_after);
    assert_memory_equal(boxes_before.data(), boxes_after.data(), boxes_before.size() * sizeof(Box));
    std::vector<uint8_t> seen(n, 0);
    check_structure(tree, tree.root, seen);
    assert_true(std::find(seen.begin(), seen.end(), 0) == seen.end());
    // The choices: a recount of the whole new tree gives the same.
    SubtreeChoices recount;
    aacbvh::BuildContext ctx2(scheduler, nullptr, nullptr);
    aacbvh::choose_subtrees(tree, rule, ctx2, recount);
    for (uint32_t id : cut_before.top) {
        assert_int_equal(recount.prims(id - n), choices.prims(id - n));
        assert_int_equal(recount.leaves(id - n), choices.leaves(id - n));
        if (std::fabs(recount.cost(id - n) - choices.cost(id - n)) > 1e-5 * recount.cost(id - n))
            fail_msg("node %u: cost %.9g, recounted %.9g", id, choices.cost(id - n), recount.cost(id - n));
    }
    // Done again (the cut may now meet new small nodes as elements), the
    // root's cost never rises.
    assert_true(!aacbvh::rebuild_top(tree, choices.table(), rule, cut, ctx) ||
                float(choices.cost(tree.root - n)) < float(got));
    assert_true(choices.cost(tree.root - n) <= got);
    return true;
}

Box random_triangle_box(XorshiftRng &rng, float spread, float size) {
    float lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        const float c = rng.unit() * spread;
        lo[k] = c;
        hi[k] = c + rng.unit() * size;
    }
    return Box{{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}};
}

/// A scanned-surface stand-in: small boxes on a bumpy sphere.
std::vector<Box> sphere_soup(uint32_t n, uint64_t seed) {
    XorshiftRng rng{seed * 0x9E3779B97F4A7C15ull + 1};
    std::vector<Box> boxes(n);
    for (uint32_t i = 0; i < n; ++i) {
        const float u = rng.unit() * 6.2831853f, v = std::acos(2.0f * rng.unit() - 1.0f);
        const float r = 10.0f + std::sin(5 * u) * std::sin(3 * v);
        const float x = r * std::sin(v) * std::cos(u), y = r * std::sin(v) * std::sin(u), z = r * std::cos(v);
        const float s = 0.05f + 0.1f * rng.unit();
        boxes[i] = Box{{x - s, y - s, z - s}, {x + s, y + s, z + s}};
    }
    return boxes;
}

void test_random_soups(void **) {
    int replaced = 0;
    for (uint64_t seed = 1; seed <= 6; ++seed) {
        XorshiftRng rng{seed * 0x9E3779B97F4A7C15ull + 1};
        std::vector<Box> boxes(1500 + 500 * seed);
        for (Box &b : boxes) b = random_triangle_box(rng, 100.0f, seed % 2 ? 1.0f : 20.0f);
        for (uint32_t cut : {8u, 64u, 300u}) replaced += check_rebuild(boxes, cut);
    }
    for (uint64_t seed = 1; seed <= 4; ++seed)
        for (uint32_t cut : {16u, 64u}) replaced += check_rebuild(sphere_soup(4000, seed), cut);
    // Leaves larger than the cut: new top nodes may become leaves themselves.
    for (uint32_t max_leaf : {16u, 64u, 1000u})
        for (uint32_t cut : {8u, 64u}) replaced += check_rebuild(sphere_soup(3000, 9), cut, max_leaf);
    // The scan stand-ins are what the rebuild is for: it must take some.
    assert_true(replaced > 0);
}

// A cut at single primitives makes the new top the full sweep of every
// primitive: the full-sweep SAH builder's tree, cost for cost.
void test_cut_at_leaves_is_full_sweep(void **) {
    const std::vector<Box> boxes = sphere_soup(3000, 11);
    const aacbvh::BuildInput in = box_input(boxes);
    const FlattenRule rule = rule_for(in);
    BinaryTree tree;
    SubtreeChoices choices;
    build_clustered(boxes, rule, tree, choices);
    aacbvh::Scheduler scheduler(1);
    aacbvh::BuildContext ctx(scheduler, nullptr, nullptr);
    assert_true(aacbvh::rebuild_top(tree, choices.table(), rule, 1, ctx));
    BinaryTree sweep;
    SubtreeChoices sweep_choices;
    aacbvh::build_sweep_sah(in, ctx, sweep);
    aacbvh::choose_subtrees(sweep, rule, ctx, sweep_choices);
    const double got = choices.cost(tree.root - tree.leaf_count());
    const double want = sweep_choices.cost(sweep.root - sweep.leaf_count());
    if (std::fabs(got - want) > 1e-6 * want) fail_msg("cut at leaves: %.9g, full sweep %.9g", got, want);
}

// Large splits, the walk that collects the sub-trees and the choices run as
// parallel tasks: the same tree and the same choices at 1, 2 and 3 threads
// (thousands of sub-trees, so that both sides of the top splits fork).
void test_same_at_any_thread_count(void **) {
    const std::vector<Box> boxes = sphere_soup(40000, 3);
    const FlattenRule rule = rule_for(box_input(boxes));
    std::vector<uint32_t> first_children;
    std::vector<Box> first_boxes;
    std::vector<double> first_costs;
    std::vector<uint32_t> first_counts;
    for (unsigned threads : {1u, 2u, 3u}) {
        BinaryTree tree;
        SubtreeChoices choices;
        build_clustered(boxes, rule, tree, choices, threads);
        aacbvh::Scheduler scheduler(threads);
        aacbvh::BuildContext ctx(scheduler, nullptr, nullptr);
        Elements cut;
        cut_of(tree, choices, tree.root, 8, cut);
        assert_true(cut.ids.size() > 4 * 1024);
        assert_true(aacbvh::rebuild_top(tree, choices.table(), rule, 8, ctx));
        std::vector<uint32_t> children;
        std::vector<Box> tree_boxes;
        walk(tree, tree.root, children, tree_boxes);
        std::vector<double> costs;
        std::vector<uint32_t> counts;
        for (const uint32_t id : children) {
            if (tree.is_leaf(id)) continue;
            const uint32_t k = id - tree.leaf_count();
            costs.push_back(choices.cost(k));
            counts.push_back(choices.prims(k));
            counts.push_back(choices.leaves(k));
        }
        if (threads == 1) {
            first_children = children;
            first_boxes = tree_boxes;
            first_costs = costs;
            first_counts = counts;
            continue;
        }
        assert_true(children == first_children);
        assert_memory_equal(tree_boxes.data(), first_boxes.data(), tree_boxes.size() * sizeof(Box));
        assert_memory_equal(costs.data(), first_costs.data(), costs.size() * sizeof(double));
        assert_true(counts == first_counts);
    }
}

// Adversarial inputs: all boxes equal (every centroid ties), flat boxes on
// one plane, centroids on one line, and cuts at or above the primitive count
// (no top to rebuild).
void test_adversarial(void **) {
    std::vector<Box> same(700, Box{{1, 2, 3}, {4, 5, 6}});
    for (uint32_t cut : {1u, 8u, 64u}) check_rebuild(same, cut);
    XorshiftRng rng{5 * 0x9E3779B97F4A7C15ull + 1};
    std::vector<Box> flat(900), line(900);
    for (uint32_t i = 0; i < 900; ++i) {
        const float x = rng.unit() * 50, y = rng.unit() * 50;
        flat[i] = Box{{x, y, 0}, {x + 1, y + 0.5f, 0}};
        line[i] = Box{{float(i), -rng.unit(), -1}, {float(i) + 2, rng.unit(), 1}};
    }
    for (uint32_t cut : {4u, 32u}) {
        check_rebuild(flat, cut);
        check_rebuild(line, cut);
    }
    assert_false(check_rebuild(flat, 900));
    assert_false(check_rebuild(flat, 5000));
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_soups),
        cmocka_unit_test(test_cut_at_leaves_is_full_sweep),
        cmocka_unit_test(test_same_at_any_thread_count),
        cmocka_unit_test(test_adversarial),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
