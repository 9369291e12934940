// The greedy loop of a small combine (build/aac/cluster_combine.h) in AVX2:
// the live clusters' boxes are six columns of up to kWideSmallCombine lanes,
// and a cluster's distances to all others are one row of a few registers,
// recomputed whenever needed instead of kept in a matrix. Same distances bit
// for bit (the operations of scaled_union_half_area in the same order, no
// FMA) and the same tie rules as the scalar loop, so the same merges.
// Compiled for AVX2 only inside the target region below and called only on
// CPUs that have it (cluster_combine.cpp).
#include "build/aac/combine_small.h"

#include <cfloat>
#include <cmath>
#include <utility>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>

// Everything defined from here to the end of the region is compiled for AVX2;
// the headers above stay baseline code.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif

namespace aacbvh {
namespace {

/// Up to 8 * kVectors clusters, kVectors registers per row.
template <int kVectors> struct SmallCombine {
    static constexpr uint32_t kLanes = 8 * kVectors;
    alignas(32) float col[6][kLanes]; ///< lo x, y, z, hi x, y, z of each live cluster
    alignas(32) float nd[kLanes];     ///< distance to the nearest neighbour
    alignas(32) int32_t nn[kLanes];   ///< the nearest neighbour's slot
    alignas(32) float row[kLanes];    ///< the last row computed
    __m256 scale;

    void set(uint32_t i, const Box &b) {
        for (int k = 0; k < 3; ++k) {
            col[k][i] = b.lo[k];
            col[k + 3][i] = b.hi[k];
        }
    }

    /// A lane past the live slots: the far box, whose distances (FLT_MAX) a
    /// live lane's are never above, nearest distance FLT_MAX, which no live
    /// slot's is above either, and no neighbour (-1: never a slot, and below
    /// every slot), so that no row, closest-pair scan or update need mask it.
    void retire(uint32_t i) {
        set(i, kFarBox);
        nd[i] = FLT_MAX;
        nn[i] = -1;
    }

    void unite_into(Box &out, uint32_t a, uint32_t b) const { out = unite(get(a), get(b)); }

    /// The greedy loop's slot moves after a merge (combine_small_loop.inl).
    void move_slots(uint32_t a, const Box &box, uint32_t b, uint32_t last) {
        if (b != last) {
            set(b, get(last));
            nd[b] = nd[last];
            nn[b] = nn[last];
        }
        retire(last); // no longer live
        set(a, box);
    }

    Box get(uint32_t i) const {
        Box b;
        for (int k = 0; k < 3; ++k) {
            b.lo[k] = col[k][i];
            b.hi[k] = col[k + 3][i];
        }
        return b;
    }
    /// The lanes that the loops below read for `count` live slots.
    static uint32_t padded(uint32_t count) { return 8 * uint32_t(registers(count)); }

    /// Registers that hold slots [0, live): the loops below cover only those
    /// (lanes past live are retired), so a combine's rows shrink with its
    /// live count instead of spanning all kVectors registers (docs/PERFORMANCE.md, change 110).
    static int registers(uint32_t live) { return live <= 8 ? 1 : int((live + 7) / 8); }
    static constexpr int cap(int n) { return n < kVectors ? n : kVectors; }

    /// op.run<K>() with K = registers(live): one instantiation per register
    /// count. (Function objects, not lambdas: the target region does not
    /// reach into lambdas.)
    template <class Op> static auto by_registers(uint32_t live, const Op &op) {
        switch (registers(live)) {
        case 1: return op.template run<cap(1)>();
        case 2: return op.template run<cap(2)>();
        case 3: return op.template run<cap(3)>();
        case 4: return op.template run<cap(4)>();
        case 5: return op.template run<cap(5)>();
        case 6: return op.template run<cap(6)>();
        case 7: return op.template run<cap(7)>();
        default: return op.template run<kVectors>();
        }
    }
    struct ClosestPair {
        const SmallCombine &s;
        template <int K> uint32_t run() const { return s.template closest_pair_in<K>(); }
    };
    struct AllNearest {
        SmallCombine &s;
        uint32_t count;
        template <int K> void run() const { s.template all_nearest_in<K>(count); }
    };
    struct AfterMerge {
        SmallCombine &s;
        uint32_t a, b, last;
        template <int K> uint32_t run() const { return s.template after_merge_in<K>(a, b, last); }
    };

    /// The slots of register v: 8 v .. 8 v + 7.
    static __m256i lane_index(int v) {
        return _mm256_add_epi32(_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), _mm256_set1_epi32(8 * v));
    }

