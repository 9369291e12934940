// PacketLeafSweep (lib/bvh/packet_leaf_sweep.h), the 8-wide layout's choice
// of packet leaves: split into tasks along the emitted layout's subtree
// ranges, it must give exactly what one backward loop over all nodes gives
// (a grain larger than the tree), at every grain and thread count; and each
// node's slot range must be the slots of the leaves below it (brute force).
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

#include "bvh/packet_leaf_sweep.h"
#include "bvh/wide8_bvh.h"
#include "bvh_object.h"
#include "core/scheduler.h"
#include "random_soup.h"

namespace {

using aacbvh_test::random_soup;

/// The slots [lo, hi) of the leaves below node i, by recursion; false when
/// they are not one range.
bool slots_below(const aacbvh::Bvh &bvh, uint32_t i, uint32_t &lo, uint32_t &hi) {
    const aacbvh::Node &b = bvh.nodes[i];
    if (b.is_leaf()) {
        lo = b.first;
        hi = b.first + b.count;
        return true;
    }
    uint32_t llo, lhi, rlo, rhi;
    if (!slots_below(bvh, b.first, llo, lhi) || !slots_below(bvh, b.first + 1, rlo, rhi) || lhi != rlo) return false;
    lo = llo;
    hi = rhi;
    return true;
}

/// Returns how many inner nodes became packet leaves.
size_t check_tree(const aacbvh::Bvh &bvh, const char *what) {
    aacbvh::Scheduler one(1), three(3);
    const aacbvh::PacketLeafSweep serial(bvh, one, SIZE_MAX);
    const size_t n = bvh.nodes.size();
    for (uint32_t i = 0; i < n; ++i) {
        uint32_t lo, hi;
        assert_true(slots_below(bvh, i, lo, hi)); // the emitted layout keeps every subtree's slots together
        if (serial.range_first[i] != lo || serial.range_count[i] != hi - lo)
            fail_msg("%s: node %u has range %u+%u, its leaves %u+%u", what, i, serial.range_first[i],
                     serial.range_count[i], lo, hi - lo);
        if (bvh.nodes[i].is_leaf() && !serial.packet_leaf[i]) fail_msg("%s: leaf %u is no packet leaf", what, i);
    }
    size_t packet_subtrees = 0;
    for (uint32_t i = 0; i < n; ++i) packet_subtrees += !bvh.nodes[i].is_leaf() && serial.packet_leaf[i];
    for (size_t grain : {size_t(1), size_t(7), size_t(64), size_t(1000), aacbvh::PacketLeafSweep::kDefaultGrain})
        for (aacbvh::Scheduler *s : {&one, &three}) {
            const aacbvh::PacketLeafSweep split(bvh, *s, grain);
            for (uint32_t i = 0; i < n; ++i)
                if (split.range_first[i] != serial.range_first[i] || split.range_count[i] != serial.range_count[i] ||
                    split.packet_leaf[i] != serial.packet_leaf[i])
                    fail_msg("%s: grain %zu, %u threads: node %u differs from one loop", what, grain,
                             s->thread_count(), i);
        }
    return packet_subtrees;
}

void test_split_sweep_matches_one_loop(void **) {
    aacbvh::Scheduler scheduler(2);
    const std::vector<float> soup = random_soup(6000, 7);
    size_t packet_subtrees = 0;
    const aacbvh_builder builders[] = {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_AAC_FAST, AACBVH_BUILDER_BINNED_SAH};
    for (aacbvh_builder builder : builders)
        for (int leaf : {1, 4, 8}) {
            aacbvh::BvhObject object(scheduler);
            aacbvh_test::build_soup(object, soup, builder, leaf);
            char what[64];
            snprintf(what, sizeof what, "builder %d, leaf %d", int(builder), leaf);
            packet_subtrees += check_tree(object.binary_tree(), what);
        }
    assert_true(packet_subtrees > 0); // the small-subtree rule was exercised
}

/// Leaves of more primitives than a packet leaf holds (max leaf size 32, and
/// a low intersection cost so that the flattening makes them): each stays a
/// leaf of its own, and no subtree of more than kPacketLeaf primitives
/// becomes one packet leaf above it. The sweep once gave such a leaf an
/// infinite cost, which made every ancestor "cheaper as one leaf" (infinity
/// against infinity) and the whole tree a single leaf of packets.
void test_big_leaves_stay_apart(void **) {
    aacbvh::Scheduler scheduler(2);
    const std::vector<float> soup = random_soup(6000, 11);
    for (aacbvh_builder builder : {AACBVH_BUILDER_AAC_HQ, AACBVH_BUILDER_BINNED_SAH}) {
        aacbvh::BvhObject object(scheduler);
        aacbvh_test::set_soup(object, soup);
        object.set_param_int(AACBVH_PARAM_BUILDER, builder);
        object.set_param_int(AACBVH_PARAM_MAX_LEAF_SIZE, 32);
        object.set_param_float(AACBVH_PARAM_INTERSECTION_COST, 0.02);
        object.build();
        const aacbvh::Bvh &bvh = object.binary_tree();
        check_tree(bvh, "leaves of up to 32");
        aacbvh::Scheduler one(1);
        const aacbvh::PacketLeafSweep sweep(bvh, one);
        size_t big_leaves = 0;
        for (uint32_t i = 0; i < bvh.nodes.size(); ++i) {
            big_leaves += bvh.nodes[i].is_leaf() && bvh.nodes[i].count > aacbvh::Wide8Bvh::kPacketLeaf;
            if (!bvh.nodes[i].is_leaf() && sweep.packet_leaf[i] && sweep.range_count[i] > aacbvh::Wide8Bvh::kPacketLeaf)
                fail_msg("builder %d: inner node %u over %u primitives became one packet leaf", int(builder), i,
                         sweep.range_count[i]);
        }
        assert_true(big_leaves > 0); // the case is exercised
    }
}

void test_one_leaf_tree(void **) {
    aacbvh::Scheduler scheduler(1);
    const std::vector<float> soup = random_soup(1, 3);
    aacbvh::BvhObject object(scheduler);
    object.set_triangles(soup.data(), 3, 3 * sizeof(float), nullptr, 1);
    object.build();
    check_tree(object.binary_tree(), "one triangle");
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_split_sweep_matches_one_loop),
        cmocka_unit_test(test_big_leaves_stay_apart),
        cmocka_unit_test(test_one_leaf_tree),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
