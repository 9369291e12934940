#include "build/aac/distance_row.h"

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>

#include "build/aac/combine_small.h"
#include "core/box.h"

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#include <immintrin.h>
#define AACBVH_X86 1
#endif

namespace aacbvh {

namespace {

void distance_row_scalar(const BoxColumns &b, uint32_t count, const float q[6], float scale, float *out) {
    const Box query{{q[0], q[1], q[2]}, {q[3], q[4], q[5]}};
    for (uint32_t j = 0; j < count; ++j) {
        const Box other{{b.lo[0][j], b.lo[1][j], b.lo[2][j]}, {b.hi[0][j], b.hi[1][j], b.hi[2][j]}};
        out[j] = scaled_union_half_area(other, query, scale);
    }
}

uint32_t argmin_row_scalar(const float *row, uint32_t count, float &best) {
    uint32_t arg = 0;
    best = row[0];
    for (uint32_t j = 1; j < count; ++j)
        if (row[j] < best) { best = row[j]; arg = j; }
    return arg;
}

#ifdef AACBVH_X86
void distance_row_sse(const BoxColumns &b, uint32_t count, const float q[6], float scale, float *out) {
    const __m128 qlx = _mm_set1_ps(q[0]), qly = _mm_set1_ps(q[1]), qlz = _mm_set1_ps(q[2]);
    const __m128 qhx = _mm_set1_ps(q[3]), qhy = _mm_set1_ps(q[4]), qhz = _mm_set1_ps(q[5]);
    const __m128 s = _mm_set1_ps(scale);
    for (uint32_t j = 0; j < count; j += 4) {
        const __m128 dx = _mm_mul_ps(_mm_sub_ps(_mm_max_ps(_mm_loadu_ps(b.hi[0] + j), qhx),
                                                _mm_min_ps(_mm_loadu_ps(b.lo[0] + j), qlx)), s);
        const __m128 dy = _mm_mul_ps(_mm_sub_ps(_mm_max_ps(_mm_loadu_ps(b.hi[1] + j), qhy),
                                                _mm_min_ps(_mm_loadu_ps(b.lo[1] + j), qly)), s);
        const __m128 dz = _mm_mul_ps(_mm_sub_ps(_mm_max_ps(_mm_loadu_ps(b.hi[2] + j), qhz),
                                                _mm_min_ps(_mm_loadu_ps(b.lo[2] + j), qlz)), s);
        const __m128 area = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dy), _mm_mul_ps(dy, dz)), _mm_mul_ps(dz, dx));
        _mm_storeu_ps(out + j, _mm_min_ps(area, _mm_set1_ps(FLT_MAX)));
    }
}

/// The query box broadcast to eight lanes, and the scale.
struct QueryAvx {
    __m256 lo[3], hi[3], scale;
};

__attribute__((target("avx"), always_inline)) inline QueryAvx query_avx(const float q[6], float scale) {
    QueryAvx r;
    for (int k = 0; k < 3; ++k) {
        r.lo[k] = _mm256_set1_ps(q[k]);
        r.hi[k] = _mm256_set1_ps(q[k + 3]);
    }
    r.scale = _mm256_set1_ps(scale);
    return r;
}

/// Distances from the query to boxes j .. j + 7, clamped to FLT_MAX.
__attribute__((target("avx"), always_inline)) inline __m256 distances_avx(const BoxColumns &b, uint32_t j,
                                                                            const QueryAvx &q) {
    __m256 d[3];
    for (int k = 0; k < 3; ++k)
        d[k] = _mm256_mul_ps(_mm256_sub_ps(_mm256_max_ps(_mm256_loadu_ps(b.hi[k] + j), q.hi[k]),
                                           _mm256_min_ps(_mm256_loadu_ps(b.lo[k] + j), q.lo[k])),
                             q.scale);
    const __m256 area =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(d[0], d[1]), _mm256_mul_ps(d[1], d[2])), _mm256_mul_ps(d[2], d[0]));
    return _mm256_min_ps(area, _mm256_set1_ps(FLT_MAX));
}

__attribute__((target("avx"))) void distance_row_avx(const BoxColumns &b, uint32_t count, const float q[6],
                                                      float scale, float *out) {
    const QueryAvx query = query_avx(q, scale);
    for (uint32_t j = 0; j < count; j += 8) _mm256_storeu_ps(out + j, distances_avx(b, j, query));
}