    /// Slot i's box, each coordinate in all lanes of a register.
    [[gnu::always_inline]] void query(uint32_t i, __m256 (&q)[6]) const {
        for (int k = 0; k < 6; ++k) q[k] = _mm256_broadcast_ss(&col[k][i]);
    }

    /// The distances from query box q to the slots of register v: the
    /// operations of scaled_union_half_area() in the same order (no FMA), and
    /// its clamp of NaN and overflow to FLT_MAX.
    [[gnu::always_inline]] __m256 distances(const __m256 (&q)[6], int v) const {
        __m256 d[3];
        for (int k = 0; k < 3; ++k)
            d[k] = _mm256_mul_ps(_mm256_sub_ps(_mm256_max_ps(_mm256_load_ps(col[k + 3] + 8 * v), q[k + 3]),
                                               _mm256_min_ps(_mm256_load_ps(col[k] + 8 * v), q[k])),
                                 scale);
        const __m256 area = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(d[0], d[1]), _mm256_mul_ps(d[1], d[2])),
                                          _mm256_mul_ps(d[2], d[0]));
        return _mm256_min_ps(area, _mm256_set1_ps(FLT_MAX));
    }

    /// d(i, j) for every lane j of the first kUsed registers (slots [0, 8
    /// kUsed) hold every live one) into `row`: +inf where j == i, FLT_MAX
    /// where j >= live (a retired lane's far box: no live slot's nearest is
    /// taken from it, since live lanes come first and no distance exceeds
    /// FLT_MAX). Returns the smallest entry's slot (the lowest on ties) and
    /// its value.
    template <int kUsed> uint32_t nearest_in(uint32_t i, float &best) {
        __m256 q[6];
        query(i, q);
        const __m256 inf = _mm256_set1_ps(INFINITY);
        const __m256i self = _mm256_set1_epi32(int(i));
        __m256 m = inf;
        __m256 r[kUsed];
        for (int v = 0; v < kUsed; ++v) {
            const __m256 area = distances(q, v);
            const __m256i lane = lane_index(v);
            r[v] = _mm256_blendv_ps(area, inf, _mm256_castsi256_ps(_mm256_cmpeq_epi32(lane, self)));
            _mm256_store_ps(row + 8 * v, r[v]);
            m = _mm256_min_ps(m, r[v]);
        }
        return first_equal<kUsed>(r, m, best);
    }

    /// nearest_in() of every slot in [0, count) into nd and nn, by columns:
    /// each row d(i, .), in slot order, offers i to every lane, kept where
    /// strictly nearer than the rows before (the lowest i of equals), so no
    /// row is reduced to its minimum. d(i, j) and d(j, i) compare equal (max,
    /// min and the area's products are symmetric; at most the sign of a zero
    /// differs), so lane j ends with nearest_in(j)'s answer: the nearest other
    /// slot, the lowest of equals.
    void all_nearest(uint32_t count) { by_registers(count, AllNearest{*this, count}); }

    template <int kUsed> void all_nearest_in(uint32_t count) {
        const __m256 inf = _mm256_set1_ps(INFINITY), fmax = _mm256_set1_ps(FLT_MAX);
        __m256 best[kUsed];
        __m256i arg[kUsed];
        for (int v = 0; v < kUsed; ++v) {
            best[v] = inf;
            arg[v] = _mm256_setzero_si256();
        }
        for (uint32_t i = 0; i < count; ++i) {
            __m256 q[6];
            query(i, q);
            const __m256i self = _mm256_set1_epi32(int(i));
            for (int v = 0; v < kUsed; ++v) {
                const __m256 area = distances(q, v);
                const __m256i lane = lane_index(v);
                const __m256 nearer = _mm256_andnot_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(lane, self)),
                                                       _mm256_cmp_ps(area, best[v], _CMP_LT_OQ));
                best[v] = _mm256_blendv_ps(best[v], area, nearer);
                arg[v] = _mm256_blendv_epi8(arg[v], self, _mm256_castps_si256(nearer));
            }
        }
        const __m256i end = _mm256_set1_epi32(int(count));
        for (int v = 0; v < kUsed; ++v) { // lanes past count: as retire() leaves them
            const __m256i lane = lane_index(v);
            const __m256i in = _mm256_cmpgt_epi32(end, lane);
            _mm256_store_ps(nd + 8 * v, _mm256_blendv_ps(fmax, best[v], _mm256_castsi256_ps(in)));
            _mm256_store_si256(reinterpret_cast<__m256i *>(nn + 8 * v),
                               _mm256_blendv_epi8(_mm256_set1_epi32(-1), arg[v], in));
        }
    }

    /// The lowest lane of r holding the minimum of the lane-wise minima m.
    template <int kUsed> static uint32_t first_equal(const __m256 *r, __m256 m, float &best) {
        m = _mm256_min_ps(m, _mm256_permute2f128_ps(m, m, 1));
        m = _mm256_min_ps(m, _mm256_shuffle_ps(m, m, _MM_SHUFFLE(1, 0, 3, 2)));
        m = _mm256_min_ps(m, _mm256_shuffle_ps(m, m, _MM_SHUFFLE(2, 3, 0, 1)));
        uint64_t mask = 0;
        for (int v = 0; v < kUsed; ++v)
            mask |= uint64_t(unsigned(_mm256_movemask_ps(_mm256_cmp_ps(r[v], m, _CMP_EQ_OQ)))) << (8 * v);
        best = _mm256_cvtss_f32(m);
        return uint32_t(__builtin_ctzll(mask)); // a row always has a finite entry (live >= 2)
    }

    /// The smallest nd among the live slots (the lowest on ties; lanes past live hold +inf).
    uint32_t closest_pair(uint32_t live) const { return by_registers(live, ClosestPair{*this}); }

    template <int kUsed> uint32_t closest_pair_in() const {
        __m256 r[kUsed];
        __m256 m = _mm256_set1_ps(INFINITY);
        for (int v = 0; v < kUsed; ++v) {
            r[v] = _mm256_load_ps(nd + 8 * v);
            m = _mm256_min_ps(m, r[v]);
        }
        float ignored;
        return first_equal<kUsed>(r, m, ignored);
    }

    /// The greedy loop's step after a merge (combine_small_loop.inl), all
    /// over the registers of `live` slots, chosen once.
    uint32_t after_merge(uint32_t a, uint32_t b, uint32_t last, uint32_t live) {
        return by_registers(live, AfterMerge{*this, a, b, last});
    }

    template <int kUsed> uint32_t after_merge_in(uint32_t a, uint32_t b, uint32_t last) {
        float best;
        const uint32_t nearest_a = nearest_in<kUsed>(a, best); // fills the row with d(a, .)
        update_in<kUsed>(a, b, last);
        nn[a] = int32_t(nearest_a);
        nd[a] = best;
        return closest_pair_in<kUsed>();
    }

    /// After merging a and b (a < b) into slot a and moving slot `last` to b,
    /// with `row` = d(a, .): the slots whose nearest neighbour was a or b search
    /// again; the others follow a partner moved from last to b and take a when
    /// it is closer (or as close with a lower slot). The scalar loop's rules.
    template <int kUsed> void update_in(uint32_t a, uint32_t b, uint32_t last) {
        const __m256i va = _mm256_set1_epi32(int(a)), vb = _mm256_set1_epi32(int(b)),
                      vlast = _mm256_set1_epi32(int(last));
        uint64_t again_bits = 0;
        for (int v = 0; v < kUsed; ++v) {
            // Retired lanes need no mask (no neighbour, FLT_MAX both ways);
            // slot a's entries are set by the caller after this.
            __m256i p = _mm256_load_si256(reinterpret_cast<const __m256i *>(nn + 8 * v));
            const __m256i again = _mm256_or_si256(_mm256_cmpeq_epi32(p, va), _mm256_cmpeq_epi32(p, vb));
            p = _mm256_blendv_epi8(p, vb, _mm256_cmpeq_epi32(p, vlast));
            const __m256 d = _mm256_load_ps(row + 8 * v), n = _mm256_load_ps(nd + 8 * v);
            const __m256i closer = _mm256_castps_si256(
                _mm256_or_ps(_mm256_cmp_ps(d, n, _CMP_LT_OQ),
                             _mm256_and_ps(_mm256_cmp_ps(d, n, _CMP_EQ_OQ), _mm256_castsi256_ps(_mm256_cmpgt_epi32(p, va)))));
            const __m256i take = _mm256_andnot_si256(again, closer);
            p = _mm256_blendv_epi8(p, va, take);
            _mm256_store_si256(reinterpret_cast<__m256i *>(nn + 8 * v), p);
            _mm256_store_ps(nd + 8 * v, _mm256_blendv_ps(n, d, _mm256_castsi256_ps(take)));
            again_bits |= uint64_t(unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(again)))) << (8 * v);
        }
        for (again_bits &= ~(uint64_t(1) << a); again_bits; again_bits &= again_bits - 1) {
            const uint32_t j = uint32_t(__builtin_ctzll(again_bits));
            nn[j] = int32_t(nearest_in<kUsed>(j, nd[j]));
        }
    }
};

