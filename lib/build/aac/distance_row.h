// One row of AAC's cluster distance matrix: d(A, B_j) = half surface area of
// the union of box A with each box B_j, for boxes kept as structure of arrays.
// This is the innermost loop of every AAC build, so it has SIMD versions
// (SSE on every x86-64, AVX chosen at run time) and a scalar fallback.
#pragma once

#include <cstdint>

namespace aacbvh {

/// Boxes of the live clusters, one array per coordinate.
struct BoxColumns {
    float *lo[3];
    float *hi[3];
};

/// out[j] = scale^2-weighted half area of union(query, boxes j), j in [0, count),
/// clamped to FLT_MAX: a scene wider than FLT_MAX overflows the extents before
/// scaling, and an inf or NaN distance would let a cluster pair with itself
/// (the matrix diagonal is +inf).
/// query = {lo x, y, z, hi x, y, z}. All arrays may be read up to the next
/// multiple of 8 past count (callers pad them).
void distance_row(const BoxColumns &boxes, uint32_t count, const float query[6], float scale, float *out);

/// distance_row() with out[self] = +inf, returning argmin_row() of the result
/// (the nearest other box, the lowest index on ties) in one pass. count must
/// be below 2^24 (indices are tracked in float lanes).
uint32_t distance_row_argmin(const BoxColumns &boxes, uint32_t count, const float query[6], float scale, float *out,
                             uint32_t self, float &best);

/// Index of the smallest of row[0, count) (the lowest such index on ties),
/// with its value in `best`; count >= 1. Reads only row[0, count).
uint32_t argmin_row(const float *row, uint32_t count, float &best);

} // namespace aacbvh
