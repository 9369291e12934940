// The 8-wide traversal, included once by each kernel's file
// (wide8_kernel_<isa>.cpp) inside that kernel's own namespace and target
// region, after the file has defined its node and packet tests:
//   struct NodeRay;     NodeRay make_node_ray(const aacbvh_ray &);
//     the node test's per-ray rows, the values make_box_ray() gives;
//   template <bool FromZero, bool Keys>
//   unsigned test_children(const Wide8Node &, const NodeRay &, float tmin,
//                          float bound, float t_entry[8]);
//     bit k set when child k may be hit within [tmin, tmax] (a conservative
//     slab test: the binary layout's ray_box_conservative() lane for lane,
//     or, where the window starts at 0 or later (FromZero, the ray's
//     window_from_zero as a constant of the loop), exits widened through
//     kFarScale; trace/ray_box.h), its clipped entry distance in t_entry[k],
//     or with Keys (closest-hit queries) and FromZero its visiting key
//     (child_order_key(), trace/child_order.h: a child holding the origin
//     goes by its exit distance, its key below tmin); `bound` is
//     exit_bound(ray, record) below;
//   int sort_hits(unsigned mask, const float t_entry[8], uint32_t key[8]);
//     the hit lanes' (distance, 7 - lane) keys, ascending (sort_hits_insertion()
//     below, or a sorting network);
//   struct PacketRay;   PacketRay make_packet_ray(const TriangleRay &);
//   unsigned filter_packets(const TrianglePacket *, uint32_t available,
//                           const PacketRay &, PacketEdges &, uint32_t &used);
//     tests the first packet (used = 1) or the first two (used = 2, lanes
//     4-7 the second); bit k set unless the single-precision edge functions
//     of intersect_triangle() prove that lane k misses (they are computed by
//     the same operations, so the lanes it keeps are a superset of the
//     hits); the kept lanes' edge functions are stored in the PacketEdges.
//   bool kPlaneDistances;
//   void plane_distances(const TrianglePacket *, unsigned lanes,
//                        const TriangleRay &, PacketPlanes &);
//     where true, the PlaneDistance (trace/triangle_intersect.h) of every
//     lane of each packet that `lanes` (as filter_packets() returned it)
//     keeps a lane of, made as triangle_distance_of() makes it.
// The lanes a packet keeps are then finished by finish_triangle_edges(),
// which decides as intersect_triangle() would on the same values, so every
// kernel reports exactly the hits of the binary traversal.
// No lambdas here: a target region does not reach into them.

/// What a node test compares the children's exit distances with:
/// exit_reach(tmax) where the window starts at 0 or later (the exits are
/// widened through inv_far; the record keeps it beside tmax), else tmax (the
/// exits widened afterwards). It changes only with tmax, so traverse() keeps
/// it between leaves.
template <bool AnyHit> inline float exit_bound(const NodeRay &r, const HitRecord<AnyHit> &best) {
    return r.window_from_zero ? best.reach() : best.tmax;
}

/// A child (node index, or leaf: first packet or slot, and count) with its
/// entry distance.
struct Entry {
    uint32_t child;
    uint32_t count;
    float t;
};

using EntryStack = SpillStack<Entry, 256>;
/// The most entries one node pushes: its children but the one visited next.
constexpr size_t kMostPushes = 7;

/// A key whose unsigned order is the order of t (sign-magnitude flipped to
/// two's complement; the negative keys of children holding the origin,
/// trace/child_order.h, included), its low three bits cleared for 7 - lane:
/// of equal distances the higher lane, the smaller box, comes first (lanes
/// hold the children largest first, bvh/wide_collapse.h). Only the visiting
/// order depends on it; pruning uses the exact t (or, for a child holding
/// the origin, its key, below tmin: never pruned, as tmin would not be).
inline uint32_t order_key8(float t) {
    uint32_t u;
    std::memcpy(&u, &t, sizeof u);
    u ^= (u >> 31) != 0 ? 0xFFFFFFFFu : 0x80000000u;
    return u & ~7u;
}

/// Asks for a pushed child's first cache lines (an inner node's boxes, or a
/// packet leaf's first packet) ahead of its visit.
inline void prefetch_child(const Wide8Node *nodes, const TrianglePacket *packets, uint32_t child, uint32_t count) {
    const char *p = count == 0 ? reinterpret_cast<const char *>(nodes + child)
                               : reinterpret_cast<const char *>(packets + child);
    __builtin_prefetch(p);
    __builtin_prefetch(p + 64);
    __builtin_prefetch(p + 128);
}

