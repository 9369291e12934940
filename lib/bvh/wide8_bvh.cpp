// Collapse and refit of the 8-wide layout (its traversal: trace/wide8_traversal.cpp).
#include "bvh/wide8_bvh.h"

#include <cmath>
#include <vector>

namespace aacbvh {

void Wide8Bvh::clear() {
    Array<Wide8Node>().swap(nodes_);
    Array<uint32_t>().swap(sources_);
    Array<TrianglePacket>().swap(packets_);
    node_count_ = 0;
    built_ = false;
}

namespace {

constexpr uint32_t kNoRange = 0xFFFFFFFFu;

void set_empty_slot(Wide8Node &node, int k) {
    node.box[0][k] = node.box[2][k] = node.box[4][k] = INFINITY;
    node.box[1][k] = node.box[3][k] = node.box[5][k] = -INFINITY;
    node.child[k] = Wide8Node::kEmptyChild;
    node.count[k] = 0;
}

void set_slot_box(Wide8Node &node, int k, const Box &b) {
    for (int a = 0; a < 3; ++a) {
        node.box[2 * a][k] = b.lo[a];
        node.box[2 * a + 1][k] = b.hi[a];
    }
}

uint32_t packets_for(uint32_t primitives) { return (primitives + 3) / 4; }

/// SAH costs of the packet-leaf choice, relative to a wide node's test.
constexpr float kPacketCost = 0.25f;
constexpr float kInnerCost = 0.35f;

/// Fills packet `p` from leaf slots [first, first + count), at most four of
/// them, the last repeated in spare lanes.
void fill_packet(TrianglePacket &p, const Geometry &g, const uint32_t *prim_ids, uint32_t first, uint32_t count) {
    for (uint32_t lane = 0; lane < 4; ++lane) {
        const uint32_t id = prim_ids[first + (lane < count ? lane : count - 1)];
        const float *v[3];
        g.triangle(id, v);
        for (int i = 0; i < 3; ++i)
            for (int a = 0; a < 3; ++a) p.v[i][a][lane] = v[i][a];
        p.prim[lane] = id;
    }
}

/// Re-reads the vertices of the packet's own primitives (after a refit).
void refill_packet(TrianglePacket &p, const Geometry &g) {
    for (uint32_t lane = 0; lane < 4; ++lane) {
        const float *v[3];
        g.triangle(p.prim[lane], v);
        for (int i = 0; i < 3; ++i)
            for (int a = 0; a < 3; ++a) p.v[i][a][lane] = v[i][a];
    }
}

} // namespace

void Wide8Bvh::build(const Bvh &bvh, const Geometry *triangles, Scheduler &scheduler) {
    if (bvh.empty()) {
        clear();
        built_ = true;
        return;
    }
    const Node *bnodes = bvh.nodes.data();
    const size_t n = bvh.nodes.size();
    const bool packets = triangles != nullptr;

    // One backward sweep (children follow their parent), only with packets:
    // each binary subtree's slot range (its count is kNoRange unless its
    // slots are one range), and which small subtrees become packet leaves.
    // By the SAH, bottom-up: a subtree of at most kPacketLeaf primitives is
    // one leaf when testing its packets costs less than walking its inner
    // nodes (a binary inner node costs about a third of a wide node: a wide
    // node replaces about three levels) and testing their leaves' packets.
    Array<uint32_t> range_count, range_first;
    Array<uint8_t> packet_leaf;
    if (packets) {
        range_count.resize(n);
        range_first.resize(n);
        packet_leaf.resize(n);
        Array<float> cost(n);
        for (size_t i = n; i-- > 0;) {
            const Node &b = bnodes[i];
            const float area = b.box.half_area();
            if (b.is_leaf()) {
                range_first[i] = b.first;
                range_count[i] = b.count;
                cost[i] = b.count <= kPacketLeaf ? area * kPacketCost * float(packets_for(b.count)) : INFINITY;
                packet_leaf[i] = 1;
                continue;
            }
            const uint32_t l = b.first, r = b.first + 1;
            const bool joined = range_count[l] != kNoRange && range_count[r] != kNoRange &&
                                range_first[l] + range_count[l] == range_first[r] &&
                                uint64_t(range_count[l]) + range_count[r] < kNoRange;
            const uint32_t count = joined ? range_count[l] + range_count[r] : kNoRange;
            range_first[i] = range_first[l];
            range_count[i] = count;
            const float as_leaf = count <= kPacketLeaf ? area * kPacketCost * float(packets_for(count)) : INFINITY;
            const float as_tree = area * kInnerCost + cost[l] + cost[r];
            packet_leaf[i] = as_leaf <= as_tree ? 1 : 0;
            cost[i] = packet_leaf[i] ? as_leaf : as_tree;
        }
    }
    auto is_leaf = [&](uint32_t i) { return bnodes[i].is_leaf() || (packets && packet_leaf[i] != 0); };
    // A leaf child's slot range: the binary leaf's, or the small subtree's.
    auto leaf_range = [&](uint32_t i, uint32_t &first, uint32_t &count) {
        if (bnodes[i].is_leaf()) {
            first = bnodes[i].first;
            count = bnodes[i].count;
        } else {
            first = range_first[i];
            count = range_count[i];
        }
    };

    // Pass 1, depth-first: each wide node's children (binary nodes, kept as
    // `sources` for refit) and their child / count fields; packets are
    // numbered in the same order, so a leaf's packets are contiguous and
    // near its node's other leaves.
    size_t inner = 0;
    for (size_t i = 0; i < n; ++i) inner += bnodes[i].is_leaf() ? 0 : 1;
    const size_t capacity = inner > 0 ? inner : 1;
    Array<uint32_t> sources(8 * capacity);
    Array<uint32_t> fields(16 * capacity); // child[8], count[8] per wide node
    struct Work {
        uint32_t binary;
        uint32_t wide;
    };
    std::vector<Work> work{{0u, 0u}};
    uint32_t next = 1;
    uint32_t next_packet = 0;
    // Each packet's first leaf slot and lane count, for pass 3 (at most one
    // packet per slot).
    Array<uint32_t> packet_slots(packets ? bvh.prim_ids.size() : 0);
    Array<uint8_t> packet_lanes(packets ? bvh.prim_ids.size() : 0);
    while (!work.empty()) {
        const Work w = work.back();
        work.pop_back();
        uint32_t kids[8];
        int m = 0;
        const Node &top = bnodes[w.binary];
        if (top.is_leaf() || is_leaf(w.binary)) {
            kids[m++] = w.binary; // only for a tree that is one leaf
        } else {
            kids[m++] = top.first;
            kids[m++] = top.first + 1;
            while (m < 8) {
                int open = -1;
                float open_area = -1.0f;
                for (int k = 0; k < m; ++k) {
                    if (is_leaf(kids[k])) continue;
                    const float a = bnodes[kids[k]].box.half_area();
                    if (a > open_area) {
                        open = k;
                        open_area = a;
                    }
                }
                if (open < 0) break;
                const uint32_t first = bnodes[kids[open]].first;
                kids[open] = first;
                kids[m++] = first + 1;
            }
        }
        uint32_t *src = &sources[8 * size_t(w.wide)];
        uint32_t *child = &fields[16 * size_t(w.wide)];
        uint32_t *count = child + 8;
        uint32_t wide_kid[8];
        for (int k = 0; k < 8; ++k) {
            wide_kid[k] = Wide8Node::kEmptyChild;
            if (k >= m) {
                src[k] = Wide8Node::kEmptyChild;
                child[k] = Wide8Node::kEmptyChild;
                count[k] = 0;
                continue;
            }
            src[k] = kids[k];
            if (!is_leaf(kids[k])) {
                wide_kid[k] = next++;
                child[k] = wide_kid[k];
                count[k] = 0;
                continue;
            }
            uint32_t first, c;
            leaf_range(kids[k], first, c);
            if (packets) {
                child[k] = next_packet;
                count[k] = packets_for(c);
                for (uint32_t j = 0; j < count[k]; ++j) {
                    packet_slots[next_packet + j] = first + 4 * j;
                    packet_lanes[next_packet + j] = uint8_t(c - 4 * j < 4 ? c - 4 * j : 4);
                }
                next_packet += count[k];
            } else {
                child[k] = first;
                count[k] = c;
            }
        }
        for (int k = m; k-- > 0;)
            if (wide_kid[k] != Wide8Node::kEmptyChild) work.push_back(Work{kids[k], wide_kid[k]});
    }

    // Pass 2, in parallel: nodes and packets.
    Array<Wide8Node> nodes(next);
    Array<TrianglePacket> packet_array(packets ? next_packet : 0);
    const uint32_t *prim_ids = bvh.prim_ids.data();
    scheduler.parallel_for(0, next, 1u << 10, [&](size_t b, size_t e) {
        for (size_t w = b; w < e; ++w) {
            Wide8Node &node = nodes[w];
            for (int k = 0; k < 8; ++k) {
                const uint32_t s = sources[8 * w + k];
                if (s == Wide8Node::kEmptyChild) {
                    set_empty_slot(node, k);
                    continue;
                }
                set_slot_box(node, k, bnodes[s].box);
                node.child[k] = fields[16 * w + k];
                node.count[k] = fields[16 * w + 8 + k];
            }
        }
    });
    // Pass 3, in parallel: the packets, in packet order; the triangles they
    // gather are asked for ahead (two steps: the index, then the vertices).
    scheduler.parallel_for(0, next_packet, 1u << 12, [&](size_t b, size_t e) {
        for (size_t p = b; p < e; ++p) {
            if (p + 16 < e) triangles->prefetch_indices(prim_ids[packet_slots[p + 16]]);
            if (p + 8 < e) triangles->prefetch_vertices(prim_ids[packet_slots[p + 8]]);
            fill_packet(packet_array[p], *triangles, prim_ids, packet_slots[p], packet_lanes[p]);
        }
    });
    Array<uint32_t>().swap(fields);
    Array<uint32_t>().swap(range_count);
    Array<uint32_t>().swap(range_first);
    Array<uint32_t>().swap(packet_slots);
    Array<uint8_t>().swap(packet_lanes);
    Array<uint8_t>().swap(packet_leaf);
    // A copy of the used part (shrink_to_fit() would swallow an allocation
    // failure and keep the whole array).
    Array<uint32_t> used_sources(sources.begin(), sources.begin() + 8 * ptrdiff_t(next));
    Array<uint32_t>().swap(sources);
    nodes_ = std::move(nodes);
    sources_ = std::move(used_sources);
    packets_ = std::move(packet_array);
    node_count_ = next;
    built_ = true;
}

void Wide8Bvh::refit(const Bvh &bvh, const Geometry &geometry, Scheduler &scheduler) {
    const Node *bnodes = bvh.nodes.data();
    Wide8Node *nodes = nodes_.data();
    const uint32_t *sources = sources_.data();
    scheduler.parallel_for(0, node_count_, 1u << 10, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i)
            for (int k = 0; k < 8; ++k)
                if (sources[8 * i + k] != Wide8Node::kEmptyChild) set_slot_box(nodes[i], k, bnodes[sources[8 * i + k]].box);
    });
    TrianglePacket *packets = packets_.data();
    scheduler.parallel_for(0, packets_.size(), 1u << 12, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) refill_packet(packets[i], geometry);
    });
}

} // namespace aacbvh
