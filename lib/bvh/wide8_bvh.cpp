// Collapse and refit of the 8-wide layout (its traversal: trace/wide8_traversal.cpp).
#include "bvh/wide8_bvh.h"

#include "bvh/collapse_plan.h"
#include "bvh/packet_leaf_sweep.h"
#include "bvh/wide_collapse.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <vector>

namespace aacbvh {

void Wide8Bvh::clear() {
    Array<Wide8Node>().swap(nodes_);
    Array<uint32_t>().swap(sources_);
    Array<TrianglePacket>().swap(packets_);
    Array<uint32_t>().swap(packet_owner_);
    node_count_ = 0;
    built_ = false;
    update_bounds();
}

void Wide8Bvh::update_bounds() {
    for (int a = 0; a < 3; ++a) {
        float lo = INFINITY, hi = -INFINITY;
        if (node_count_ != 0)
            for (int k = 0; k < 8; ++k) { // an unused slot's empty box changes nothing
                lo = std::min(lo, nodes_[0].box[2 * a][k]);
                hi = std::max(hi, nodes_[0].box[2 * a + 1][k]);
            }
        bounds_[a] = lo;
        bounds_[4 + a] = hi;
    }
}

namespace testing {
std::atomic<uint64_t> largest_plan_bytes{0};
} // namespace testing

namespace {

void set_empty_slot(Wide8Node &node, int k) {
    node.box[0][k] = node.box[2][k] = node.box[4][k] = INFINITY;
    node.box[1][k] = node.box[3][k] = node.box[5][k] = -INFINITY;
    node.child[k] = Wide8Node::kEmptyChild;
    node.count[k] = 0;
}

void write_slot_box(Wide8Node &node, int k, const Box &b) {
    for (int a = 0; a < 3; ++a) {
        node.box[2 * a][k] = b.lo[a];
        node.box[2 * a + 1][k] = b.hi[a];
    }
}

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

/// The wide nodes below one binary node, numbered from 0 depth-first, with
/// their packets numbered from 0 in the same order (so a leaf's packets are
/// contiguous and near its node's other leaves).
///
/// Plain vectors: they grow as the collapse goes, and the build allocator
/// would make each growth an allocation-failure test point (thousands per
/// tree); MeteredBytes counts them in the build's peak instead.
struct CollapsePiece {
    std::vector<uint32_t> sources;      ///< 8 per wide node: the binary node behind each slot
    std::vector<uint32_t> fields;       ///< 16 per wide node: child[8], count[8]
    std::vector<uint32_t> packet_slots; ///< each packet's first leaf slot
    std::vector<uint8_t> packet_lanes;  ///< and its lane count
    uint32_t node_base = 0, packet_base = 0; ///< where they land in the whole tree
    size_t node_count() const { return sources.size() / 8; }
    size_t held_bytes() const {
        return 4 * (sources.capacity() + fields.capacity() + packet_slots.capacity()) + packet_lanes.capacity();
    }
};

/// Bytes of plain vectors (the collapse's pieces, a task's plan) in the
/// build's memory meter, when one is installed, while they live: set() says
/// how many there are now.
class MeteredBytes {
public:
    explicit MeteredBytes(MemoryMeter *meter) : meter_(meter) {}
    ~MeteredBytes() { set(0); }
    MeteredBytes(const MeteredBytes &) = delete;
    MeteredBytes &operator=(const MeteredBytes &) = delete;
    void set(size_t bytes) {
        if (meter_) meter_->add(int64_t(bytes) - bytes_);
        bytes_ = int64_t(bytes);
    }

private:
    MemoryMeter *meter_;
    int64_t bytes_ = 0;
};

/// testing::largest_plan_bytes raised to `bytes` where they are more.
void note_plan_bytes(uint64_t bytes) {
    std::atomic<uint64_t> &largest = testing::largest_plan_bytes;
    uint64_t seen = largest.load(std::memory_order_relaxed);
    while (bytes > seen && !largest.compare_exchange_weak(seen, bytes, std::memory_order_relaxed)) {
    }
}

/// An inner child handed to a task: its child field holds the task's index
/// with this bit until the pieces are placed.
constexpr uint32_t kTaskBit = 0x80000000u;
/// Inner children with fewer primitives than this are collapsed by a task
/// of their own; the top of the tree, above them, by the calling thread.
constexpr uint32_t kTaskPrimitives = 1u << 12;

/// The emitted binary nodes as the collapse reads them: with packets, the
/// sweep's packet leaves and slot ranges.
struct EmittedSource : EmittedShape {
    const PacketLeafSweep *sweep; ///< with packets only