/// A lane-wise choice by a compare mask: `yes` where set, else `no`. With
/// kBlend one blend; else and / andnot / or, since GCC turns a blend on a
/// compare mask into a select that it lowers lane by lane when only AVX
/// (not AVX2) is enabled.
template <bool kBlend>
__attribute__((target("avx"), always_inline)) inline __m256 select_lanes(__m256 mask, __m256 yes, __m256 no) {
    if (kBlend) return _mm256_blendv_ps(no, yes, mask);
    return _mm256_or_ps(_mm256_and_ps(mask, yes), _mm256_andnot_ps(mask, no));
}

/// The AVX row with the nearest-neighbour search folded in: lanes past
/// `count` and the `self` lane are not candidates; each lane keeps its
/// smallest value and the first index holding it, then the lanes reduce.
template <bool kBlend>
__attribute__((target("avx"), always_inline)) inline uint32_t row_argmin_avx(const BoxColumns &b, uint32_t count,
                                                                             const float q[6], float scale, float *out,
                                                                             uint32_t self, float &best) {
    const QueryAvx query = query_avx(q, scale);
    const __m256 inf = _mm256_set1_ps(INFINITY);
    const __m256 self_index = _mm256_set1_ps(float(self)), end = _mm256_set1_ps(float(count));
    const __m256 eight = _mm256_set1_ps(8.0f);
    __m256 index = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
    __m256 m = inf, at = _mm256_setzero_ps();
    for (uint32_t j = 0; j < count; j += 8, index = _mm256_add_ps(index, eight)) {
        __m256 area = distances_avx(b, j, query);
        area = select_lanes<kBlend>(_mm256_cmp_ps(index, self_index, _CMP_EQ_OQ), inf, area);
        _mm256_storeu_ps(out + j, area);
        const __m256 candidate = select_lanes<kBlend>(_mm256_cmp_ps(index, end, _CMP_LT_OQ), area, inf);
        const __m256 less = _mm256_cmp_ps(candidate, m, _CMP_LT_OQ);
        m = _mm256_min_ps(candidate, m); // = candidate where less, else m
        at = select_lanes<kBlend>(less, index, at);
    }
    __m256 h = _mm256_min_ps(m, _mm256_permute2f128_ps(m, m, 1));
    h = _mm256_min_ps(h, _mm256_shuffle_ps(h, h, _MM_SHUFFLE(1, 0, 3, 2)));
    h = _mm256_min_ps(h, _mm256_shuffle_ps(h, h, _MM_SHUFFLE(2, 3, 0, 1)));
    alignas(32) float where[8];
    _mm256_store_ps(where, at);
    int lanes = _mm256_movemask_ps(_mm256_cmp_ps(m, h, _CMP_EQ_OQ));
    float arg = lanes ? where[__builtin_ctz(unsigned(lanes))] : 0.0f;
    for (lanes &= lanes - 1; lanes; lanes &= lanes - 1) arg = std::min(arg, where[__builtin_ctz(unsigned(lanes))]);
    best = _mm256_cvtss_f32(h);
    return uint32_t(arg);
}

__attribute__((target("avx"))) uint32_t distance_row_argmin_avx(const BoxColumns &b, uint32_t count, const float q[6],
                                                                float scale, float *out, uint32_t self, float &best) {
    return row_argmin_avx<false>(b, count, q, scale, out, self, best);
}

/// The same with AVX2 enabled, where a blend stays one instruction.
__attribute__((target("avx2"))) uint32_t distance_row_argmin_avx2(const BoxColumns &b, uint32_t count,
                                                                  const float q[6], float scale, float *out,
                                                                  uint32_t self, float &best) {
    return row_argmin_avx<true>(b, count, q, scale, out, self, best);
}


