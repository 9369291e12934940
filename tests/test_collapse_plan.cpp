// SubtreePlan (lib/bvh/collapse_plan.h), the SAH collapse of the 8-wide
// layout's small subtrees: on random binary trees, the wide tree its plan
// gives costs exactly the least that an independent search finds by
// enumerating every cut of every subtree (every set of up to eight nodes
// that covers a node's leaves once), under the same model and the same rules
// (binary leaves and subtrees of at most kWholePrimitives primitives are
// never opened; subtrees of at most kMaxPacketLeaf primitives may be one
// packet leaf); each wide node's children cover its primitives once and
// come largest first. Then, on whole scenes, the default layout's wide nodes
// keep their lanes in order of area, as the traversals expect, and each
// handle's wide tree is its collapse rule's (largest first for AAC-Fast,
// planned for the others, which costs less in the model).
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
#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

#include "bvh/collapse_plan.h"
#include "bvh/wide8_bvh.h"
#include "bvh_object.h"
#include "core/box.h"
#include "core/scheduler.h"
#include "random_soup.h"

namespace {

/// A binary tree of explicit nodes: node 0 the root, leaves with a
/// primitive count, inner nodes with two children.
struct TestTree {
    struct N {
        aacbvh::Box box;
        uint32_t left = 0, right = 0; ///< inner nodes only
        uint32_t prims = 0;
        bool leaf = false;
    };
    std::vector<N> nodes;
};

/// The Source SubtreePlan reads (bvh/collapse_plan.h).
struct TestSource {
    using Handle = uint32_t;
    const TestTree *tree;
    bool is_binary_leaf(uint32_t i) const { return tree->nodes[i].leaf; }
    float half_area(uint32_t i) const { return tree->nodes[i].box.half_area(); }
    void children(uint32_t i, uint32_t &l, uint32_t &r) const {
        l = tree->nodes[i].left;
        r = tree->nodes[i].right;
    }
    uint32_t prims(uint32_t i) const { return tree->nodes[i].prims; }
    void prefetch(uint32_t) const {}
};

/// A random tree over `leaves` leaves (random splits), leaf boxes random
/// in [0, 10]^3 (some flat, some tiny), 1-3 primitives a leaf.
TestTree random_tree(uint32_t leaves, std::mt19937 &rng) {
    TestTree t;
    std::uniform_real_distribution<float> pos(0.0f, 10.0f), size(0.0f, 3.0f);
    std::uniform_int_distribution<uint32_t> prims(1, 3);
    struct Build {
        TestTree &t;
        std::mt19937 &rng;
        std::uniform_real_distribution<float> &pos, &size;
        std::uniform_int_distribution<uint32_t> &prims;
        uint32_t make(uint32_t n) {
            const uint32_t id = uint32_t(t.nodes.size());
            t.nodes.emplace_back();
            if (n == 1) {
                TestTree::N leaf;
                leaf.leaf = true;
                leaf.prims = prims(rng);
                for (int a = 0; a < 3; ++a) {
                    leaf.box.lo[a] = pos(rng);
                    leaf.box.hi[a] = leaf.box.lo[a] + (rng() % 5 == 0 ? 0.0f : size(rng));
                }
                t.nodes[id] = leaf;
                return id;
            }
            const uint32_t nl = 1 + uint32_t(rng() % (n - 1));
            const uint32_t l = make(nl), r = make(n - nl);
            TestTree::N inner;
            inner.left = l;
            inner.right = r;
            inner.prims = t.nodes[l].prims + t.nodes[r].prims;
            inner.box = t.nodes[l].box;
            inner.box.extend(t.nodes[r].box);
            t.nodes[id] = inner;
            return id;
        }
    } b{t, rng, pos, size, prims};
    b.make(leaves);
    return t;
}

/// The independent search: every cut below a node, by enumeration.
struct Search {
    const TestTree &t;
    uint32_t root;

