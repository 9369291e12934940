#include "build/aac/cluster_combine.h"

#include <algorithm>
#include <atomic>
#include <thread>
#include <cfloat>
#include <cmath>

#include "build/aac/combine_small.h"
#include "build/aac/distance_row.h"

#if defined(__SSE2__)
#include <immintrin.h>
#define AACBVH_SSE2 1
#endif

namespace aacbvh {

namespace {

uint64_t next_pool_id() {
    static std::atomic<uint64_t> next{1};
    return next.fetch_add(1, std::memory_order_relaxed);
}

/// Above kMatrixCombine clusters the pairwise matrix (count^2 floats) is not
/// kept; rows are recomputed when needed instead (exact-clustering settings
/// reach this).

inline uint32_t padded(uint32_t n) { return (n + 7) & ~7u; }

/// Live clusters' boxes as six columns (structure of arrays) for distance_row().
class Columns {
public:
    Columns(float *base, uint32_t stride) {
        for (int k = 0; k < 3; ++k) {
            cols_.lo[k] = base + size_t(k) * stride;
            cols_.hi[k] = base + size_t(k + 3) * stride;
        }
    }
    const BoxColumns &columns() const { return cols_; }
    void set(uint32_t i, const Box &b) {
        for (int k = 0; k < 3; ++k) {
            cols_.lo[k][i] = b.lo[k];
            cols_.hi[k][i] = b.hi[k];
        }
    }
    void query(uint32_t i, float q[6]) const {
        for (int k = 0; k < 3; ++k) {
            q[k] = cols_.lo[k][i];
            q[k + 3] = cols_.hi[k][i];
        }
    }
    void move(uint32_t from, uint32_t to) {
        for (int k = 0; k < 3; ++k) {
            cols_.lo[k][to] = cols_.lo[k][from];
            cols_.hi[k][to] = cols_.hi[k][from];
        }
    }

private:
    BoxColumns cols_;
};

/// update_nearest()'s rules one slot at a time, for slots [j, live) (the
/// SIMD loops' tails); appends to rescan[rescans ...] and returns the new count.
inline uint32_t update_nearest_from(uint32_t j, const float *da, float *nd, uint32_t *nn, uint32_t live, uint32_t a,
                                    uint32_t b, uint32_t last, uint32_t *rescan, uint32_t rescans) {
    for (; j < live; ++j) {
        if (j == a) continue;
        uint32_t &p = nn[j];
        if (p == a || p == b) {
            rescan[rescans++] = j;
            continue;
        }
        if (p == last) p = b;
        if (da[j] < nd[j] || (da[j] == nd[j] && a < p)) {
            nd[j] = da[j];
            p = a;
        }
    }
    return rescans;
}

/// The nearest-neighbour bookkeeping after a merge, for every live slot j
/// but a: clusters a and b (a < b) merged into slot a, the last live cluster
/// moved from slot `last` (== live) into slot b, and da[j] = d(a, j). A slot
/// whose nearest neighbour was a or b must search again: its index goes to
/// `rescan` (the count is returned). The others follow a partner that moved
/// from `last` to b, and take a when it is closer (or as close with a lower
/// slot). SSE2 on x86-64, four slots at a time.
uint32_t update_nearest(const float *da, float *nd, uint32_t *nn, uint32_t live, uint32_t a, uint32_t b, uint32_t last,
                        uint32_t *rescan) {
    uint32_t rescans = 0;
    uint32_t j = 0;
#ifdef AACBVH_SSE2
    const __m128i va = _mm_set1_epi32(int(a)), vb = _mm_set1_epi32(int(b)), vlast = _mm_set1_epi32(int(last));
    __m128i index = _mm_setr_epi32(0, 1, 2, 3);
    const __m128i four = _mm_set1_epi32(4);
    for (; j + 4 <= live; j += 4, index = _mm_add_epi32(index, four)) {
        __m128i p = _mm_loadu_si128(reinterpret_cast<const __m128i *>(nn + j));
        const __m128i not_a = _mm_xor_si128(_mm_cmpeq_epi32(index, va), _mm_set1_epi32(-1));
        const __m128i again = _mm_and_si128(_mm_or_si128(_mm_cmpeq_epi32(p, va), _mm_cmpeq_epi32(p, vb)), not_a);
        const __m128i moved = _mm_cmpeq_epi32(p, vlast);
        p = _mm_or_si128(_mm_andnot_si128(moved, p), _mm_and_si128(moved, vb));
        const __m128 d = _mm_loadu_ps(da + j), n = _mm_loadu_ps(nd + j);
        const __m128i closer = _mm_castps_si128(_mm_or_ps(
            _mm_cmplt_ps(d, n), _mm_and_ps(_mm_cmpeq_ps(d, n), _mm_castsi128_ps(_mm_cmpgt_epi32(p, va)))));
        const __m128i take = _mm_andnot_si128(again, _mm_and_si128(closer, not_a));
        p = _mm_or_si128(_mm_andnot_si128(take, p), _mm_and_si128(take, va));
        _mm_storeu_si128(reinterpret_cast<__m128i *>(nn + j), p);
        _mm_storeu_ps(nd + j, _mm_or_ps(_mm_andnot_ps(_mm_castsi128_ps(take), n),
                                        _mm_and_ps(_mm_castsi128_ps(take), d)));
        int bits = _mm_movemask_ps(_mm_castsi128_ps(again));
        while (bits) {
            rescan[rescans++] = j + uint32_t(__builtin_ctz(unsigned(bits)));
            bits &= bits - 1;
        }
    }
#endif
    return update_nearest_from(j, da, nd, nn, live, a, b, last, rescan, rescans);
}

#ifdef AACBVH_SSE2
/// update_nearest() with eight slots at a time, for CPUs with AVX2 (the
/// same rules lane by lane, the same rescans in the same order).
__attribute__((target("avx2"))) uint32_t update_nearest_avx2(const float *da, float *nd, uint32_t *nn, uint32_t live,
                                                             uint32_t a, uint32_t b, uint32_t last, uint32_t *rescan) {
    uint32_t rescans = 0;
    uint32_t j = 0;
    const __m256i va = _mm256_set1_epi32(int(a)), vb = _mm256_set1_epi32(int(b)), vlast = _mm256_set1_epi32(int(last));
    const __m256i ones = _mm256_set1_epi32(-1), eight = _mm256_set1_epi32(8);
    __m256i index = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for (; j + 8 <= live; j += 8, index = _mm256_add_epi32(index, eight)) {
        __m256i p = _mm256_loadu_si256(reinterpret_cast<const __m256i *>(nn + j));
        const __m256i not_a = _mm256_xor_si256(_mm256_cmpeq_epi32(index, va), ones);
        const __m256i again =
            _mm256_and_si256(_mm256_or_si256(_mm256_cmpeq_epi32(p, va), _mm256_cmpeq_epi32(p, vb)), not_a);
        p = _mm256_blendv_epi8(p, vb, _mm256_cmpeq_epi32(p, vlast));
        const __m256 d = _mm256_loadu_ps(da + j), n = _mm256_loadu_ps(nd + j);
        const __m256i closer = _mm256_castps_si256(_mm256_or_ps(
            _mm256_cmp_ps(d, n, _CMP_LT_OQ),
            _mm256_and_ps(_mm256_cmp_ps(d, n, _CMP_EQ_OQ), _mm256_castsi256_ps(_mm256_cmpgt_epi32(p, va)))));
        const __m256i take = _mm256_andnot_si256(again, _mm256_and_si256(closer, not_a));
        p = _mm256_blendv_epi8(p, va, take);
        _mm256_storeu_si256(reinterpret_cast<__m256i *>(nn + j), p);
        _mm256_storeu_ps(nd + j, _mm256_blendv_ps(n, d, _mm256_castsi256_ps(take)));
        for (int bits = _mm256_movemask_ps(_mm256_castsi256_ps(again)); bits; bits &= bits - 1)
            rescan[rescans++] = j + uint32_t(__builtin_ctz(unsigned(bits)));
    }
    return update_nearest_from(j, da, nd, nn, live, a, b, last, rescan, rescans);
}
#endif

/// The greedy loop. With kMatrix, d(i, j) of live clusters is cached and only
/// the merged cluster's row is recomputed, as the paper suggests; without, a
/// row is recomputed whenever a nearest neighbour must be found again.
template <bool kMatrix>
uint32_t combine(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target, float scale,
                 const FlattenRule &rule, ChoiceTable choices, CombineScratch &s, BuildContext &ctx) {
    const uint32_t n = tree.leaf_count();
    auto choice = [&](uint32_t id) { return id < n ? rule.leaf(tree.boxes[id]) : choices.get(id - n); };
    const uint32_t stride = padded(count + 1); // + 1: a spare row for the non-matrix mode
    Columns boxes(s.columns.data(), stride);
    float *nd = s.nearest_distance.data();
    uint32_t *nn = s.nearest.data();
    uint32_t *rescan = s.rescan.data();
    float *matrix = s.distances.data();
    float q[6];

    for (uint32_t i = 0; i < count; ++i) boxes.set(i, tree.boxes[ids[i]]);
    // Padding lanes read by the SIMD row get a harmless box.
    for (uint32_t i = count; i < stride; ++i) boxes.set(i, tree.boxes[ids[0]]);

    // Work between two polls is bounded in distance evaluations: a combine
    // of 2^20 clusters (delta 2^20, or alpha = 1) does 2^40 in its first scan.
    PollingCounter work(ctx);
#ifdef AACBVH_SSE2
    const bool avx2 = distance_kernel() >= DistanceKernel::Avx2; // update_nearest_avx2()
#endif
    auto rows_done = [&work](uint32_t rows, uint32_t length) {
        testing::count_distances(uint64_t(rows) * length);
        work.add(uint64_t(rows) * length);
    };

    if (kMatrix) {
        // The diagonal is +inf so that nearest-neighbour scans need no self test.
        for (uint32_t i = 0; i < count; ++i) {
            boxes.query(i, q);
            nn[i] = distance_row_argmin(boxes.columns(), count, q, scale, matrix + size_t(i) * stride, i, nd[i]);
            rows_done(1, count);
        }
    } else {
        // Each pair's distance once where the kernel can (nearest_rows()),
        // in runs of rows of about 2^20 distances between polls.
        for (uint32_t j = 0; j < stride; ++j) {
            nd[j] = INFINITY;
            nn[j] = 0;
        }
        for (uint32_t i = 0; i < count;) {
            uint32_t e = i;
            uint32_t pairs = 0;
            while (e < count && pairs < (uint32_t(1) << 20)) pairs += count - e++;
            nearest_rows(boxes.columns(), count, scale, i, e, nd, nn, matrix);
            rows_done(1, pairs);
            i = e;
        }
    }

    uint32_t live = count;
    uint32_t used = 0;
    while (live > target) {
        float ignored;
        uint32_t a = argmin_row(nd, live, ignored); // the closest pair, lowest slot on ties
        uint32_t b = nn[a];
        if (a > b) std::swap(a, b); // the merged cluster takes the lower slot

        const uint32_t node = free_ids[used++];
        const Box merged = unite(tree.boxes[ids[a]], tree.boxes[ids[b]]);
        tree.boxes[node] = merged;
        tree.set_children(node, ids[a], ids[b]);
        choices.set(node - n, rule.inner(merged, choice(ids[a]), choice(ids[b])));

        // Slot b is freed by moving the last live cluster into it.
        const uint32_t last = live - 1;
        if (b != last) {
            boxes.move(last, b);
            ids[b] = ids[last];
            nd[b] = nd[last];
            nn[b] = nn[last];
            if (kMatrix) {
                std::copy(matrix + size_t(last) * stride, matrix + size_t(last) * stride + live,
                          matrix + size_t(b) * stride);
                for (uint32_t j = 0; j < live; ++j) matrix[size_t(j) * stride + b] = matrix[size_t(j) * stride + last];
            }
        }
        live = last;
        boxes.set(a, merged);
        boxes.set(live, merged); // keep the padding lanes valid
        ids[a] = node;

        // The merged cluster's row, and its nearest neighbour.
        float *da = kMatrix ? matrix + size_t(a) * stride : matrix;
        boxes.query(a, q);
        nn[a] = distance_row_argmin(boxes.columns(), live, q, scale, da, a, nd[a]);
        if (kMatrix)
            for (uint32_t j = 0; j < live; ++j) matrix[size_t(j) * stride + a] = da[j];

        // Clusters whose nearest neighbour was merged look again; the others
        // only compare with the new cluster. (Without the matrix the rescans
        // reuse da's row, so da is read first.)
#ifdef AACBVH_SSE2
        const uint32_t rescans = avx2 ? update_nearest_avx2(da, nd, nn, live, a, b, last, rescan)
                                      : update_nearest(da, nd, nn, live, a, b, last, rescan);
#else
        const uint32_t rescans = update_nearest(da, nd, nn, live, a, b, last, rescan);
#endif
        for (uint32_t k = 0; k < rescans; ++k) {
            const uint32_t j = rescan[k];
            if (kMatrix) {
                nn[j] = argmin_row(matrix + size_t(j) * stride, live, nd[j]);
            } else { // the row recomputed, and its minimum, in one pass
                boxes.query(j, q);
                nn[j] = distance_row_argmin(boxes.columns(), live, q, scale, matrix, j, nd[j]);
            }
        }
        rows_done(1 + (kMatrix ? 0 : rescans), live);
    }

    // Unused ids move to the front of free_ids for the caller.
    for (uint32_t i = 0; i < live; ++i) free_ids[i] = free_ids[used + i];
    return live;
}

/// The same greedy loop for a handful of clusters (9 to kSmallCombine where
/// the AVX2 loop is not available; below that the pair scan, combine_few):
/// everything in registers and stack arrays, scalar distances, no padding.
/// Same tie rules as combine(), so results are identical.

/// argmin_row() for rows of a few entries, inlined.
/// Branch-free: which entry is smallest is data, not a pattern to predict.
inline uint32_t argmin_small(const float *row, uint32_t count, float &best) {
    uint32_t arg = 0;
    float b = row[0];
    for (uint32_t j = 1; j < count; ++j) {
        const bool less = row[j] < b;
        b = less ? row[j] : b;
        arg = less ? j : arg;
    }
    best = b;
    return arg;
}

/// A small combine that makes one merge (count == target + 1: most of
/// AAC-Fast's, 3 clusters to 2 above all). The greedy loop's first merge joins
/// slot a, the lowest slot whose nearest distance is the smallest, with its
/// nearest neighbour b, the lowest slot at that distance; b > a, since b would
/// otherwise be a lower slot with the smallest distance. So (a, b) is the
/// first pair in (a, b) order at the smallest distance, found here with one
/// distance per pair and no nearest-neighbour bookkeeping; the slots then
/// move as in the loop.
uint32_t combine_once(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, float scale,
                      const FlattenRule &rule, ChoiceTable choices) {
    const uint32_t n = tree.leaf_count();
    Box box[kSmallCombine];
    for (uint32_t i = 0; i < count; ++i) box[i] = tree.boxes[ids[i]];
    // The pair as one word (a, b << 16) chosen through a mask: three
    // selections on one comparison became a branch, which the data (which
    // pair is nearest) mispredicts about as often as not.
    static_assert(kSmallCombine <= 0x10000, "slots must fit 16 bits");
    float best = INFINITY;
    uint32_t pair = 1u << 16;
    for (uint32_t i = 0; i + 1 < count; ++i)
        for (uint32_t j = i + 1; j < count; ++j) {
            const float d = scaled_union_half_area(box[i], box[j], scale);
            const uint32_t take = 0u - uint32_t(d < best);
            best = d < best ? d : best;
            pair ^= (pair ^ (i | j << 16)) & take;
        }
    const uint32_t a = pair & 0xFFFFu, b = pair >> 16;
    auto choice = [&](uint32_t id) { return id < n ? rule.leaf(tree.boxes[id]) : choices.get(id - n); };
    const uint32_t node = free_ids[0];
    Box &merged = tree.boxes[node];
    write_union(merged, box[a], box[b]); // no union copied from the stack (row 241)
    tree.set_children(node, ids[a], ids[b]);
    choices.set(node - n, rule.inner(merged, choice(ids[a]), choice(ids[b])));
    const uint32_t last = count - 1;
    if (b != last) ids[b] = ids[last];
    ids[a] = node;
    for (uint32_t i = 0; i < last; ++i) free_ids[i] = free_ids[i + 1];
    return last;
}

/// Combines of at most kFewCombine clusters (most of AAC-Fast's, 4 to 8 down
/// to 3 or 4): each pair's distance once, then every merge joins the first
/// pair in (a, b) slot order at the smallest distance, found by scanning the
/// live pairs, with no nearest-neighbour bookkeeping; slots move as in the
/// other loops (the merged cluster in slot a, the last live one into slot b).
/// Without ties this is the pair every loop picks. With ties it can differ
/// from the greedy loops, which keep a recorded nearest neighbour that a
/// moved slot ties with (docs/PERFORMANCE.md, rows 78 and 112); every kernel
/// runs this same loop for these counts, so builds stay identical across
/// kernels and thread counts.
uint32_t combine_few(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                     float scale, const FlattenRule &rule, ChoiceTable choices) {
    const uint32_t n = tree.leaf_count();
    Box box[kFewCombine];
    float d[kFewCombine][kFewCombine]; // d[i][j] for i < j
    // A leaf's choice from the box held here (the same values as the tree's).
    auto choice = [&](uint32_t slot) { return ids[slot] < n ? rule.leaf(box[slot]) : choices.get(ids[slot] - n); };
    for (uint32_t i = 0; i < count; ++i) box[i] = tree.boxes[ids[i]];
    for (uint32_t i = 0; i + 1 < count; ++i)
        for (uint32_t j = i + 1; j < count; ++j) d[i][j] = scaled_union_half_area(box[i], box[j], scale);

    uint32_t live = count, used = 0;
    while (live > target) {
        float best = INFINITY;
        uint32_t a = 0, b = 1;
        for (uint32_t i = 0; i + 1 < live; ++i)
            for (uint32_t j = i + 1; j < live; ++j) {
                const bool less = d[i][j] < best; // strict: the first pair in slot order wins ties
                best = less ? d[i][j] : best;
                a = less ? i : a;
                b = less ? j : b;
            }
        const uint32_t node = free_ids[used++];
        const Box merged = unite(box[a], box[b]);
        tree.boxes[node] = merged;
        tree.set_children(node, ids[a], ids[b]);
        choices.set(node - n, rule.inner(merged, choice(a), choice(b)));

        const uint32_t last = live - 1;
        if (b != last) { // the last live cluster moves into slot b, its distances with it
            box[b] = box[last];
            ids[b] = ids[last];
            for (uint32_t j = 0; j < last; ++j) {
                if (j == b) continue;
                const float v = d[j][last]; // j < last
                if (j < b) d[j][b] = v;
                else d[b][j] = v;
            }
        }
        live = last;
        box[a] = merged;
        ids[a] = node;
        for (uint32_t j = 0; j < live; ++j) {
            if (j == a) continue;
            const float v = scaled_union_half_area(merged, box[j], scale);
            if (j < a) d[j][a] = v;
            else d[a][j] = v;
        }
    }
    for (uint32_t i = 0; i < live; ++i) free_ids[i] = free_ids[used + i];
    return live;
}

uint32_t combine_small(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                       float scale, const FlattenRule &rule, ChoiceTable choices) {
    const uint32_t n = tree.leaf_count();
    Box box[kSmallCombine];
    float d[kSmallCombine][kSmallCombine];
    float nd[kSmallCombine];
    uint32_t nn[kSmallCombine];
    auto dist = [scale](const Box &a, const Box &b) { return scaled_union_half_area(a, b, scale); };
    auto choice = [&](uint32_t id) { return id < n ? rule.leaf(tree.boxes[id]) : choices.get(id - n); };

    for (uint32_t i = 0; i < count; ++i) box[i] = tree.boxes[ids[i]];
    for (uint32_t i = 0; i < count; ++i) {
        d[i][i] = INFINITY;
        for (uint32_t j = i + 1; j < count; ++j) d[i][j] = d[j][i] = dist(box[i], box[j]);
    }
    for (uint32_t i = 0; i < count; ++i) nn[i] = argmin_small(d[i], count, nd[i]);

    uint32_t live = count, used = 0;
    while (live > target) {
        float ignored;
        uint32_t a = argmin_small(nd, live, ignored);
        uint32_t b = nn[a];
        if (a > b) std::swap(a, b);

        const uint32_t node = free_ids[used++];
        const Box merged = unite(box[a], box[b]);
        tree.boxes[node] = merged;
        tree.set_children(node, ids[a], ids[b]);
        choices.set(node - n, rule.inner(merged, choice(ids[a]), choice(ids[b])));

        const uint32_t last = live - 1;
        if (b != last) {
            box[b] = box[last];
            ids[b] = ids[last];
            nd[b] = nd[last];
            nn[b] = nn[last];
            for (uint32_t j = 0; j < live; ++j) {
                d[b][j] = d[last][j];
                d[j][b] = d[j][last];
            }
            d[b][b] = INFINITY;
        }
        live = last;
        box[a] = merged;
        ids[a] = node;
        for (uint32_t j = 0; j < live; ++j) {
            const float daj = dist(merged, box[j]);
            d[a][j] = d[j][a] = daj;
        }
        d[a][a] = INFINITY;
        for (uint32_t j = 0; j < live; ++j) {
            if (j == a) continue;
            const float daj = d[a][j];
            uint32_t &p = nn[j];
            if (p == a || p == b) {
                p = argmin_small(d[j], live, nd[j]);
                continue;
            }
            p = p == last ? b : p;
            const bool closer = daj < nd[j] || (daj == nd[j] && a < p);
            nd[j] = closer ? daj : nd[j];
            p = closer ? a : p;
        }
        nn[a] = argmin_small(d[a], live, nd[a]);
    }
    for (uint32_t i = 0; i < live; ++i) free_ids[i] = free_ids[used + i];
    return live;
}

} // namespace

CombineScratchPool::CombineScratchPool(MemoryMeter *meter) : id_(next_pool_id()), meter_(meter) {}

CombineScratch &CombineScratchPool::local() {
    // Pools are short-lived and threads long-lived: each thread remembers its
    // scratch in the last pool it used, the common case in one build.
    struct Cached {
        uint64_t pool = 0;
        CombineScratch *scratch = nullptr;
    };
    static thread_local Cached cached;
    if (cached.pool == id_) return *cached.scratch;
    // A miss: the thread's first combine of this build, or its first after a
    // build started from a progress callback took the cache over. Its slot,
    // if it has one, is found by owner.
    const std::thread::id me = std::this_thread::get_id();
    std::lock_guard<std::mutex> lock(mutex_);
    CombineScratch *mine = nullptr;
    for (const auto &slot : slots_)
        if (slot->owner == me) mine = slot.get();
    if (!mine) {
        slots_.push_back(std::make_unique<CombineScratch>());
        mine = slots_.back().get();
        mine->meter = meter_;
        mine->owner = me;
    }
    cached = Cached{id_, mine};
    return *mine;
}

static_assert(kFewCombine <= 8, "combine_few_avx2 holds the clusters in eight lanes and their pairs in four registers");

static uint32_t combine_with_scratch(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count,
                                     uint32_t target, float scale, const FlattenRule &rule, ChoiceTable choices,
                                     CombineScratchPool &scratch_pool, BuildContext &ctx, CombineVariant variant);

uint32_t combine_clusters(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                          float scale, const FlattenRule &rule, ChoiceTable choices, CombineScratchPool &scratch_pool,
                          BuildContext &ctx, CombineVariant variant) {
    if (target < 1) target = 1;
    if (count <= target) return count;
    // With AVX2, combines of 9 to kWideSmallCombine clusters recompute rows in
    // registers, faster than the matrix (docs/PERFORMANCE.md, change 51); up
    // to kFewCombine the pair scan takes them (changes 112, 118 and 130).
    // Above that, AVX2 rows recomputed when needed beat the matrix's
    // bookkeeping (two strided column writes per merge) at every size
    // (change 76: dragon, the combines of ranges of 4,096 primitives and
    // more, AAC-Fast 29 -> 19 ms, AAC-HQ 38 -> 25 ms).
    // AVX-512 runs the same loops with 16 lanes a register (change 81), its
    // register loop up to kWideSmallCombine512 clusters (change 154).
    const DistanceKernel kernel = distance_kernel();
    const bool avx2 = kernel >= DistanceKernel::Avx2; // or AVX-512
    const uint32_t wide_limit = kernel == DistanceKernel::Avx512 ? kWideSmallCombine512 : kWideSmallCombine;
    const uint32_t small_limit = avx2 ? wide_limit : kSmallCombine;
    const uint32_t matrix_limit = avx2 ? wide_limit : kMatrixCombine;
    if (variant == CombineVariant::Automatic)
        variant = count <= small_limit    ? CombineVariant::Small
                  : count <= matrix_limit ? CombineVariant::Matrix
                                          : CombineVariant::Rows;
    if (variant == CombineVariant::Small && count <= small_limit) {
        // One merge: a scalar scan of every pair, except where the AVX2 pair
        // scan holds the clusters, from four on (it computes all pairs at
        // once; docs/PERFORMANCE.md row 130).
        const bool pair_scan = avx2 && count >= 4 && count <= kFewCombine;
        if (count == target + 1 && count <= kSmallCombine && !pair_scan)
            return combine_once(tree, ids, free_ids, count, scale, rule, choices);
        if (count <= kFewCombine)
            return avx2 ? combine_few_avx2(tree, ids, free_ids, count, target, scale, rule, choices)
                        : combine_few(tree, ids, free_ids, count, target, scale, rule, choices);
        if (kernel == DistanceKernel::Avx512 && count > 8)
            return combine_small_avx512(tree, ids, free_ids, count, target, scale, rule, choices);
        if (avx2 && count > 8) return combine_small_avx2(tree, ids, free_ids, count, target, scale, rule, choices);
        return combine_small(tree, ids, free_ids, count, target, scale, rule, choices);
    }
    return combine_with_scratch(tree, ids, free_ids, count, target, scale, rule, choices, scratch_pool, ctx, variant);
}

/// combine_clusters()' loops over scratch memory (the matrix and the rows),
/// out of line: their frame would otherwise cost every small combine a
/// longer entry and exit (docs/PERFORMANCE.md row 131).
[[gnu::noinline]] static uint32_t combine_with_scratch(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids,
                                                       uint32_t count, uint32_t target, float scale,
                                                       const FlattenRule &rule, ChoiceTable choices,
                                                       CombineScratchPool &scratch_pool, BuildContext &ctx,
                                                       CombineVariant variant) {
    CombineScratch &scratch = scratch_pool.local();
    const uint32_t stride = padded(count + 1);
    const MemoryMeter::Scope metered(scratch.meter); // growth counts in the build's peak
    if (scratch.columns.size() < 6 * size_t(stride)) scratch.columns.resize(6 * size_t(stride));
    if (scratch.nearest.size() < stride) { // padded: nearest_rows() reads and writes whole lanes
        scratch.nearest_distance.resize(stride);
        scratch.nearest.resize(stride);
        scratch.rescan.resize(stride);
    }
    const bool use_matrix = variant == CombineVariant::Matrix;
    const size_t matrix_floats = use_matrix ? size_t(count) * stride : stride;
    if (scratch.distances.size() < matrix_floats) scratch.distances.resize(matrix_floats);
    if (use_matrix) return combine<true>(tree, ids, free_ids, count, target, scale, rule, choices, scratch, ctx);
    return combine<false>(tree, ids, free_ids, count, target, scale, rule, choices, scratch, ctx);
}

} // namespace aacbvh