/// nearest_rows() with eight lanes: row i covers the slots above it only and
/// leaves its distances as column minima for the rows below them.
template <bool kBlend>
__attribute__((target("avx"), always_inline)) inline void rows_nearest_avx(const BoxColumns &b, uint32_t count,
                                                                           float scale, uint32_t first, uint32_t last,
                                                                           float *nd, uint32_t *nn) {
    const __m256 inf = _mm256_set1_ps(INFINITY), end = _mm256_set1_ps(float(count)), eight = _mm256_set1_ps(8.0f);
    for (uint32_t i = first; i < last; ++i) {
        const float q[6] = {b.lo[0][i], b.lo[1][i], b.lo[2][i], b.hi[0][i], b.hi[1][i], b.hi[2][i]};
        const QueryAvx query = query_avx(q, scale);
        const __m256 self = _mm256_set1_ps(float(i));
        const __m256 row_bits = _mm256_castsi256_ps(_mm256_set1_epi32(int(i)));
        const uint32_t start = (i + 1) & ~7u;
        __m256 index = _mm256_add_ps(_mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7), _mm256_set1_ps(float(start)));
        __m256 m = inf, at = _mm256_setzero_ps();
        for (uint32_t j = start; j < count; j += 8, index = _mm256_add_ps(index, eight)) {
            const __m256 area = distances_avx(b, j, query);
            const __m256 above = _mm256_and_ps(_mm256_cmp_ps(index, self, _CMP_GT_OQ), _mm256_cmp_ps(index, end, _CMP_LT_OQ));
            const __m256 candidate = select_lanes<kBlend>(above, area, inf);
            const __m256 less = _mm256_cmp_ps(candidate, m, _CMP_LT_OQ);
            m = _mm256_min_ps(candidate, m);
            at = select_lanes<kBlend>(less, index, at);
            // The slots above i: row i is their nearest lower row if strictly
            // closer than the rows before it (so the lowest row wins ties).
            const __m256 column = _mm256_loadu_ps(nd + j);
            const __m256 closer = _mm256_cmp_ps(candidate, column, _CMP_LT_OQ);
            _mm256_storeu_ps(nd + j, select_lanes<kBlend>(closer, candidate, column));
            float *owner = reinterpret_cast<float *>(nn + j);
            _mm256_storeu_ps(owner, select_lanes<kBlend>(closer, row_bits, _mm256_loadu_ps(owner)));
        }
        __m256 h = _mm256_min_ps(m, _mm256_permute2f128_ps(m, m, 1));
        h = _mm256_min_ps(h, _mm256_shuffle_ps(h, h, _MM_SHUFFLE(1, 0, 3, 2)));
        h = _mm256_min_ps(h, _mm256_shuffle_ps(h, h, _MM_SHUFFLE(2, 3, 0, 1)));
        const float up = _mm256_cvtss_f32(h);
        if (nd[i] <= up) continue; // the nearest lies below i (or no slot lies above it)
        alignas(32) float where[8];
        _mm256_store_ps(where, at);
        int lanes = _mm256_movemask_ps(_mm256_cmp_ps(m, h, _CMP_EQ_OQ));
        float arg = where[__builtin_ctz(unsigned(lanes))];
        for (lanes &= lanes - 1; lanes; lanes &= lanes - 1) arg = std::min(arg, where[__builtin_ctz(unsigned(lanes))]);
        nd[i] = up;
        nn[i] = uint32_t(arg);
    }
}

__attribute__((target("avx"))) void nearest_rows_avx(const BoxColumns &b, uint32_t count, float scale, uint32_t first,
                                                      uint32_t last, float *nd, uint32_t *nn) {
    rows_nearest_avx<false>(b, count, scale, first, last, nd, nn);
}

/// The same with AVX2 enabled, where a blend stays one instruction.
__attribute__((target("avx2"))) void nearest_rows_avx2(const BoxColumns &b, uint32_t count, float scale, uint32_t first,
                                                        uint32_t last, float *nd, uint32_t *nn) {
    rows_nearest_avx<true>(b, count, scale, first, last, nd, nn);
}

// GCC 12's avx512fintrin.h warns of its own self-initialised placeholder
// operands (`__Y = __Y`) once they are inlined.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif

