// The 8-wide layout's collapse of one small subtree, chosen by the SAH
// (bvh/wide8_bvh.cpp): which binary nodes become each wide node's children,
// and which small subtrees become one packet leaf, decided for the whole
// subtree at once by a dynamic programme over its binary nodes (as Ylitie,
// Karras and Laine, "Efficient incoherent ray traversal on GPUs through
// compressed wide BVHs", HPG 2017, collapse whole trees), instead of opening
// the child of largest area until eight children (bvh/wide_collapse.h) over
// packet leaves chosen beforehand, node by node (bvh/packet_leaf_sweep.h).
//
// The collapse plans only the subtrees of fewer than kTaskPrimitives
// primitives that its tasks take; the top keeps the opening of the largest
// child. Planned from the root, the trees needed less work for closest hits
// but more for the occlusion rays of the game levels, whose large occluders
// the greedy top keeps as leaf children of the first wide nodes
// (docs/PERFORMANCE.md, rows 208 and 211). AAC-Fast's trees are not planned
// (CollapseRule, bvh/wide8_bvh.h): the plan made AAC-HQ's builds about
// 6.7 % longer (the dragon's 217 -> 230 ms, one thread; row 263).
//
// The model: a wide node costs its half area (kWideNodeCost), a packet leaf
// its half area times kPacketCost per packet (bvh/packet_leaf_sweep.h).
// For a binary node x and k = 1..8, S(x, k) is the least cost of x's
// subtree spread over at most k child slots of one wide node:
//   S(x, 1) = min(one packet leaf, where x may be one; A(x) + D(x, 8)),
//   D(x, k) = min over j in 1..k-1 of S(left, j) + S(right, k - j),
//   S(x, k) = min(S(x, 1), D(x, k)) for k >= 2.
// Any subtree of at most kMaxPacketLeaf primitives whose slots are one range
// may be one packet leaf; a binary leaf, or a subtree of at most
// kWholePrimitives primitives (one packet: opening it can only add packets),
// is one at any k. The subtree's root is a wide node whose children are
// D(root, 8)'s. Ties go to the first j and to S(x, 1). Every step is a
// float addition or comparison in a fixed order, so the plan is the same on
// every CPU and at any thread count, and the same from both sources of
// bvh/wide8_bvh.cpp (their areas and counts agree).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "bvh/packet_leaf_sweep.h"
#include "bvh/wide_collapse.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace aacbvh {

/// A wide node's cost in the collapse's model (packet leaves cost
/// kPacketCost a packet, relative to it).
constexpr float kWideNodeCost = 1.0f;