    bool is_leaf(uint32_t i) const { return sweep ? sweep->packet_leaf[i] != 0 : nodes[i].is_leaf(); }
    /// For the plan of a task's subtree (bvh/collapse_plan.h): a leaf of the
    /// binary layout, and a hint that node i is read soon.
    bool is_binary_leaf(uint32_t i) const { return nodes[i].is_leaf(); }
    void prefetch(uint32_t i) const {
        __builtin_prefetch(&nodes[i]);
        if (sweep) __builtin_prefetch(&sweep->range_count[i]);
    }
    /// The primitives below, kNoRange when unknown (no packets).
    uint32_t prims(uint32_t i) const { return sweep ? sweep->range_count[i] : kNoRange; }
    /// A leaf child's slot range: the binary leaf's, or the small subtree's.
    void leaf_range(uint32_t i, uint32_t &first, uint32_t &count) const {
        if (nodes[i].is_leaf()) {
            first = nodes[i].first;
            count = nodes[i].count;
        } else {
            first = sweep->range_first[i];
            count = sweep->range_count[i];
        }
    }
    /// What the slot's `sources` entry holds, and the box behind it.
    uint32_t source(uint32_t i) const { return i; }
    const Box &box(uint32_t source) const { return nodes[source].box; }
};

/// A builder's tree before its binary layout (bvh/chosen_tree.h), with
/// packets: the emitted leaves and the sweep's packet leaves are leaves.
struct ChosenSource {
    using Handle = Place;
    const ChosenTree &tree;
    EmittedOrder order; ///< written as the collapse meets the nodes