/// distance_row_argmin_avx() with 16 lanes and mask registers: the same
/// distances (the same operations in the same order), the same candidates
/// and the same tie rule (each lane keeps the first index at its minimum,
/// then the lowest index among the lanes holding the row's minimum).
__attribute__((target("avx512f"))) uint32_t distance_row_argmin_avx512(const BoxColumns &b, uint32_t count,
                                                                      const float q[6], float scale, float *out,
                                                                      uint32_t self, float &best) {
    __m512 lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        lo[k] = _mm512_set1_ps(q[k]);
        hi[k] = _mm512_set1_ps(q[k + 3]);
    }
    const __m512 s = _mm512_set1_ps(scale), inf = _mm512_set1_ps(INFINITY), fmax = _mm512_set1_ps(FLT_MAX);
    const __m512 self_index = _mm512_set1_ps(float(self)), end = _mm512_set1_ps(float(count));
    const __m512 sixteen = _mm512_set1_ps(16.0f);
    __m512 index = _mm512_setr_ps(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    __m512 m = inf, at = _mm512_setzero_ps();
    uint32_t j = 0;
    for (; j < count; j += 16, index = _mm512_add_ps(index, sixteen)) {
        // Rows are padded to a multiple of 8 only: the last block of 16 may
        // reach 8 lanes past the padding, so it loads and stores under a mask.
        const uint32_t readable = ((count + 7) & ~7u) - j;
        const __mmask16 lanes = readable >= 16 ? __mmask16(0xffff) : __mmask16((1u << readable) - 1);
        __m512 d[3];
        for (int k = 0; k < 3; ++k)
            d[k] = _mm512_mul_ps(_mm512_sub_ps(_mm512_max_ps(_mm512_maskz_loadu_ps(lanes, b.hi[k] + j), hi[k]),
                                               _mm512_min_ps(_mm512_maskz_loadu_ps(lanes, b.lo[k] + j), lo[k])),
                                 s);
        __m512 area =
            _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(d[0], d[1]), _mm512_mul_ps(d[1], d[2])), _mm512_mul_ps(d[2], d[0]));
        area = _mm512_min_ps(area, fmax);
        area = _mm512_mask_mov_ps(area, _mm512_cmp_ps_mask(index, self_index, _CMP_EQ_OQ), inf);
        _mm512_mask_storeu_ps(out + j, lanes, area);
        const __m512 candidate = _mm512_mask_mov_ps(inf, _mm512_cmp_ps_mask(index, end, _CMP_LT_OQ), area);
        const __mmask16 less = _mm512_cmp_ps_mask(candidate, m, _CMP_LT_OQ);
        m = _mm512_min_ps(candidate, m); // = candidate where less, else m
        at = _mm512_mask_mov_ps(at, less, index);
    }
    const float low = _mm512_reduce_min_ps(m);
    const __mmask16 holding = _mm512_cmp_ps_mask(m, _mm512_set1_ps(low), _CMP_EQ_OQ);
    // The lowest index among the lanes at the minimum (lanes never at it hold +inf).
    const float arg = _mm512_mask_reduce_min_ps(holding, at);
    best = low;
    return holding ? uint32_t(arg) : 0;
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif



/// Minimum of row[0, count) and the first index holding it, in one pass:
/// each of four lanes keeps its smallest value and where it first saw it
/// (strict compares keep the earliest), then the lanes are reduced.
uint32_t argmin_row_sse(const float *row, uint32_t count, float &best) {
    __m128 m = _mm_set1_ps(INFINITY);
    __m128i at = _mm_set1_epi32(0);
    __m128i index = _mm_setr_epi32(0, 1, 2, 3);
    const __m128i four = _mm_set1_epi32(4);
    uint32_t j = 0;
    for (; j + 4 <= count; j += 4, index = _mm_add_epi32(index, four)) {
        const __m128 x = _mm_loadu_ps(row + j);
        const __m128i less = _mm_castps_si128(_mm_cmplt_ps(x, m));
        m = _mm_min_ps(m, x);
        at = _mm_or_si128(_mm_andnot_si128(less, at), _mm_and_si128(less, index));
    }
    float v = INFINITY;
    uint32_t arg = 0;
    if (j > 0) {
        // The smallest lane value, then the earliest index among the lanes holding it.
        __m128 h = _mm_min_ps(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(2, 3, 0, 1)));
        h = _mm_min_ps(h, _mm_shuffle_ps(h, h, _MM_SHUFFLE(1, 0, 3, 2)));
        v = _mm_cvtss_f32(h);
        alignas(16) uint32_t where[4];
        _mm_store_si128(reinterpret_cast<__m128i *>(where), at);
        int lanes = _mm_movemask_ps(_mm_cmpeq_ps(m, h));
        arg = lanes ? where[__builtin_ctz(unsigned(lanes))] : 0;
        for (lanes &= lanes - 1; lanes; lanes &= lanes - 1) arg = std::min(arg, where[__builtin_ctz(unsigned(lanes))]);
    }
    for (; j < count; ++j)
        if (row[j] < v || (j == 0)) {
            v = row[j];
            arg = j;
        }
    if (!(v == v)) return argmin_row_scalar(row, count, best); // NaN entries: valid boxes never give them
    best = v;
    return arg;
}
#endif


/// Indices are tracked in float lanes by the fused AVX kernel: exact below 2^24.
constexpr uint32_t kFloatIndexLimit = uint32_t(1) << 24;

/// The most capable kernel this build and CPU can run.
DistanceKernel best_kernel() {
#ifdef AACBVH_X86
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f") && combine_small_avx512_compiled()) return DistanceKernel::Avx512;
    if (__builtin_cpu_supports("avx2") && combine_small_avx2_compiled()) return DistanceKernel::Avx2;
    return __builtin_cpu_supports("avx") ? DistanceKernel::Avx : DistanceKernel::Sse;
#else
    return DistanceKernel::Scalar;
#endif
}