#include "build/aac/combine_small_loop.inl"

template <int kVectors>
uint32_t run(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target, float scale,
             const FlattenRule &rule, ChoiceTable choices) {
    SmallCombine<kVectors> s;
    s.scale = _mm256_set1_ps(scale);
    return greedy_loop(s, tree, ids, free_ids, count, target, rule, choices);
}

/// The pairs (a, b), a < b, of up to kPairSlots[R - 1] clusters in slot
/// order (a first, then b), eight to a register, in R registers: lane p of
/// register v holds pair 8 v + p; lanes past the pairs hold (0, 0).
constexpr uint32_t kPairSlots[4] = {4, 6, 7, 8};
constexpr int32_t kPairCount[4] = {6, 15, 21, 28};
alignas(32) constexpr int32_t kPairA[4][32] = {{0, 0, 0, 1, 1, 2},
                                                {0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 3, 3, 4},
                                                {0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 4, 4, 5},
                                                {0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 5, 5, 6}};
alignas(32) constexpr int32_t kPairB[4][32] = {{1, 2, 3, 2, 3, 3},
                                                {1, 2, 3, 4, 5, 2, 3, 4, 5, 3, 4, 5, 4, 5, 5},
                                                {1, 2, 3, 4, 5, 6, 2, 3, 4, 5, 6, 3, 4, 5, 6, 4, 5, 6, 5, 6, 6},
                                                {1, 2, 3, 4, 5, 6, 7, 2, 3, 4, 5, 6, 7, 3, 4, 5, 6, 7, 4, 5, 6, 7, 5, 6, 7, 6, 7, 7}};