/// The hit lanes of `mask` as (distance, 7 - lane) keys (order_key8), sorted
/// ascending into key[0, n); returns n. Insertion sort: few children are
/// hit. The kernels whose ISA has a faster way define sort_hits() with it.
inline int sort_hits_insertion(unsigned mask, const float t_entry[8], uint32_t key[8]) {
    int n = 0;
    do {
        const unsigned k = unsigned(__builtin_ctz(mask));
        mask &= mask - 1;
        const uint32_t kk = order_key8(t_entry[k]) | (7u - k);
        int i = n++;
        while (i > 0 && key[i - 1] > kk) {
            key[i] = key[i - 1];
            --i;
        }
        key[i] = kk;
    } while (mask != 0);
    return n;
}

/// The plane distances of one or two packets' lanes (lanes 4-7: the
/// second), as plane_distances() makes them.
struct alignas(32) PacketPlanes {
    double plane[8];
    unsigned inside; ///< bit k: lane k's plane point lies in its triangle's box
    PlaneDistance at(unsigned k) const { return PlaneDistance{plane[k], ((inside >> k) & 1u) != 0}; }
};

/// Tests a packet leaf's lanes; true when the query is done (any hit).
/// filter_packets() tests one packet, or two at once where the kernel's
/// registers hold eight lanes (it says how many it took). Where the kernel
/// makes the kept lanes' plane distances for a whole packet at once
/// (kPlaneDistances), the finish takes them instead of making its own.
/// Never inlined: the any-hit walks that inlined it (the single ray's and
/// the AVX2 kernel's runs of eight) ran more instructions and slower than
/// with the call (docs/PERFORMANCE.md, row 257).
template <bool AnyHit>
[[gnu::noinline]] bool test_packets(const TrianglePacket *packets, uint32_t count, const TriangleRay &tray,
                                    const PacketRay &pray, float tmin, HitRecord<AnyHit> &best) {
    for (uint32_t j = 0; j < count;) {
        PacketEdges e;
        uint32_t used;
        unsigned lanes = filter_packets(packets + j, count - j, pray, e, used);
        PacketPlanes planes;
        if (kPlaneDistances && lanes != 0) plane_distances(packets + j, lanes, tray, planes);
        while (lanes != 0) {
            const unsigned lane = unsigned(__builtin_ctz(lanes));
            lanes &= lanes - 1;
            const PacketLane tri{packets + j + (lane >> 2), lane & 3u};
            float t, u, v;
            if (!finish_triangle_edges<kPlaneDistances>(tray, tri, e.eu[lane], e.ev[lane], e.ew[lane], e.mag[lane],
                                                        kPlaneDistances ? planes.at(lane) : PlaneDistance{}, tmin,
                                                        best.tmax, t, u, v))
                continue;
            if (best.offer(t, u, v, tri.packet->prim[tri.k])) return true;
        }
        j += used;
    }
    return false;
}

/// Leaf tests that no packet leaf calls (the slot adapter's stand-in).
struct NoSlots {
    bool intersect(uint32_t, float, float, float &, float &, float &) const { return false; }
};

