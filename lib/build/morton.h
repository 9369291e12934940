// Morton (Z-order) codes of primitive centroids, 21 bits per axis (63 bits in
// all) so that large scenes do not tie (the paper used 30 bits).
#pragma once

#include <algorithm>
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "build/build_input.h"
#include "core/box.h"
#include "core/memory.h"
#include "core/scheduler.h"

namespace aacbvh {

/// Spreads the low 21 bits of x so that bit i lands on bit 3i (the
/// arithmetic form; MortonQuantizer spreads by tables).
inline uint64_t spread_bits_21(uint64_t x) {
    x &= 0x1FFFFF;
    x = (x | x << 32) & 0x1F00000000FFFFull;
    x = (x | x << 16) & 0x1F0000FF0000FFull;
    x = (x | x << 8) & 0x100F00F00F00F00Full;
    x = (x | x << 4) & 0x10C30C30C30C30C3ull;
    x = (x | x << 2) & 0x1249249249249249ull;
    return x;
}

/// spread[a][b]: the bits i of byte b at bits 3i + 2 - a, for axis a (x 0,
/// y 1, z 2): one byte of each axis makes 24 bits of a Morton code.
struct MortonByteTable {
    uint32_t spread[3][256];
    constexpr MortonByteTable() : spread{} {
        for (int a = 0; a < 3; ++a)
            for (uint32_t b = 0; b < 256; ++b) {
                uint32_t s = 0;
                for (int i = 0; i < 8; ++i) s |= (b >> i & 1u) << (3 * i + 2 - a);
                spread[a][b] = s;
            }
    }
};
inline constexpr MortonByteTable kMortonBytes{};

/// Maps points of `bounds` onto a grid of 2^21 cells per axis. The cells are
/// cubes (one scale, from the largest extent), so the radix-tree splits of an
/// elongated scene stay balanced in world space; per-axis scales would split
/// a long, flat room as often across its height as along its length. This
/// gave slightly cheaper trees on most scenes (figures: docs/PERFORMANCE.md,
/// "Tree quality: cubic Morton cells"). Computed in double so that bounds spanning
/// most of the float range do not overflow.
class MortonQuantizer {
public:
    explicit MortonQuantizer(const Box &bounds) {
        double largest = 0.0;
        for (int k = 0; k < 3; ++k) largest = std::max(largest, double(bounds.hi[k]) - double(bounds.lo[k]));
        for (int k = 0; k < 3; ++k) {
            origin_[k] = bounds.lo[k];
            scale_[k] = largest > 0.0 ? double(kCells) / largest : 0.0;
        }
    }
    /// The cell's coordinates interleaved, x highest: bit i of x, y, z at
    /// bits 3i + 2, 3i + 1, 3i. Spread a byte at a time through tables (nine
    /// loads instead of fifteen shift, or and mask steps per axis); the same
    /// codes as spread_bits_21 (tests/test_morton_sort.cpp checks every value).
    uint64_t code(const float p[3]) const {
        uint32_t q[3];
        for (int k = 0; k < 3; ++k) {
            const double cell = (double(p[k]) - origin_[k]) * scale_[k];
            // In range, the cell fits an int64_t, whose conversion is one
            // instruction (uint64_t's is not, before AVX-512).
            q[k] = cell <= 0.0 ? 0 : cell >= double(kCells - 1) ? uint32_t(kCells - 1) : uint32_t(int64_t(cell));
        }
        return interleave(q);
    }

    /// code() of the box's centroid (Box::centroid()). With SSE2 the three
    /// axes go two and one to a register, by the same float and double
    /// operations: max with 0, then min with the last cell, then truncation
    /// give what code()'s comparisons give, NaN included (0).
    uint64_t centroid_code(const Box &box) const {
#if defined(__SSE2__)
        static_assert(sizeof(Box) == 6 * sizeof(float), "Box is lo[3] then hi[3]");
        const float *f = reinterpret_cast<const float *>(&box);
        const __m128 lo = _mm_loadu_ps(f);          // lo x, y, z, hi x
        const __m128 upper = _mm_loadu_ps(f + 2);   // lo z, hi x, y, z
        const __m128 hi = _mm_shuffle_ps(upper, upper, _MM_SHUFFLE(3, 3, 2, 1)); // hi x, y, z, z
        const __m128 half = _mm_set1_ps(0.5f);
        const __m128 c = _mm_add_ps(_mm_mul_ps(half, lo), _mm_mul_ps(half, hi));
        const __m128d zero = _mm_setzero_pd(), last = _mm_set1_pd(double(kCells - 1));
        const __m128d cell_xy = _mm_mul_pd(_mm_sub_pd(_mm_cvtps_pd(c), _mm_loadu_pd(origin_)), _mm_loadu_pd(scale_));
        const __m128d cell_z =
            _mm_mul_pd(_mm_sub_pd(_mm_cvtps_pd(_mm_movehl_ps(c, c)), _mm_loadu_pd(origin_ + 2)), _mm_loadu_pd(scale_ + 2));
        const __m128i q_xy = _mm_cvttpd_epi32(_mm_min_pd(_mm_max_pd(cell_xy, zero), last));
        const __m128i q_z = _mm_cvttpd_epi32(_mm_min_pd(_mm_max_pd(cell_z, zero), last));
        const uint32_t q[3] = {uint32_t(_mm_cvtsi128_si32(q_xy)), uint32_t(_mm_cvtsi128_si32(_mm_srli_si128(q_xy, 4))),
                               uint32_t(_mm_cvtsi128_si32(q_z))};
        return interleave(q);
#else
        const float c[3] = {box.centroid(0), box.centroid(1), box.centroid(2)};
        return code(c);
#endif
    }

private:
    static constexpr uint64_t kCells = uint64_t(1) << 21;