/// Four boxes' six coordinates as columns (lo x, y, z, hi x, y, z), lane i
/// from box[i]: each box's first four floats (lo x, y, z, hi x) and last two
/// (hi y, z) loaded, then transposed.
inline void corner_columns4(const Box *const box[4], __m128 (&c)[6]) {
    __m128 r[4], y[4];
    for (int k = 0; k < 4; ++k) {
        r[k] = _mm_loadu_ps(box[k]->lo);
        y[k] = _mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i *>(box[k]->hi + 1)));
    }
    const __m128 t0 = _mm_unpacklo_ps(r[0], r[1]), t1 = _mm_unpacklo_ps(r[2], r[3]);
    const __m128 t2 = _mm_unpackhi_ps(r[0], r[1]), t3 = _mm_unpackhi_ps(r[2], r[3]);
    const __m128 u0 = _mm_unpacklo_ps(y[0], y[1]), u1 = _mm_unpacklo_ps(y[2], y[3]);
    c[0] = _mm_movelh_ps(t0, t1);
    c[1] = _mm_movehl_ps(t1, t0);
    c[2] = _mm_movelh_ps(t2, t3);
    c[3] = _mm_movehl_ps(t3, t2);
    c[4] = _mm_movelh_ps(u0, u1);
    c[5] = _mm_movehl_ps(u1, u0);
}