/// Walks inner nodes from `current` (an inner node) until it holds a leaf:
/// hit children are visited near to far (by their keys, trace/child_order.h:
/// those holding the origin first, by exit), the nearest next, the others pushed
/// farthest first; a node with no hit child pops the next pending entry
/// (HitRecord::pop_next). False when nothing is left to visit. A loop of
/// its own, apart from the leaf tests (calls): pops after a node with no hit
/// child go straight to the next node test. No call inside it either: a
/// node that would push where the stack has no room returns true with
/// `current` still that inner node, and traverse() grows the stack and comes
/// back to test it again (a call in the loop, even a cold one, made the
/// compiler keep the ray's rows in memory: docs/PERFORMANCE.md row 231).
template <bool AnyHit, bool Packets, bool FromZero>
[[gnu::always_inline]] inline bool descend(const Wide8Node *nodes, const TrianglePacket *packets, const NodeRay &r,
                                           float tmin, float bound, const HitRecord<AnyHit> &best, EntryStack &stack,
                                           Entry &current) {
    do {
        const Wide8Node &node = nodes[current.child];
        __builtin_prefetch(node.child); // its own line, read once the mask is known
        alignas(32) float t_entry[8];
        unsigned mask = test_children<FromZero, !AnyHit>(node, r, tmin, bound, t_entry);
        if (mask == 0) {
            if (!best.pop_next(stack, current)) return false;
            continue;
        }
        const unsigned k0 = unsigned(__builtin_ctz(mask));
        mask &= mask - 1;
        if (mask == 0) { // one child: nothing to order or push
            current = Entry{node.child[k0], node.count[k0], t_entry[k0]};
            continue;
        }
        if (!stack.has_room(kMostPushes)) return true; // traverse() grows the stack
        if (AnyHit) { // any hit ends the query: no sorting; the largest box first
            do {
                const unsigned k = unsigned(__builtin_ctz(mask));
                mask &= mask - 1;
                stack.push_within(Entry{node.child[k], node.count[k], t_entry[k]});
            } while (mask != 0);
            current = Entry{node.child[k0], node.count[k0], t_entry[k0]};
            continue;
        }
        const unsigned k1 = unsigned(__builtin_ctz(mask));
        if ((mask & (mask - 1)) == 0) { // two: one comparison
            const bool swap = t_entry[k1] <= t_entry[k0]; // equal: the smaller box (k1)
            const unsigned near = swap ? k1 : k0, far = swap ? k0 : k1;
            stack.push_within(Entry{node.child[far], node.count[far], t_entry[far]});
            if (Packets || node.count[far] == 0) prefetch_child(nodes, packets, node.child[far], node.count[far]);
            current = Entry{node.child[near], node.count[near], t_entry[near]};
            continue;
        }
        // Three or more: (distance, lane) keys in ascending order.
        alignas(32) uint32_t key[8];
        const int n = sort_hits(mask | (1u << k0), t_entry, key);
        for (int i = n; i-- > 1;) {
            const unsigned k = ~key[i] & 7u;
            stack.push_within(Entry{node.child[k], node.count[k], t_entry[k]});
            if (Packets || node.count[k] == 0) prefetch_child(nodes, packets, node.child[k], node.count[k]);
        }
        const unsigned k = ~key[0] & 7u;
        current = Entry{node.child[k], node.count[k], t_entry[k]};
    } while (current.count == 0);
    return true;
}

/// Closest hit (AnyHit false) or any hit of a valid ray over a non-empty
/// wide tree: descend() to each leaf in turn, test it, pop the next pending
/// entry within reach. Always inlined into query(): the ray's rows then stay
/// in registers instead of being passed through memory, and the call goes
/// (docs/PERFORMANCE.md, change 100).
template <bool AnyHit, bool Packets, class Slots>
[[gnu::always_inline]] inline bool traverse(const Wide8Bvh &wide, const uint32_t *prim_ids, const Slots &slots,
                                            const NodeRay &nray, const TriangleRay &tray, const PacketRay &pray,
                                            float tmin, float tmax, aacbvh_hit &hit) {
    const Wide8Node *nodes = wide.nodes();
    const TrianglePacket *packets = wide.packets();
    HitRecord<AnyHit> best(tmax);
    SpillBlock<Entry> spill;
    EntryStack stack(spill);
    Entry current{0u, 0u, tmin}; // the root, an inner node
    float bound = exit_bound(nray, best);
    for (;;) {
        // The window's form is a constant of each inner loop: no test of it
        // at every node.
        if (current.count == 0 &&
            !(nray.window_from_zero
                  ? descend<AnyHit, Packets, true>(nodes, packets, nray, tmin, bound, best, stack, current)
                  : descend<AnyHit, Packets, false>(nodes, packets, nray, tmin, bound, best, stack, current)))
            break;
        if (current.count == 0) { // descend() found no room on the stack for a node's children
            stack.reserve(kMostPushes);
            continue;
        }
        if (Packets ? test_packets<AnyHit>(packets + current.child, current.count, tray, pray, tmin, best)
                    : best.test_leaf(slots, prim_ids, current.child, current.count, tmin))
            break;
        if (!AnyHit) bound = exit_bound(nray, best); // an any-hit query's tmax never changes
        if (!best.pop_next(stack, current)) break;
    }
    if (!AnyHit) write_closest(best.found, best.tmax, best.u, best.v, best.prim, hit);
    return best.found;
}

/// Whether a ray from outside the tree's bounds misses every child of the
/// root: then it is answered before the triangle test's set-up (most camera
/// rays that miss an object: docs/PERFORMANCE.md, row 238). The root's test
/// is traverse()'s first step, the same call on the same values, so the
/// answer is the one traverse() would give. A ray from inside (shadow and
/// bounce rays, views inside a scene) would pass: it pays a compare only.
template <bool AnyHit>
[[gnu::always_inline]] inline bool misses_root(const Wide8Bvh &wide, const NodeRay &nray, const aacbvh_ray &r) {
    if (origin_in_bounds(wide.bounds(), r)) return false;
    const float bound = exit_bound(nray, HitRecord<AnyHit>(r.tmax));
    alignas(32) float t_entry[8];
    return (nray.window_from_zero ? test_children<true, false>(wide.nodes()[0], nray, r.tmin, bound, t_entry)
                                  : test_children<false, false>(wide.nodes()[0], nray, r.tmin, bound, t_entry)) == 0;
}