/// Whether the AVX-512 combines pay on this CPU: measured faster on an AMD
/// Zen 5 (family 1Ah: AAC-HQ 3-8 % faster, AAC-Fast unchanged,
/// docs/PERFORMANCE.md row 81), not on an Intel Xeon (Sapphire Rapids: no
/// gain for AAC-HQ, AAC-Fast 4 % slower, row 53). Other CPUs keep AVX2 until
/// measured; tests force AVX-512 on any CPU that has it.
bool avx512_pays() {
#if defined(AACBVH_X86) && (defined(__GNUC__) || defined(__clang__))
    unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
    if (!__get_cpuid(0, &eax, &ebx, &ecx, &edx)) return false;
    const bool amd = ebx == 0x68747541u && edx == 0x69746e65u && ecx == 0x444d4163u; // "AuthenticAMD"
    if (!amd || !__get_cpuid(1, &eax, &ebx, &ecx, &edx)) return false;
    unsigned family = (eax >> 8) & 0xFu;
    if (family == 0xFu) family += (eax >> 20) & 0xFFu;
    return family >= 0x1Au;
#else
    return false;
#endif
}

/// The kernel builds use unless a test forces another.
DistanceKernel default_kernel() {
    const DistanceKernel best = best_kernel();
    return best == DistanceKernel::Avx512 && !avx512_pays() ? DistanceKernel::Avx2 : best;
}

} // namespace

std::atomic<DistanceKernel> g_distance_kernel{default_kernel()};

bool kernel_available(DistanceKernel kernel) {
    switch (kernel) {
    case DistanceKernel::Scalar: return true;
#ifdef AACBVH_X86
    case DistanceKernel::Sse: return true;
    case DistanceKernel::Avx: return best_kernel() >= DistanceKernel::Avx;
    case DistanceKernel::Avx2: return best_kernel() >= DistanceKernel::Avx2;
    case DistanceKernel::Avx512: return best_kernel() >= DistanceKernel::Avx512;
#endif
    default: return false;
    }
}

bool set_distance_kernel(DistanceKernel kernel) {
    if (!kernel_available(kernel)) return false;
    g_distance_kernel.store(kernel, std::memory_order_relaxed);
    return true;
}

uint32_t argmin_row(const float *row, uint32_t count, float &best) {
#ifdef AACBVH_X86
    if (distance_kernel() != DistanceKernel::Scalar) return argmin_row_sse(row, count, best);
#endif
    return argmin_row_scalar(row, count, best);
}

uint32_t distance_row_argmin(const BoxColumns &boxes, uint32_t count, const float query[6], float scale, float *out,
                             uint32_t self, float &best) {
#ifdef AACBVH_X86
    if (distance_kernel() == DistanceKernel::Avx512 && count < kFloatIndexLimit)
        return distance_row_argmin_avx512(boxes, count, query, scale, out, self, best);
    if (distance_kernel() == DistanceKernel::Avx2 && count < kFloatIndexLimit)
        return distance_row_argmin_avx2(boxes, count, query, scale, out, self, best);
    if (distance_kernel() >= DistanceKernel::Avx && count < kFloatIndexLimit)
        return distance_row_argmin_avx(boxes, count, query, scale, out, self, best);
#endif
    distance_row(boxes, count, query, scale, out);
    out[self] = INFINITY;
    return argmin_row(out, count, best);
}

void nearest_rows(const BoxColumns &boxes, uint32_t count, float scale, uint32_t first, uint32_t last, float *nd,
                  uint32_t *nn, float *scratch) {
#ifdef AACBVH_X86
    if (distance_kernel() >= DistanceKernel::Avx2 && count < kFloatIndexLimit) {
        nearest_rows_avx2(boxes, count, scale, first, last, nd, nn);
        return;
    }
    if (distance_kernel() >= DistanceKernel::Avx && count < kFloatIndexLimit) {
        nearest_rows_avx(boxes, count, scale, first, last, nd, nn);
        return;
    }
#endif
    for (uint32_t i = first; i < last; ++i) {
        const float q[6] = {boxes.lo[0][i], boxes.lo[1][i], boxes.lo[2][i], boxes.hi[0][i], boxes.hi[1][i], boxes.hi[2][i]};
        nn[i] = distance_row_argmin(boxes, count, q, scale, scratch, i, nd[i]);
    }
}

void distance_row(const BoxColumns &boxes, uint32_t count, const float query[6], float scale, float *out) {
    switch (distance_kernel()) {
#ifdef AACBVH_X86
    case DistanceKernel::Avx:
    case DistanceKernel::Avx2:
    case DistanceKernel::Avx512: distance_row_avx(boxes, count, query, scale, out); return;
    case DistanceKernel::Sse: distance_row_sse(boxes, count, query, scale, out); return;
#endif
    default: distance_row_scalar(boxes, count, query, scale, out); return;
    }
}

} // namespace aacbvh
