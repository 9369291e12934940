// The greedy loop of a small combine (build/aac/cluster_combine.h) in
// AVX-512: the AVX2 loop (combine_small_avx2.cpp) with 16 lanes a register
// and mask registers for the per-lane choices, so a row of up to 64 clusters
// is at most four registers. Same distances bit for bit (the operations of
// scaled_union_half_area in the same order; the library is compiled with
// -ffp-contract=off, so no FMA) and the same tie rules as the scalar loop, so
// the same merges. Compiled for AVX-512F only inside the target region below
// and called only on CPUs that have it (cluster_combine.cpp).
#include "build/aac/combine_small.h"

#include <cfloat>
#include <cmath>
#include <type_traits>
#include <utility>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>

// Everything defined from here to the end of the region is compiled for
// AVX-512F; the headers above stay baseline code.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx512f")
// GCC 12's avx512fintrin.h warns of its own self-initialised placeholder
// operands (`__Y = __Y`) once they are inlined here.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif

namespace aacbvh {
namespace {

__extension__ typedef unsigned __int128 Bits128;

inline uint32_t lowest_bit(uint64_t x) { return uint32_t(__builtin_ctzll(x)); }
inline uint32_t lowest_bit(Bits128 x) {
    const uint64_t low = uint64_t(x);
    return low ? uint32_t(__builtin_ctzll(low)) : 64 + uint32_t(__builtin_ctzll(uint64_t(x >> 64)));
}

/// Up to 16 * kVectors clusters, kVectors registers per row.
template <int kVectors> struct SmallCombine512 {
    static constexpr uint32_t kLanes = 16 * kVectors;
    /// One bit per lane.
    using Bits = std::conditional_t<(kLanes > 64), Bits128, uint64_t>;
    alignas(64) float col[6][kLanes]; ///< lo x, y, z, hi x, y, z of each live cluster
    alignas(64) float nd[kLanes];     ///< distance to the nearest neighbour
    alignas(64) int32_t nn[kLanes];   ///< the nearest neighbour's slot
    alignas(64) float row[kLanes];    ///< the last row computed
    Box box[kLanes];
    __m512 scale;

    /// The lanes that the loops below read (all of them).
    static uint32_t padded(uint32_t) { return kLanes; }

    /// A lane past the live slots (its loops mask them: any box would do).
    void retire(uint32_t i) {
        set(i, kFarBox);
        nd[i] = INFINITY;
        nn[i] = 0;
    }

    void set(uint32_t i, const Box &b) {
        copy_box(i, b);
        for (int k = 0; k < 3; ++k) {
            col[k][i] = b.lo[k];
            col[k + 3][i] = b.hi[k];
        }
    }

    /// Lane i of `lanes` (kLanes of them) set to `value` by rewriting the
    /// whole register of 16 lanes that holds it, for the writes between
    /// merges: the next whole-register load of those lanes then takes the
    /// value from this store, where a one-lane store under it would stall
    /// the load until the store retires (docs/PERFORMANCE.md, row 152).
    static void put(float *lanes, uint32_t i, float value) {
        float *at = lanes + (i & ~15u);
        _mm512_store_ps(at, _mm512_mask_broadcastss_ps(_mm512_load_ps(at), __mmask16(1u << (i & 15)),
                                                       _mm_set_ss(value)));
    }
    static void put(int32_t *lanes, uint32_t i, int32_t value) {
        int32_t *at = lanes + (i & ~15u);
        _mm512_store_si512(at, _mm512_mask_set1_epi32(_mm512_load_si512(at), __mmask16(1u << (i & 15)), value));
    }
    void replace(uint32_t i, const Box &b) {
        copy_box(i, b);
        for (int k = 0; k < 3; ++k) {
            put(col[k], i, b.lo[k]);
            put(col[k + 3], i, b.hi[k]);
        }
    }

    /// unite(box[a], box[b]) into `out` by two register stores (the first
    /// four floats, then the last two), as the boxes were written: the box
    /// made by one-float stores and copied whole was read back by wider
    /// loads than its stores (docs/PERFORMANCE.md, row 161). The same bits
    /// as unite(): b taken only where it is below, or above, a.
    void unite_into(Box &out, uint32_t a, uint32_t b) const {
        const __m128 ra = _mm_loadu_ps(box[a].lo), rb = _mm_loadu_ps(box[b].lo); // lo x, y, z, hi x
        const __m128 head = _mm_blend_ps(_mm_min_ps(rb, ra), _mm_max_ps(rb, ra), 0x8);
        const __m128 ya = _mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i *>(box[a].hi + 1)));
        const __m128 yb = _mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i *>(box[b].hi + 1)));
        _mm_storeu_ps(out.lo, head);
        _mm_storel_epi64(reinterpret_cast<__m128i *>(out.hi + 1), _mm_castps_si128(_mm_max_ps(yb, ya)));
    }
    /// box[i] = b by the same two register stores.
    void copy_box(uint32_t i, const Box &b) {
        _mm_storeu_ps(box[i].lo, _mm_loadu_ps(b.lo));
        _mm_storel_epi64(reinterpret_cast<__m128i *>(box[i].hi + 1),
                         _mm_loadl_epi64(reinterpret_cast<const __m128i *>(b.hi + 1)));
    }

    /// The greedy loop's slot moves after a merge (combine_small_loop.inl),
    /// as retire() and set() do, by whole-register writes.
    void move_slots(uint32_t a, const Box &merged_box, uint32_t b, uint32_t last) {
        if (b != last) {
            replace(b, box[last]);
            put(nd, b, nd[last]);
            put(nn, b, nn[last]);
        }
        replace(last, kFarBox);
        put(nd, last, INFINITY);
        put(nn, last, 0);
        replace(a, merged_box);
    }

    /// Bit j set for the live slots j < live other than `except`.
    static Bits live_bits(uint32_t live, uint32_t except) {
        const Bits below = live >= kLanes ? ~Bits(0) : (Bits(1) << live) - 1;
        return below & ~(Bits(1) << except);
    }

    /// nearest() of every slot in [0, count) into nd and nn.
    void all_nearest(uint32_t count) {
        for (uint32_t i = 0; i < count; ++i) nn[i] = int32_t(nearest(i, count, nd[i]));
    }

    /// d(i, j) for every lane j into `row`: +inf where j == i or j >= live.
    /// Returns the smallest entry's slot (the lowest on ties) and its value.
    uint32_t nearest(uint32_t i, uint32_t live, float &best) {
        __m512 q[6];
        for (int k = 0; k < 6; ++k) q[k] = _mm512_set1_ps(col[k][i]);
        const __m512 inf = _mm512_set1_ps(INFINITY), fmax = _mm512_set1_ps(FLT_MAX);
        const Bits valid = live_bits(live, i);
        __m512 m = inf;
        __m512 r[kVectors];
        for (int v = 0; v < kVectors; ++v) {
            __m512 d[3];
            for (int k = 0; k < 3; ++k)
                d[k] = _mm512_mul_ps(_mm512_sub_ps(_mm512_max_ps(_mm512_load_ps(col[k + 3] + 16 * v), q[k + 3]),
                                                   _mm512_min_ps(_mm512_load_ps(col[k] + 16 * v), q[k])),
                                     scale);
            __m512 area = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(d[0], d[1]), _mm512_mul_ps(d[1], d[2])),
                                        _mm512_mul_ps(d[2], d[0]));
            area = _mm512_min_ps(area, fmax); // NaN and overflow: FLT_MAX, as the scalar clamp
            r[v] = _mm512_mask_blend_ps(__mmask16(valid >> (16 * v)), inf, area);
            _mm512_store_ps(row + 16 * v, r[v]);
            m = _mm512_min_ps(m, r[v]);
        }
        return first_equal(r, m, best);
    }

    /// The lowest lane of r holding the minimum of the lane-wise minima m.
    static uint32_t first_equal(const __m512 *r, __m512 m, float &best) {
        const __m512 low = _mm512_set1_ps(_mm512_reduce_min_ps(m));
        Bits mask = 0;
        for (int v = 0; v < kVectors; ++v)
            mask |= Bits(_mm512_cmp_ps_mask(r[v], low, _CMP_EQ_OQ)) << (16 * v);
        best = _mm512_cvtss_f32(low);
        return lowest_bit(mask); // a row always has a finite entry (live >= 2)
    }

    /// The smallest nd among the live slots (lanes past live hold +inf).
    uint32_t closest_pair(uint32_t /*live: lanes past it hold +inf*/) const {
        __m512 r[kVectors];
        __m512 m = _mm512_set1_ps(INFINITY);
        for (int v = 0; v < kVectors; ++v) {
            r[v] = _mm512_load_ps(nd + 16 * v);
            m = _mm512_min_ps(m, r[v]);
        }
        float ignored;
        return first_equal(r, m, ignored);
    }

    /// The greedy loop's step after a merge (combine_small_loop.inl).
    uint32_t after_merge(uint32_t a, uint32_t b, uint32_t last, uint32_t live) {
        float best;
        const uint32_t nearest_a = nearest(a, live, best); // fills the row with d(a, .)
        update(a, b, last, live);
        put(nn, a, int32_t(nearest_a));
        put(nd, a, best);
        return closest_pair(live);
    }

    /// After merging a and b (a < b) into slot a and moving slot `last` to b,
    /// with `row` = d(a, .): the slots whose nearest neighbour was a or b search
    /// again; the others follow a partner moved from last to b and take a when
    /// it is closer (or as close with a lower slot). The scalar loop's rules.
    void update(uint32_t a, uint32_t b, uint32_t last, uint32_t live) {
        const __m512i va = _mm512_set1_epi32(int(a)), vb = _mm512_set1_epi32(int(b)),
                      vlast = _mm512_set1_epi32(int(last));
        const Bits live_lanes = live_bits(live, a);
        Bits again_bits = 0;
        for (int v = 0; v < kVectors; ++v) {
            const __mmask16 lane_live = __mmask16(live_lanes >> (16 * v));
            __m512i p = _mm512_load_si512(nn + 16 * v);
            const __mmask16 again =
                lane_live & (_mm512_cmpeq_epi32_mask(p, va) | _mm512_cmpeq_epi32_mask(p, vb));
            p = _mm512_mask_mov_epi32(p, _mm512_cmpeq_epi32_mask(p, vlast), vb);
            const __m512 d = _mm512_load_ps(row + 16 * v), n = _mm512_load_ps(nd + 16 * v);
            const __mmask16 closer = _mm512_cmp_ps_mask(d, n, _CMP_LT_OQ) |
                                     (_mm512_cmp_ps_mask(d, n, _CMP_EQ_OQ) & _mm512_cmpgt_epi32_mask(p, va));
            const __mmask16 take = closer & lane_live & __mmask16(~again);
            p = _mm512_mask_mov_epi32(p, take, va);
            _mm512_store_si512(nn + 16 * v, p);
            _mm512_store_ps(nd + 16 * v, _mm512_mask_mov_ps(n, take, d));
            again_bits |= Bits(again) << (16 * v);
        }
        for (; again_bits; again_bits &= again_bits - 1) {
            const uint32_t j = lowest_bit(again_bits);
            float best;
            put(nn, j, int32_t(nearest(j, live, best)));
            put(nd, j, best);
        }
    }
};

