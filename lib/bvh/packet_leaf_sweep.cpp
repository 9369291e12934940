// The packet-leaf choice of the 8-wide layout (see packet_leaf_sweep.h).
#include "bvh/packet_leaf_sweep.h"

#include <cmath>

#include "bvh/wide8_bvh.h"

namespace aacbvh {

PacketLeafSweep::PacketLeafSweep(const Bvh &bvh, Scheduler &scheduler, size_t grain)
    : range_count(bvh.nodes.size()), range_first(bvh.nodes.size()), packet_leaf(bvh.nodes.size()),
      nodes_(bvh.nodes.data()), extent_scale_(bvh.nodes.empty() ? 1.0f : extent_scale_of(bvh.nodes[0].box)),
      scheduler_(scheduler), grain_(grain), cost_(bvh.nodes.size()) {
    if (!bvh.nodes.empty()) sweep(0, bvh.nodes.size(), 0);
    Array<float>().swap(cost_);
}

/// Node i and its descendants, which the emitted layout keeps in positions
/// [nodes_[i].first, end): its left child's after its children pair, its
/// right child's after them. Children sit after their parent, so a backward
/// loop over such a range sees them first; big subtrees split into two tasks.
void PacketLeafSweep::sweep(uint32_t i, size_t end, unsigned depth) {
    const Node &b = nodes_[i];
    if (!b.is_leaf()) {
        const size_t first = b.first;
        if (end - first > grain_ && depth < 48) {
            const uint32_t l = b.first, r = b.first + 1;
            const size_t left_end = nodes_[r].is_leaf() ? end : nodes_[r].first;
            scheduler_.fork_join([&] { sweep(l, left_end, depth + 1); }, [&] { sweep(r, end, depth + 1); });
        } else {
            for (size_t k = end; k-- > first;) visit(uint32_t(k));
        }
    }
    visit(i);
}

void PacketLeafSweep::visit(uint32_t i) {
    const Node &b = nodes_[i];
    const float area = b.box.is_empty() ? 0.0f : scaled_half_area(b.box, extent_scale_);
    if (b.is_leaf()) {
        range_first[i] = b.first;
        range_count[i] = b.count;
        // A binary leaf is a leaf of the wide tree at any size: its packets
        // are tested whole, so its cost is theirs. (An infinite cost for a
        // leaf of more than kPacketLeaf primitives once made every ancestor
        // "cheaper as a leaf", infinity against infinity, and the whole tree
        // one packet leaf: docs/PERFORMANCE.md, change 145.)
        cost_[i] = packet_leaf_cost(area, b.count);
        packet_leaf[i] = 1;
        return;
    }
    const uint32_t l = b.first, r = b.first + 1;
    const bool joined = range_count[l] != kNoRange && range_count[r] != kNoRange &&
                        range_first[l] + range_count[l] == range_first[r] &&
                        uint64_t(range_count[l]) + range_count[r] < kNoRange;
    const uint32_t count = joined ? range_count[l] + range_count[r] : kNoRange;
    range_first[i] = range_first[l];
    range_count[i] = count;
    packet_leaf[i] = choose_packet_leaf(area, count, cost_[l], cost_[r], cost_[i]) ? 1 : 0;
}

} // namespace aacbvh