/// The combines of at most kFewCombine = 8 clusters (most of AAC-Fast's:
/// four leaves to two, five or six clusters to three or four) with AVX2,
/// kPairSlots[R - 1] clusters at most: every pair (a, b) of slots has a lane
/// of R registers, so each merge's pair scan computes all live pairs'
/// distances at once (the operations of scaled_union_half_area() in the same
/// order, as in nearest_in()), with no rows to set up or keep, and merges the
/// first pair in slot order at the smallest distance: the union into slot a,
/// the last live cluster into slot b (combine_few()'s rule, so the same
/// merges).
template <int R>
uint32_t combine_pairs(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                       float scale, const FlattenRule &rule, ChoiceTable choices) {
    constexpr uint32_t kSlots = kPairSlots[R - 1];
    const uint32_t n = tree.leaf_count();
    const __m256 vscale = _mm256_set1_ps(scale);
    const __m256 inf = _mm256_set1_ps(INFINITY);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    __m256i pa[R], pb[R], real[R];
    for (int v = 0; v < R; ++v) {
        pa[v] = _mm256_load_si256(reinterpret_cast<const __m256i *>(kPairA[R - 1] + 8 * v));
        pb[v] = _mm256_load_si256(reinterpret_cast<const __m256i *>(kPairB[R - 1] + 8 * v));
        real[v] = _mm256_cmpgt_epi32(_mm256_set1_epi32(kPairCount[R - 1] - 8 * v), lane);
    }
    // The columns (lo x, y, z, hi x, y, z) of slots [0, kSlots): slots past
    // count are harmless copies of slot 0; with four slots the upper half
    // is never read (every pair's slots are below four).
    __m256 c[6];
    {
        const Box *box[8];
        for (uint32_t i = 0; i < 8; ++i) box[i] = &tree.boxes[ids[i < count ? i : 0]];
        __m128 low[6], high[6];
        corner_columns4(box, low);
        if (kSlots > 4) corner_columns4(box + 4, high);
        for (int k = 0; k < 6; ++k)
            c[k] = kSlots > 4 ? _mm256_insertf128_ps(_mm256_castps128_ps256(low[k]), high[k], 1)
                             : _mm256_zextps128_ps256(low[k]);
    }

    uint32_t live = count, used = 0;
    while (live > target) {
        __m256 r[R];
        __m256 m = inf;
        for (int v = 0; v < R; ++v) {
            __m256 d[3];
            for (int k = 0; k < 3; ++k)
                d[k] = _mm256_mul_ps(_mm256_sub_ps(_mm256_max_ps(_mm256_permutevar8x32_ps(c[k + 3], pb[v]),
                                                                 _mm256_permutevar8x32_ps(c[k + 3], pa[v])),
                                                   _mm256_min_ps(_mm256_permutevar8x32_ps(c[k], pb[v]),
                                                                 _mm256_permutevar8x32_ps(c[k], pa[v]))),
                                     vscale);
            const __m256 area = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(d[0], d[1]), _mm256_mul_ps(d[1], d[2])),
                                              _mm256_mul_ps(d[2], d[0]));
            // NaN and overflow: FLT_MAX, as the scalar clamp. Live pairs:
            // b < live (then a < live too).
            const __m256i in = _mm256_and_si256(_mm256_cmpgt_epi32(_mm256_set1_epi32(int(live)), pb[v]), real[v]);
            r[v] = _mm256_blendv_ps(inf, _mm256_min_ps(area, _mm256_set1_ps(FLT_MAX)), _mm256_castsi256_ps(in));
            m = _mm256_min_ps(m, r[v]);
        }
        m = _mm256_min_ps(m, _mm256_permute2f128_ps(m, m, 1));
        m = _mm256_min_ps(m, _mm256_shuffle_ps(m, m, _MM_SHUFFLE(1, 0, 3, 2)));
        m = _mm256_min_ps(m, _mm256_shuffle_ps(m, m, _MM_SHUFFLE(2, 3, 0, 1)));
        uint32_t at = 0;
        for (int v = 0; v < R; ++v)
            at |= uint32_t(unsigned(_mm256_movemask_ps(_mm256_cmp_ps(r[v], m, _CMP_EQ_OQ)))) << (8 * v);
        const uint32_t p = uint32_t(__builtin_ctz(at)); // a finite entry exists (live >= 2)
        const uint32_t a = uint32_t(kPairA[R - 1][p]), b = uint32_t(kPairB[R - 1][p]);

        // The union of slots a and b from the columns, in every lane (no box
        // read back from the tree): min(b, a) and max(b, a) lane for lane
        // are unite()'s std::min and std::max, so the same bits. The tree's
        // box is written a float at a time and read so by the choice.
        const __m256i va = _mm256_set1_epi32(int(a)), vb = _mm256_set1_epi32(int(b));
        __m256 merged_cols[6];
        for (int k = 0; k < 3; ++k) {
            merged_cols[k] = _mm256_min_ps(_mm256_permutevar8x32_ps(c[k], vb), _mm256_permutevar8x32_ps(c[k], va));
            merged_cols[k + 3] =
                _mm256_max_ps(_mm256_permutevar8x32_ps(c[k + 3], vb), _mm256_permutevar8x32_ps(c[k + 3], va));
        }
        const uint32_t node = free_ids[used++];
        Box &merged = tree.boxes[node];
        for (int k = 0; k < 3; ++k) {
            merged.lo[k] = _mm256_cvtss_f32(merged_cols[k]);
            merged.hi[k] = _mm256_cvtss_f32(merged_cols[k + 3]);
        }
        tree.set_children(node, ids[a], ids[b]);
        choices.set(node - n, rule.inner(merged, cluster_choice(tree, rule, choices, ids[a]),
                                         cluster_choice(tree, rule, choices, ids[b])));

        const uint32_t last = live - 1;
        live = last;
        ids[a] = node;
        const __m256 at_a = _mm256_castsi256_ps(_mm256_cmpeq_epi32(lane, va));
        for (int k = 0; k < 6; ++k) c[k] = _mm256_blendv_ps(c[k], merged_cols[k], at_a);
        if (b != last) { // the last live cluster moves into slot b
            ids[b] = ids[last];
            const __m256i vlast = _mm256_set1_epi32(int(last));
            const __m256 at_b = _mm256_castsi256_ps(_mm256_cmpeq_epi32(lane, vb));
            for (int k = 0; k < 6; ++k) c[k] = _mm256_blendv_ps(c[k], _mm256_permutevar8x32_ps(c[k], vlast), at_b);
        }
    }
    for (uint32_t i = 0; i < live; ++i) free_ids[i] = free_ids[used + i];
    return live;
}

} // namespace