#include "build/aac/combine_small_loop.inl"

template <int kVectors>
uint32_t run(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target, float scale,
             const FlattenRule &rule, ChoiceTable choices) {
    SmallCombine512<kVectors> s;
    s.scale = _mm512_set1_ps(scale);
    return greedy_loop(s, tree, ids, free_ids, count, target, rule, choices);
}

} // namespace

bool combine_small_avx512_compiled() { return true; }

uint32_t combine_small_avx512(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                              float scale, const FlattenRule &rule, ChoiceTable choices) {
    if (count <= 16) return run<1>(tree, ids, free_ids, count, target, scale, rule, choices);
    if (count <= 32) return run<2>(tree, ids, free_ids, count, target, scale, rule, choices);
    if (count <= 48) return run<3>(tree, ids, free_ids, count, target, scale, rule, choices);
    if (count <= 64) return run<4>(tree, ids, free_ids, count, target, scale, rule, choices);
    if (count <= 80) return run<5>(tree, ids, free_ids, count, target, scale, rule, choices);
    if (count <= 96) return run<6>(tree, ids, free_ids, count, target, scale, rule, choices);
    if (count <= 112) return run<7>(tree, ids, free_ids, count, target, scale, rule, choices);
    return run<8>(tree, ids, free_ids, count, target, scale, rule, choices);
}

} // namespace aacbvh

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif

#else // not x86-64 with GCC or Clang: never called (combine_small_avx512_compiled() is false)

namespace aacbvh {
bool combine_small_avx512_compiled() { return false; }
uint32_t combine_small_avx512(BinaryTree &, uint32_t *, uint32_t *, uint32_t count, uint32_t, float,
                              const FlattenRule &, ChoiceTable) {
    return count;
}
} // namespace aacbvh

#endif