    static uint64_t interleave(const uint32_t q[3]) {
        const uint32_t(&t)[3][256] = kMortonBytes.spread;
        const uint64_t low = t[0][q[0] & 255] | t[1][q[1] & 255] | t[2][q[2] & 255];
        const uint64_t mid = t[0][q[0] >> 8 & 255] | t[1][q[1] >> 8 & 255] | t[2][q[2] >> 8 & 255];
        const uint64_t high = t[0][q[0] >> 16] | t[1][q[1] >> 16] | t[2][q[2] >> 16];
        return low | mid << 24 | high << 48;
    }

    double origin_[4] = {}; ///< x, y, z and a spare 0 (centroid_code() loads pairs)
    double scale_[4] = {};
};

/// Sorts the input's primitives by the Morton codes of their box centroids
/// (quantised in input.centroid_bounds): codes[i] is the i-th smallest code
/// and order[i] the input entry it belongs to. Equal codes keep input order.
/// The sort works in kMortonSortWords 64-bit words a primitive: `room`'s
/// when the caller has them to spare (at least that many times
/// input.size(), 8-byte aligned; AAC passes the room it keeps for its tree
/// in the input's box array, InputRoom::Tree), else an array of its own.
constexpr size_t kMortonSortWords = 3;
void sort_by_morton_code(const BuildInput &input, Scheduler &scheduler, Array<uint64_t> &codes,
                         Array<uint32_t> &order, uint64_t *room = nullptr);
/// The same for callers that need only the order and the common prefix
/// lengths of neighbouring codes (AAC's splits, build/radix_split.h):
/// prefix[i] = common_prefix(code i, code i + 1) for i + 1 < input.size(),
/// written from the sort's work without an array of the codes (8 bytes a
/// primitive of fresh memory and a pass over them; docs/PERFORMANCE.md,
/// row 216).
void sort_by_morton_prefixes(const BuildInput &input, Scheduler &scheduler, Array<uint32_t> &order, uint8_t *prefix,
                             uint64_t *room = nullptr);

/// Morton codes of `count` boxes (`box_at(i)`) on a grid over their own
/// centroids, into `codes[0, count)`, and into `rank` the positions in the
/// order of those codes (equal codes in position order). False, with
/// nothing written, when the centroids are all one point: no grid
/// separates them. For clusters that share one cell of the scene's grid
/// (refine_equal_code_runs() below; AAC's ranges, build/aac/aac_builder.cpp).
template <class BoxAt>
bool local_morton_order(size_t count, const BoxAt &box_at, Array<uint64_t> &codes, Array<uint32_t> &rank) {
    Box bounds = Box::empty();
    for (size_t i = 0; i < count; ++i) {
        const Box &box = box_at(i);
        const float c[3] = {box.centroid(0), box.centroid(1), box.centroid(2)};
        bounds.extend(c);
    }
    if (!(bounds.hi[0] > bounds.lo[0] || bounds.hi[1] > bounds.lo[1] || bounds.hi[2] > bounds.lo[2])) return false;
    const MortonQuantizer grid(bounds);
    codes.resize(count);
    rank.resize(count);
    for (size_t i = 0; i < count; ++i) {
        codes[i] = grid.centroid_code(box_at(i));
        rank[i] = uint32_t(i);
    }
    std::sort(rank.begin(), rank.end(),
              [&](uint32_t x, uint32_t y) { return codes[x] < codes[y] || (codes[x] == codes[y] && x < y); });
    return true;
}

/// After sort_by_morton_code(): each run of at least `min_run` equal codes
/// whose centroids are not all one point (a cluster that shares one cell of
/// the scene's grid, such as small primitives far from an outlier) gets codes
/// on a grid over its own centroids and is sorted by them, ties keeping their
/// order; runs it leaves equal are refined again. For builders that use the
/// whole order at once (PLOC); AAC refines inside its recursion instead
/// (build/aac/aac_builder.cpp), where it also scales its distances per range.
void refine_equal_code_runs(const BuildInput &input, Array<uint64_t> &codes, Array<uint32_t> &order, size_t min_run);

} // namespace aacbvh