    bool is_leaf(Place p) const { return tree.is_packet_leaf(p.id); }
    /// For the plan of a task's subtree (bvh/collapse_plan.h): a leaf of the
    /// binary layout, and a hint that the node's box, counts and children
    /// are read soon.
    bool is_binary_leaf(Place p) const { return tree.is_leaf(p.id); }
    void prefetch(Place p) const {
        __builtin_prefetch(&tree.boxes[p.id]);
        if (p.id >= tree.n) {
            __builtin_prefetch(&tree.counts[p.id - tree.n]);
            __builtin_prefetch(&tree.children[2 * size_t(p.id - tree.n)]);
        }
    }
    /// The builder's ids are in merge order, so a node's children lie
    /// anywhere: their ids are asked for as soon as the node joins a wide
    /// node, before the areas decide whether it is opened.
    void prefetch_children(Place p) const {
        if (p.id >= tree.n) __builtin_prefetch(&tree.children[2 * size_t(p.id - tree.n)]);
    }
    float extent_scale; ///< extent_scale_of() the root's box, as EmittedShape's
    float half_area(Place p) const { return scaled_half_area(tree.boxes[p.id], extent_scale); }
    /// Called once for each node the collapse opens: the emitted layout's
    /// inner nodes above the packet leaves.
    void children(Place p, Place &l, Place &r) const { emit_inner(tree, order, p, l, r); }
    uint32_t prims(Place p) const { return tree.prims(p.id); }
    /// Called once for each packet leaf.
    void leaf_range(Place p, uint32_t &first, uint32_t &count) const {
        first = p.slot;
        count = tree.prims(p.id);
        emit_packet_leaf(tree, order, p);
    }
    uint32_t source(Place p) const { return p.id; }
    const Box &box(uint32_t source) const { return tree.boxes[source]; }
};

/// Collapsing: a wide node starts as its binary node's two children and
/// opens the child of largest area until it has eight children or only
/// leaves (binary leaves, or packet leaves with packets); with packets and
/// CollapseRule::Planned, the subtrees that tasks take follow their SAH plan
/// instead (bvh/collapse_plan.h).
template <class Source> class Collapser {
public:
    using Handle = typename Source::Handle;
    Collapser(const Source &source, bool packets) : source_(source), packets_(packets) {}

    /// The wide nodes from binary node `root` down into `out`; with `tasks`,
    /// inner children of fewer than kTaskPrimitives primitives are left to
    /// tasks (appended to it) instead. With `plan` (a task's subtree, with
    /// packets), the wide nodes and packet leaves are the plan's
    /// (bvh/collapse_plan.h) instead of open_largest()'s.
    void run(Handle root, CollapsePiece &out, std::vector<Handle> *tasks, SubtreePlan<Source> *plan = nullptr) const {
        struct Work {
            Handle binary;
            uint32_t wide;
            uint32_t planned; ///< the node's index in `plan`
        };
        std::vector<Work> work{{root, 0u, plan ? plan->plan(root) : 0u}};
        uint32_t next = 1, next_packet = 0;
        // A task's piece sized ahead from its primitives (about 0.04 wide
        // nodes and 0.3 packets a primitive on the shared scenes), so that
        // its arrays do not grow by copies in fresh heap pages
        // (docs/PERFORMANCE.md, change 144); a piece that needs more grows
        // as before.
        if (!tasks && packets_ && source_.prims(root) != kNoRange) {
            const size_t prims = source_.prims(root);
            out.sources.reserve(8 * (prims / 16 + 1));
            out.fields.reserve(16 * (prims / 16 + 1));
            out.packet_slots.reserve(prims / 3 + 1);
            out.packet_lanes.reserve(prims / 3 + 1);
        }
        while (!work.empty()) {
            const Work w = work.back();
            work.pop_back();
            Handle kids[8];
            bool leaf[8];
            uint32_t planned[8];
            int m;
            if (plan) {
                m = plan->open(w.planned, planned, leaf);
                for (int k = 0; k < m; ++k) kids[k] = plan->handle(planned[k]);
            } else {
                m = open_largest<8>(source_, w.binary, kids);
                for (int k = 0; k < m; ++k) leaf[k] = source_.is_leaf(kids[k]);
            }
            // Nodes are numbered when their parent meets them, so this one's
            // entries may exist already.
            if (out.sources.size() < 8 * size_t(next)) {
                out.sources.resize(8 * size_t(next), Wide8Node::kEmptyChild);
                out.fields.resize(16 * size_t(next), 0);
            }
            uint32_t *src = &out.sources[8 * size_t(w.wide)];
            uint32_t *child = &out.fields[16 * size_t(w.wide)];
            uint32_t *count = child + 8;
            uint32_t wide_kid[8];
            for (int k = 0; k < 8; ++k) {
                wide_kid[k] = Wide8Node::kEmptyChild;
                child[k] = Wide8Node::kEmptyChild;
                count[k] = 0;
                if (k >= m) continue;
                src[k] = source_.source(kids[k]);
                if (!leaf[k]) {
                    const uint32_t prims = source_.prims(kids[k]);
                    if (tasks && prims < kTaskPrimitives) {
                        child[k] = kTaskBit | uint32_t(tasks->size());
                        tasks->push_back(kids[k]);
                    } else {
                        wide_kid[k] = next++;
                        child[k] = wide_kid[k];
                    }
                    continue;
                }
                uint32_t first, c;
                source_.leaf_range(kids[k], first, c);
                if (packets_) {
                    child[k] = next_packet;
                    count[k] = packets_for(c);
                    for (uint32_t j = 0; j < count[k]; ++j) {
                        out.packet_slots.push_back(first + 4 * j);
                        out.packet_lanes.push_back(uint8_t(c - 4 * j < 4 ? c - 4 * j : 4));
                    }
                    next_packet += count[k];
                } else {
                    child[k] = first;
                    count[k] = c;
                }
            }
            for (int k = m; k-- > 0;)
                if (wide_kid[k] != Wide8Node::kEmptyChild)
                    work.push_back(Work{kids[k], wide_kid[k], plan ? planned[k] : 0u});
        }
    }

private:
    const Source &source_;
    bool packets_;
};

} // namespace

template <class Source>
void Wide8Bvh::build_from(const Source &source, typename Source::Handle root, const Geometry *triangles,
                          const uint32_t *prim_ids, Scheduler &scheduler, CollapseRule rule,
                          const std::function<void()> &shape_done, const std::function<void()> &source_done) {
    using Handle = typename Source::Handle;
    const bool packets = triangles != nullptr;

    // Pass 1: the collapse, with packets in pieces: the top of the tree on
    // this thread, the subtrees below it by tasks, each numbered from 0, then
    // placed one after another (top first, tasks in the order the top met
    // them), so the numbering is the same at any thread count.
    const Collapser<Source> collapser(source, packets);
    std::vector<Handle> tasks;
    std::vector<CollapsePiece> pieces(1);
    collapser.run(root, pieces[0], packets ? &tasks : nullptr);
    pieces.resize(1 + tasks.size());
    scheduler.parallel_for(0, tasks.size(), 1, [&](size_t b, size_t e) {
        SubtreePlan<Source> plan(source); // its arrays serve each task in turn
        SubtreePlan<Source> *const planned = rule == CollapseRule::Planned ? &plan : nullptr;
        MeteredBytes plan_bytes(MemoryMeter::current()); // the build's, on any thread (Scheduler)
        for (size_t t = b; t < e; ++t) {
            collapser.run(tasks[t], pieces[1 + t], nullptr, planned);
            plan_bytes.set(plan.held_bytes());
            note_plan_bytes(plan.held_bytes());
        }
    });
    // Only the boxes of the source are read from here on: a caller may free
    // the rest before the arrays below are allocated (docs/PERFORMANCE.md,
    // row 210).
    if (shape_done) shape_done();
    uint32_t next = 0, next_packet = 0;
    for (CollapsePiece &piece : pieces) {
        piece.node_base = next;
        piece.packet_base = next_packet;
        next += uint32_t(piece.node_count());
        next_packet += uint32_t(piece.packet_slots.size());
    }
    MeteredBytes piece_bytes(MemoryMeter::current());
    size_t held = 0;
    for (const CollapsePiece &piece : pieces) held += piece.held_bytes();
    piece_bytes.set(held);
    Array<uint32_t> sources(8 * size_t(next));
    Array<uint32_t> fields(16 * size_t(next)); // child[8], count[8] per wide node
    Array<uint32_t> packet_slots(next_packet);
    Array<uint8_t> packet_lanes(next_packet);
    scheduler.parallel_for(0, pieces.size(), 1, [&](size_t b, size_t e) {
        for (size_t p = b; p < e; ++p) {
            const CollapsePiece &piece = pieces[p];
            // data() + offset, not &array[offset]: the packet arrays are
            // empty without packets.
            std::copy(piece.sources.begin(), piece.sources.end(), sources.data() + 8 * size_t(piece.node_base));
            std::copy(piece.packet_slots.begin(), piece.packet_slots.end(), packet_slots.data() + piece.packet_base);
            std::copy(piece.packet_lanes.begin(), piece.packet_lanes.end(), packet_lanes.data() + piece.packet_base);
            for (size_t w = 0; w < piece.node_count(); ++w) {
                const uint32_t *from = &piece.fields[16 * w];
                uint32_t *to = &fields[16 * (piece.node_base + w)];
                for (int k = 0; k < 8; ++k) {
                    uint32_t c = from[k];
                    if (c != Wide8Node::kEmptyChild && from[8 + k] == 0)
                        c = c & kTaskBit ? pieces[1 + (c & ~kTaskBit)].node_base : c + piece.node_base;
                    else if (c != Wide8Node::kEmptyChild && packets)
                        c += piece.packet_base;
                    to[k] = c;
                    to[8 + k] = from[8 + k];
                }
            }
        }
    });
    std::vector<CollapsePiece>().swap(pieces);
    piece_bytes.set(0);

    // Pass 2, in parallel: nodes and packets.
    constexpr size_t kAhead = 8;
    Array<Wide8Node> nodes(next);
    Array<uint32_t> packet_owner(packets ? next_packet : 0);
    scheduler.parallel_for(0, next, 1u << 10, [&](size_t b, size_t e) {
        for (size_t w = b; w < e; ++w) {
            Wide8Node &node = nodes[w];
            // The binary nodes behind the slots lie scattered: asked for a
            // few wide nodes ahead.
            if (w + kAhead < e)
                for (int k = 0; k < 8; ++k) {
                    const uint32_t s = sources[8 * (w + kAhead) + k];
                    if (s != Wide8Node::kEmptyChild) __builtin_prefetch(&source.box(s));
                }
            for (int k = 0; k < 8; ++k) {
                const uint32_t s = sources[8 * w + k];
                if (s == Wide8Node::kEmptyChild) {
                    set_empty_slot(node, k);
                    continue;
                }
                write_slot_box(node, k, source.box(s));
                node.child[k] = fields[16 * w + k];
                node.count[k] = fields[16 * w + 8 + k];
                if (packets)
                    for (uint32_t j = 0; j < node.count[k]; ++j) packet_owner[node.child[k] + j] = uint32_t(8 * w + k);
            }
        }
    });
    Array<uint32_t>().swap(fields);
    // The source's boxes are read no more: a caller may free them before
    // the packets are allocated.
    if (source_done) source_done();
    // Pass 3, in parallel: the packets, in packet order; the triangles they
    // gather are asked for ahead (two steps: the index, then the vertices).
    Array<TrianglePacket> packet_array(packets ? next_packet : 0);
    scheduler.parallel_for(0, next_packet, 1u << 12, [&](size_t b, size_t e) {
        for (size_t p = b; p < e; ++p) {
            if (p + 16 < e)
                for (uint32_t j = 0; j < packet_lanes[p + 16]; ++j)
                    triangles->prefetch_indices(prim_ids[packet_slots[p + 16] + j]);
            if (p + 8 < e)
                for (uint32_t j = 0; j < packet_lanes[p + 8]; ++j)
                    triangles->prefetch_vertices(prim_ids[packet_slots[p + 8] + j]);
            fill_packet(packet_array[p], *triangles, prim_ids, packet_slots[p], packet_lanes[p]);
        }
    });
    Array<uint32_t>().swap(packet_slots);
    Array<uint8_t>().swap(packet_lanes);
    nodes_ = std::move(nodes);
    sources_ = std::move(sources);
    packets_ = std::move(packet_array);
    packet_owner_ = std::move(packet_owner);
    node_count_ = next;
    built_ = true;
    update_bounds();
}

void Wide8Bvh::build(const Bvh &bvh, const Geometry *triangles, Scheduler &scheduler, CollapseRule rule) {
    if (bvh.empty()) {
        clear();
        built_ = true;
        return;
    }
    std::unique_ptr<PacketLeafSweep> sweep;
    if (triangles) sweep.reset(new PacketLeafSweep(bvh, scheduler));
    const EmittedSource source{{bvh.nodes.data(), extent_scale_of(bvh.nodes[0].box)}, sweep.get()};
    build_from(source, 0u, triangles, bvh.prim_ids.data(), scheduler, rule, nullptr, [&] { sweep.reset(); });
}

void Wide8Bvh::build(const ChosenTree &tree, const Geometry &triangles, const EmittedOrder &order,
                     Scheduler &scheduler, CollapseRule rule, const std::function<void()> &shape_done,
                     const std::function<void()> &tree_done) {
    const ChosenSource source{tree, order, extent_scale_of(tree.boxes[tree.root])};
    build_from(source, Place{tree.root, 0, 0, 1}, &triangles, order.prim_ids, scheduler, rule, shape_done,
               tree_done);
    // Its sources are the builder's ids, which mean nothing once the build
    // is over: the handle keeps the binary tree's shape instead.
    release_sources();
}

void Wide8Bvh::refit(const Bvh &bvh, const Geometry &geometry, Scheduler &scheduler) {
    const Node *bnodes = bvh.nodes.data();
    Wide8Node *nodes = nodes_.data();
    const uint32_t *sources = sources_.data();
    scheduler.parallel_for(0, node_count_, 1u << 10, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i)
            for (int k = 0; k < 8; ++k)
                if (sources[8 * i + k] != Wide8Node::kEmptyChild) write_slot_box(nodes[i], k, bnodes[sources[8 * i + k]].box);
    });
    update_bounds();
    refill_packets(geometry, scheduler);
}