/// One query. With Counted, leaf tests over slots (triangles referenced, or
/// boxes) are counted into *tests (for the tests of the visiting order); a
/// tree with packet leaves is answered without counting. The same answer.
template <bool AnyHit, bool Counted = false>
bool query(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray, aacbvh_hit &hit,
           uint64_t *tests = nullptr) {
    ScaledRay scaled;
    const aacbvh_ray *traced = traced_ray(ray, scaled);
    if (wide.node_count() == 0 || geometry.kind == GeometryKind::None || traced == nullptr) {
        set_miss(hit);
        return false;
    }
    const aacbvh_ray &r = *traced;
    const uint32_t *prim_ids = bvh.prim_ids.data();
    const NodeRay nray = make_node_ray(r);
    if (misses_root<AnyHit>(wide, nray, r)) {
        set_miss(hit);
        return false;
    }
    auto over_slots = [&](const auto &prims, const TriangleRay &tray) {
        if constexpr (Counted)
            return traverse<AnyHit, false>(wide, prim_ids, count_tests(prims, tests), nray, tray, PacketRay{},
                                           r.tmin, r.tmax, hit);
        else
            return traverse<AnyHit, false>(wide, prim_ids, prims, nray, tray, PacketRay{}, r.tmin, r.tmax, hit);
    };
    // Only box primitives need the box ray (its SSE rows included).
    bool found;
    if (geometry.kind == GeometryKind::Boxes) {
        const BoxRay box_ray = make_box_ray(r.org, r.dir);
        found = over_slots(BoxPrimitives{geometry, prim_ids, box_ray}, TriangleRay{});
    } else {
        const TriangleRay tray = make_triangle_ray(r.org, r.dir);
        if (wide.has_packets())
            found = traverse<AnyHit, true>(wide, prim_ids, NoSlots{}, nray, tray, make_packet_ray(tray), r.tmin,
                                           r.tmax, hit);
        else
            found = over_slots(TrianglePrimitives{geometry, prim_ids, tray}, tray);
    }
    if (!AnyHit) scaled.unscale(hit);
    return found;
}

// The single-ray entries. A kernel compiled with
// AACBVH_WIDE8_SINGLE_RAYS_FROM_AVX2 (the AVX-512 kernel) hands them to the
// AVX2 kernel's code, which ran them faster (docs/PERFORMANCE.md, row 259).
#if AACBVH_WIDE8_SINGLE_RAYS_FROM_AVX2
void intersect_entry(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                     aacbvh_hit &hit) {
    kWide8Avx2.intersect(wide, bvh, geometry, ray, hit);
}

void intersect_counted_entry(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                             aacbvh_hit &hit, TraversalCounters &counters) {
    kWide8Avx2.intersect_counted(wide, bvh, geometry, ray, hit, counters);
}

bool occluded_entry(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray) {
    return kWide8Avx2.occluded(wide, bvh, geometry, ray);
}
#else
void intersect_entry(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                     aacbvh_hit &hit) {
    query<false>(wide, bvh, geometry, ray, hit);
}

/// intersect_entry(), counting primitive tests over slot leaves into
/// counters.primitive_tests.
void intersect_counted_entry(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                             aacbvh_hit &hit, TraversalCounters &counters) {
    query<false, true>(wide, bvh, geometry, ray, hit, &counters.primitive_tests);
}

bool occluded_entry(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray) {
    aacbvh_hit unused;
    return query<true>(wide, bvh, geometry, ray, unused);
}
#endif

#if !AACBVH_WIDE8_PACKETS
/// intersect_entry() over rays[0, count) into hits[0, count), one by one
/// (the AVX2 kernel traces runs of coherent rays together instead).
void intersect_batch_entry(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray *rays,
                           aacbvh_hit *hits, size_t count) {
    for (size_t i = 0; i < count; ++i) intersect_entry(wide, bvh, geometry, rays[i], hits[i]);
}

/// occluded_entry() over rays[0, count) into out[0, count) (1: occluded),
/// one by one.
void occluded_batch_entry(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray *rays,
                          uint8_t *out, size_t count) {
    for (size_t i = 0; i < count; ++i) out[i] = occluded_entry(wide, bvh, geometry, rays[i]) ? 1 : 0;
}
#endif