    bool whole(uint32_t x) const {
        return x != root && (t.nodes[x].leaf || t.nodes[x].prims <= aacbvh::SubtreePlan<TestSource>::kWholePrimitives);
    }
    double leaf_cost(uint32_t x) const {
        return double(aacbvh::packet_leaf_cost(t.nodes[x].box.half_area(), t.nodes[x].prims));
    }
    /// Every cut of x's subtree (sets of nodes covering its leaves once), of
    /// at most `limit` nodes.
    std::vector<std::vector<uint32_t>> cuts(uint32_t x, size_t limit) const {
        std::vector<std::vector<uint32_t>> out{{x}};
        if (whole(x) || t.nodes[x].leaf || limit < 2) return out;
        for (const auto &l : cuts(t.nodes[x].left, limit - 1))
            for (const auto &r : cuts(t.nodes[x].right, limit - l.size())) {
                std::vector<uint32_t> c = l;
                c.insert(c.end(), r.begin(), r.end());
                if (c.size() <= limit) out.push_back(c);
            }
        return out;
    }
    /// The least cost of x as one child: one packet leaf where allowed, or a
    /// wide node over the best cut of its children.
    double as_child(uint32_t x) const {
        const TestTree::N &n = t.nodes[x];
        if (whole(x)) return leaf_cost(x);
        double best = double(n.box.half_area()) + below(x);
        if (n.prims <= aacbvh::kMaxPacketLeaf) best = std::min(best, leaf_cost(x));
        return best;
    }
    /// The least cost of the children of a wide node over x.
    double below(uint32_t x) const {
        double best = INFINITY;
        for (const auto &l : cuts(t.nodes[x].left, 7))
            for (const auto &r : cuts(t.nodes[x].right, 8 - l.size())) {
                double c = 0.0;
                for (uint32_t k : l) c += as_child(k);
                for (uint32_t k : r) c += as_child(k);
                best = std::min(best, c);
            }
        return best;
    }
};

/// The planned wide tree's cost below wide node `node` (a plan index), with
/// its children's checks.
double planned_cost(const aacbvh::SubtreePlan<TestSource> &plan, const TestTree &t, uint32_t node) {
    uint32_t kids[8];
    bool leaf[8];
    const int m = plan.open(node, kids, leaf);
    if (m < 2) fail_msg("a wide node of %d children", m);
    uint32_t prims = 0;
    double cost = 0.0;
    for (int k = 0; k < m; ++k) {
        const TestTree::N &n = t.nodes[plan.handle(kids[k])];
        prims += n.prims;
        if (k > 0 && t.nodes[plan.handle(kids[k - 1])].box.half_area() < n.box.half_area())
            fail_msg("children not largest first");
        if (n.leaf && !leaf[k]) fail_msg("a binary leaf made a wide node");
        if (leaf[k] && n.prims > aacbvh::kMaxPacketLeaf && !n.leaf) fail_msg("a packet leaf of %u primitives", n.prims);
        cost += leaf[k] ? double(aacbvh::packet_leaf_cost(n.box.half_area(), n.prims))
                        : double(n.box.half_area()) + planned_cost(plan, t, kids[k]);
    }
    if (prims != t.nodes[plan.handle(node)].prims) fail_msg("children hold %u primitives, the node %u", prims,
                                                            t.nodes[plan.handle(node)].prims);
    return cost;
}

void test_plan_is_optimal(void **) {
    std::mt19937 rng(2026);
    const TestTree empty;
    TestSource source{&empty};
    aacbvh::SubtreePlan<TestSource> plan(source); // reused across trees, as the collapse's tasks do
    for (uint32_t leaves = 2; leaves <= 11; ++leaves)
        for (int round = 0; round < 12; ++round) {
            const TestTree t = random_tree(leaves, rng);
            source.tree = &t;
            const uint32_t root = plan.plan(0);
            const double got = planned_cost(plan, t, root);
            const double want = Search{t, 0}.below(0);
            if (!(std::fabs(got - want) <= 1e-5 * want + 1e-6))
                fail_msg("%u leaves, round %d: planned cost %.9g, least %.9g", leaves, round, got, want);
            // Planned again: the same plan.
            const uint32_t again = plan.plan(0);
            if (planned_cost(plan, t, again) != got) fail_msg("%u leaves, round %d: planned twice, two costs", leaves, round);
        }
}

/// The default layout (packets, the plan in the tasks' subtrees): every wide
/// node's lanes in order of area, for AAC and the sweep, at 1 and 2 threads,
/// and the same nodes at both thread counts.
void test_default_layout_lanes_by_area(void **) {
    const std::vector<float> soup = aacbvh_test::random_soup(20000, 23);
    for (aacbvh_builder builder : {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_SWEEP_SAH}) {
        std::vector<aacbvh::Wide8Node> first;
        for (unsigned threads : {1u, 2u}) {
            aacbvh::Scheduler scheduler(threads);
            aacbvh::BvhObject object(scheduler);
            aacbvh_test::build_soup(object, soup, builder, 4);
            const aacbvh::Wide8Bvh &wide = object.wide8();
            assert_true(wide.has_packets());
            size_t ordered = 0;
            for (size_t w = 0; w < wide.node_count(); ++w) {
                const aacbvh::Wide8Node &node = wide.nodes()[w];
                float previous = 0.0f;
                for (int k = 0; k < 8 && node.child[k] != aacbvh::Wide8Node::kEmptyChild; ++k) {
                    const aacbvh::Box b = node.slot_box(k);
                    if (k > 0 && b.half_area() > previous)
                        fail_msg("builder %d: wide node %zu, lane %d after a smaller box", int(builder), w, k);
                    ordered += k > 0;
                    previous = b.half_area();
                }
            }
            assert_true(ordered > 0);
            std::vector<aacbvh::Wide8Node> nodes(wide.nodes(), wide.nodes() + wide.node_count());
            if (threads == 1)
                first = nodes;
            else if (nodes.size() != first.size() ||
                     std::memcmp(nodes.data(), first.data(), nodes.size() * sizeof(aacbvh::Wide8Node)) != 0)
                fail_msg("builder %d: other wide nodes at 2 threads", int(builder));
        }
    }
}

/// The wide tree's cost in the collapse's model (bvh/collapse_plan.h): each
/// wide node below the root its box's half area, each packet leaf its half
/// area times kPacketCost a packet.
double model_cost(const aacbvh::Wide8Bvh &wide) {
    double cost = 0.0;
    for (size_t w = 0; w < wide.node_count(); ++w) {
        const aacbvh::Wide8Node &node = wide.nodes()[w];
        for (int k = 0; k < 8 && node.child[k] != aacbvh::Wide8Node::kEmptyChild; ++k) {
            const double area = node.slot_box(k).half_area();
            cost += node.count[k] == 0 ? area * aacbvh::kWideNodeCost : area * aacbvh::kPacketCost * node.count[k];
        }
    }
    return cost;
}

/// The handle's collapse rule: AAC-Fast's trees are collapsed largest first,
/// the others by the plan; on the same binary tree the planned wide tree
/// costs less in the model than the largest-first one (whose packet leaves
/// and cuts are among those the plan weighs: it can only cost as much where
/// no subtree has a better cut); the handle's own wide tree is its rule's.
void test_collapse_rules(void **) {
    const std::vector<float> soup = aacbvh_test::random_soup(20000, 29);
    for (aacbvh_builder builder : {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_SWEEP_SAH}) {
        aacbvh::Scheduler scheduler(2);
        aacbvh::BvhObject object(scheduler);
        aacbvh_test::build_soup(object, soup, builder, 4);
        const aacbvh::CollapseRule rule = object.collapse_rule();
        assert_true((rule == aacbvh::CollapseRule::LargestFirst) == (builder == AACBVH_BUILDER_AAC_FAST));
        object.with_tree([&](const aacbvh::Bvh &tree) {
            aacbvh::Wide8Bvh planned, largest;
            planned.build(tree, &object.geometry(), scheduler, aacbvh::CollapseRule::Planned);
            largest.build(tree, &object.geometry(), scheduler, aacbvh::CollapseRule::LargestFirst);
            const double p = model_cost(planned), l = model_cost(largest), own = model_cost(object.wide8());
            if (!(p < l)) fail_msg("builder %d: planned cost %.9g, largest first %.9g", int(builder), p, l);
            // The handle's own tree is the one its rule makes from the same
            // binary tree (straight from the builder's tree, for AAC).
            const double want = rule == aacbvh::CollapseRule::Planned ? p : l;
            if (!(std::fabs(own - want) <= 1e-9 * want))
                fail_msg("builder %d: the handle's wide tree costs %.12g, its rule's %.12g", int(builder), own, want);
        });
    }
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_plan_is_optimal),
        cmocka_unit_test(test_default_layout_lanes_by_area),
        cmocka_unit_test(test_collapse_rules),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