void Wide8Bvh::refill_packets(const Geometry &geometry, Scheduler &scheduler) {
    TrianglePacket *packets = packets_.data();
    scheduler.parallel_for(0, packets_.size(), 1u << 12, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) refill_packet(packets[i], geometry);
    });
}

void Wide8Bvh::refit_from_packets(const Geometry &geometry, Scheduler &scheduler) {
    Wide8Node *nodes = nodes_.data();
    TrianglePacket *packets = packets_.data();
    const uint32_t *owner = packet_owner_.data();
    const size_t count = packets_.size();
    // In packet order (the collapse's depth-first order, not the nodes'):
    // each packet refilled, and its leaf child boxed while the vertices are
    // at hand. A chunk boxes the leaves that start in it, to their ends.
    scheduler.parallel_for(0, count, 1u << 12, [&](size_t b, size_t e) {
        size_t p = b;
        while (p < count && p > 0 && owner[p] == owner[p - 1]) ++p; // the previous chunk's leaf
        while (p < e) {
            const uint32_t slot = owner[p];
            Box box = Box::empty();
            for (; p < count && owner[p] == slot; ++p) {
                // Random reads: asked for ahead (the index, then the vertices).
                if (p + 8 < count)
                    for (int lane = 0; lane < 4; ++lane) geometry.prefetch_indices(packets[p + 8].prim[lane]);
                if (p + 4 < count)
                    for (int lane = 0; lane < 4; ++lane) geometry.prefetch_vertices(packets[p + 4].prim[lane]);
                TrianglePacket &packet = packets[p];
                refill_packet(packet, geometry);
                for (int lane = 0; lane < 4; ++lane)
                    for (int i = 0; i < 3; ++i) {
                        const float v[3] = {packet.v[i][0][lane], packet.v[i][1][lane], packet.v[i][2][lane]};
                        box.extend(v);
                    }
            }
            write_slot_box(nodes[slot >> 3], int(slot & 7), box);
        }
    });
    // Children are numbered after their parents, so a reverse sweep is
    // bottom-up; an unused slot's empty box adds nothing to a union.
    for (size_t w = node_count_; w-- > 0;)
        for (int k = 0; k < 8; ++k) {
            if (nodes[w].count[k] != 0 || nodes[w].child[k] == Wide8Node::kEmptyChild) continue;
            const Wide8Node &c = nodes[nodes[w].child[k]];
            for (int a = 0; a < 3; ++a) {
                float lo = c.box[2 * a][0], hi = c.box[2 * a + 1][0];
                for (int j = 1; j < 8; ++j) {
                    lo = std::min(lo, c.box[2 * a][j]);
                    hi = std::max(hi, c.box[2 * a + 1][j]);
                }
                nodes[w].box[2 * a][k] = lo;
                nodes[w].box[2 * a + 1][k] = hi;
            }
        }
    update_bounds();
}

void Wide8Bvh::index_packets(size_t primitive_count, Array<uint32_t> &out, Scheduler &scheduler) const {
    out.resize(primitive_count);
    uint32_t *where = out.data();
    const TrianglePacket *packets = packets_.data();
    // A primitive sits in one packet (spare lanes repeat that packet's last),
    // so tasks never write the same entry.
    scheduler.parallel_for(0, packets_.size(), 1u << 12, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i)
            for (uint32_t lane = 0; lane < 4; ++lane)
                if (packets[i].prim[lane] < primitive_count) where[packets[i].prim[lane]] = uint32_t(4 * i + lane);
    });
}

} // namespace aacbvh
