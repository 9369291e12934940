// One row of AAC's cluster distance matrix: d(A, B_j) = half surface area of
// the union of box A with each box B_j, for boxes kept as structure of arrays.
// This is the innermost loop of every AAC build, so it has SIMD versions
// (SSE on every x86-64, AVX chosen at run time) and a scalar fallback.
#pragma once

#include <atomic>
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
/// (the nearest other box, the lowest index on ties) in one pass. count
/// may be anything: the fused AVX kernel tracks indices in float lanes, so
/// rows of 2^24 and more take the separate kernels.
uint32_t distance_row_argmin(const BoxColumns &boxes, uint32_t count, const float query[6], float scale, float *out,
                             uint32_t self, float &best);

/// The first nearest neighbours of a combine, rows [first, last) of them: for
/// each i there, nd[i] and nn[i] as distance_row_argmin(boxes, count, box i,
/// scale, ., i, nd[i]) gives them. The AVX kernels compute d(i, j) for j > i
/// only, once per pair (d(i, j) and d(j, i) are the same float): row i leaves
/// in nd[j] and nn[j], for each j > i, the smallest d(h, j) over the rows
/// h <= i and the lowest such h, and row j then takes the nearer of that and
/// its own part (the lower index on ties). So nd and nn must start at +inf
/// and 0 over [0, count rounded up to a multiple of 8) (they are read and
/// written that far), and rows [0, first) must be done. The other kernels
/// compute whole rows into `scratch` (count padded floats).
void nearest_rows(const BoxColumns &boxes, uint32_t count, float scale, uint32_t first, uint32_t last, float *nd,
                  uint32_t *nn, float *scratch);

/// Index of the smallest of row[0, count) (the lowest such index on ties),
/// with its value in `best`; count >= 1. Reads only row[0, count).
uint32_t argmin_row(const float *row, uint32_t count, float &best);

/// The kernels: chosen once from the CPU (AVX-512F where it has it and it
/// was measured to pay, else AVX2, else AVX, else SSE on x86-64, else plain
/// C++); all give bit-identical results. Tests force each in turn (set_distance_kernel, not thread-safe:
/// never during a build). Avx2 rows are the Avx ones; it adds the small
/// combines' AVX2 loop (build/aac/combine_small.h). Avx512 adds the small
/// combines' AVX-512 loop and rows of 16 lanes.
enum class DistanceKernel { Scalar, Sse, Avx, Avx2, Avx512 };
/// The kernel in use (distance_row.cpp sets it); read inline, so that a
/// small combine's dispatch (combine_clusters()) makes no call before its
/// own tail call (docs/PERFORMANCE.md row 131).
extern std::atomic<DistanceKernel> g_distance_kernel;
inline DistanceKernel distance_kernel() { return g_distance_kernel.load(std::memory_order_relaxed); }
/// Whether this build and CPU can run `kernel`.
bool kernel_available(DistanceKernel kernel);
/// Makes `kernel` the one in use; false (nothing changes) if it is not available.
bool set_distance_kernel(DistanceKernel kernel);

} // namespace aacbvh