uint32_t combine_few_avx2(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                          float scale, const FlattenRule &rule, ChoiceTable choices) {
    if (count <= kPairSlots[0]) return combine_pairs<1>(tree, ids, free_ids, count, target, scale, rule, choices);
    if (count <= kPairSlots[1]) return combine_pairs<2>(tree, ids, free_ids, count, target, scale, rule, choices);
    if (count <= kPairSlots[2]) return combine_pairs<3>(tree, ids, free_ids, count, target, scale, rule, choices);
    return combine_pairs<4>(tree, ids, free_ids, count, target, scale, rule, choices);
}

bool combine_small_avx2_compiled() { return true; }

uint32_t combine_small_avx2(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                            float scale, const FlattenRule &rule, ChoiceTable choices) {
    if (count <= 8) return run<1>(tree, ids, free_ids, count, target, scale, rule, choices);
    if (count <= 16) return run<2>(tree, ids, free_ids, count, target, scale, rule, choices);
    if (count <= 32) return run<4>(tree, ids, free_ids, count, target, scale, rule, choices);
    return run<8>(tree, ids, free_ids, count, target, scale, rule, choices);
}

} // namespace aacbvh

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

#else // not x86-64 with GCC or Clang: never called (combine_small_avx2_compiled() is false)

namespace aacbvh {
bool combine_small_avx2_compiled() { return false; }
uint32_t combine_small_avx2(BinaryTree &, uint32_t *, uint32_t *, uint32_t count, uint32_t, float,
                            const FlattenRule &, ChoiceTable) {
    return count;
}
uint32_t combine_few_avx2(BinaryTree &, uint32_t *, uint32_t *, uint32_t count, uint32_t, float, const FlattenRule &,
                          ChoiceTable) {
    return count;
}
} // namespace aacbvh

#endif