/// The plan of one subtree read through a Source (bvh/wide8_bvh.cpp):
/// Handle, is_binary_leaf(h) (a leaf of the binary layout), half_area(h),
/// children(h, l, r), prims(h) (kNoRange where the subtree's slots are not
/// one range: never one packet leaf) and prefetch(h) (a hint that h's
/// fields are read soon). Reusable: plan() replaces the previous plan, and
/// its arrays keep their capacity.
template <class Source> class SubtreePlan {
public:
    using Handle = typename Source::Handle;
    /// Subtrees of at most this many primitives are one packet leaf, never
    /// opened (one packet).
    static constexpr uint32_t kWholePrimitives = 4;

    explicit SubtreePlan(const Source &source) : source_(source) {}

    /// Plans the subtree of inner node `root` (not a binary leaf); returns
    /// root's index for open(). Throws std::bad_alloc.
    uint32_t plan(Handle root) {
        gather(root);
        cost_.resize(nodes_.size());
        // Breadth first: children after their parents, so a backward sweep
        // meets them first.
        for (size_t i = nodes_.size(); i-- > 0;) solve(uint32_t(i));
        return 0;
    }

    Handle handle(uint32_t node) const { return nodes_[node].h; }

    /// The bytes its arrays hold (their capacity), for the build's memory
    /// meter.
    size_t held_bytes() const { return nodes_.capacity() * sizeof(Node) + cost_.capacity() * sizeof(Costs); }

    /// The children of the wide node over planned inner node `node` (0 from
    /// plan(), or an inner child from open()), with whether each is one
    /// packet leaf; in order of surface area, largest first, equals in
    /// left-to-right order, as open_largest() orders its children (the
    /// traversals read that order). Returns the count.
    int open(uint32_t node, uint32_t (&kids)[8], bool (&leaf)[8]) const {
        int m = 0;
        const Node &n = nodes_[node];
        const uint32_t j = share(n.word, 8);
        assign(n.left, j, kids, m);
        assign(n.left + 1, 8 - j, kids, m);
        float area[8];
        for (int k = 0; k < m; ++k) area[k] = nodes_[kids[k]].area;
        sort_largest_first(m, kids, area);
        for (int k = 0; k < m; ++k) leaf[k] = (nodes_[kids[k]].word & kLeafBit) != 0;
        return m;
    }

private:
    /// A node's choices: for k = 2..8, the left child's share j of k slots
    /// in D(x, k) (3 bits at 3 (k - 2)) and whether S(x, k) is S(x, 1)
    /// (bit 21 + k - 2); kLeafBit: S(x, 1) is one packet leaf; kWholeBit:
    /// the node is one packet leaf at any k (not gathered below).
    static constexpr uint32_t kLeafBit = 1u << 28, kWholeBit = 1u << 29;
    /// No split: what a share of slots beyond a subtree's reach costs.
    static constexpr float kNoSplit = __builtin_inff();
    static uint32_t share(uint32_t w, int k) { return (w >> (3 * (k - 2))) & 7u; }
    static bool takes_one(uint32_t w, int k) { return ((w >> (21 + k - 2)) & 1u) != 0; }

    struct Node {
        Handle h;
        float area;
        uint32_t prims;
        uint32_t left; ///< the children's indices: left, left + 1 (inner nodes)
        uint32_t word;
    };
    /// S(x, k) at s[k - 1].
    struct Costs {
        float s[8];
    };

    /// The subtree's nodes breadth first, each inner node's children side
    /// by side; a node's fields are asked for when it is appended, and read
    /// when the queue reaches it (the builder's ids lie scattered).
    void gather(Handle root) {
        nodes_.clear();
        append(root);
        for (size_t i = 0; i < nodes_.size(); ++i) {
            Node &n = nodes_[i];
            n.area = source_.half_area(n.h);
            n.prims = source_.prims(n.h);
            const bool whole =
                i != 0 && (source_.is_binary_leaf(n.h) || (n.prims != kNoRange && n.prims <= kWholePrimitives));
            if (whole) {
                n.word = kWholeBit | kLeafBit;
                continue;
            }
            Handle l, r;
            source_.children(n.h, l, r);
            nodes_[i].left = uint32_t(nodes_.size()); // n may move as the queue grows
            append(l);
            append(r);
        }
    }

    void append(Handle h) {
        source_.prefetch(h);
        nodes_.push_back(Node{h, 0.0f, 0, 0, 0});
    }

    void solve(uint32_t i) {
        Node &n = nodes_[i];
        Costs &c = cost_[i];
        if (n.word & kWholeBit) {
            const float v = packet_leaf_cost(n.area, n.prims);
            for (float &s : c.s) s = v;
            return;
        }
        uint32_t w = 0;
        float d[8]; // D(x, k) at d[k - 2]
        uint32_t j_best[8];
        best_splits(cost_[n.left], cost_[n.left + 1], d, j_best);
        for (int k = 2; k <= 8; ++k) w |= j_best[k - 2] << (3 * (k - 2));
        float one = n.area * kWideNodeCost + d[6];
        if (n.prims != kNoRange && n.prims <= kMaxPacketLeaf) {
            const float as_leaf = packet_leaf_cost(n.area, n.prims);
            if (as_leaf <= one) {
                one = as_leaf;
                w |= kLeafBit;
            }
        }
        c.s[0] = one;
        for (int k = 2; k <= 8; ++k) {
            const bool take_one = one <= d[k - 2];
            c.s[k - 1] = take_one ? one : d[k - 2];
            w |= uint32_t(take_one) << (21 + k - 2);
        }
        n.word = w;
    }

    /// D(x, k) for k = 2..8 at d[k - 2] from the children's costs, and the
    /// left share j that reaches it (the first j of equal sums) at j[k - 2]:
    /// for each j in turn, every k's sum S(left, j) + S(right, k - j) at
    /// once (SSE2: lanes of k; the same additions and comparisons as one k
    /// at a time, so the same answer).
    static void best_splits(const Costs &L, const Costs &R, float d[8], uint32_t j[8]) {
        // R's costs behind seven +inf: from (padded + 8 - a), lane m holds
        // S(right, m - a + 1), or +inf where m < a (no such k).
        alignas(16) float padded[16];
        for (int m = 0; m < 8; ++m) {
            padded[m] = kNoSplit;
            padded[8 + m] = R.s[m];
        }
#if defined(__SSE2__)
        __m128 best_lo = _mm_add_ps(_mm_set1_ps(L.s[0]), _mm_load_ps(padded + 8));
        __m128 best_hi = _mm_add_ps(_mm_set1_ps(L.s[0]), _mm_load_ps(padded + 12));
        __m128i share_lo = _mm_set1_epi32(1), share_hi = share_lo;
        for (int a = 1; a < 7; ++a) {
            const __m128 l = _mm_set1_ps(L.s[a]);
            const __m128 v_lo = _mm_add_ps(l, _mm_loadu_ps(padded + 8 - a));
            const __m128 v_hi = _mm_add_ps(l, _mm_loadu_ps(padded + 12 - a));
            const __m128 lt_lo = _mm_cmplt_ps(v_lo, best_lo), lt_hi = _mm_cmplt_ps(v_hi, best_hi);
            best_lo = _mm_or_ps(_mm_and_ps(lt_lo, v_lo), _mm_andnot_ps(lt_lo, best_lo));
            best_hi = _mm_or_ps(_mm_and_ps(lt_hi, v_hi), _mm_andnot_ps(lt_hi, best_hi));
            const __m128i jj = _mm_set1_epi32(a + 1);
            share_lo = _mm_or_si128(_mm_and_si128(_mm_castps_si128(lt_lo), jj),
                                    _mm_andnot_si128(_mm_castps_si128(lt_lo), share_lo));
            share_hi = _mm_or_si128(_mm_and_si128(_mm_castps_si128(lt_hi), jj),
                                    _mm_andnot_si128(_mm_castps_si128(lt_hi), share_hi));
        }
        _mm_storeu_ps(d, best_lo);
        _mm_storeu_ps(d + 4, best_hi);
        _mm_storeu_si128(reinterpret_cast<__m128i *>(j), share_lo);
        _mm_storeu_si128(reinterpret_cast<__m128i *>(j + 4), share_hi);
#else
        for (int m = 0; m < 8; ++m) {
            d[m] = L.s[0] + padded[8 + m];
            j[m] = 1;
        }
        for (int a = 1; a < 7; ++a)
            for (int m = 0; m < 8; ++m) {
                const float v = L.s[a] + padded[8 + m - a];
                j[m] = v < d[m] ? uint32_t(a + 1) : j[m];
                d[m] = v < d[m] ? v : d[m];
            }
#endif
    }

    /// Spreads `k` slots over the subtree of planned node `x`. A child it
    /// takes whole is one packet leaf where its kLeafBit says so.
    void assign(uint32_t x, uint32_t k, uint32_t (&kids)[8], int &m) const {
        const Node &n = nodes_[x];
        if (k == 1 || (n.word & kWholeBit) != 0 || takes_one(n.word, int(k))) {
            kids[m++] = x;
            return;
        }
        const uint32_t j = share(n.word, int(k));
        assign(n.left, j, kids, m);
        assign(n.left + 1, k - j, kids, m);
    }

    const Source &source_;
    std::vector<Node> nodes_;
    std::vector<Costs> cost_;
};

} // namespace aacbvh
