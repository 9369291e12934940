// Ray queries over the 8-wide layout (bvh/wide8_bvh.h), with kernels chosen
// at run time from the CPU: a plain C++ one that builds anywhere, SSE2 (the
// x86-64 baseline), AVX2, and AVX-512 (the AVX2 kernel's code compiled
// for AVX-512 F, VL, BW and DQ, its single rays left to the AVX2 code,
// where that measured faster). Every kernel does the same floating-point
// operations in the same order for each ray and box, so all give the same
// hits bit for bit (the AVX2 kernel's batches trace runs of eight coherent
// rays together: the same tests in another order, and a closest hit does not
// depend on the order); the tests force each in turn (set_trace_kernel) on
// any host that can run it.
#pragma once

#include "aacbvh/aacbvh.h"
#include "bvh/bvh.h"
#include "bvh/wide8_bvh.h"
#include "core/geometry.h"
#include "trace/traversal.h"

namespace aacbvh {

enum class TraceKernel { Scalar, Sse2, Avx2, Avx512 };

/// Whether this build has the x86 vector kernels (AVX2 and AVX-512,
/// trace/wide8_kernel_x86.inl): GCC or Clang on x86-64.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AACBVH_WIDE8_X86_KERNELS 1
#else
#define AACBVH_WIDE8_X86_KERNELS 0
#endif

/// The kernel in use: the best this build and CPU can run, unless a test
/// forced another.
TraceKernel trace_kernel();
/// Whether this build and CPU can run `kernel`.
bool trace_kernel_available(TraceKernel kernel);
/// Makes `kernel` the one in use; false (nothing changes) if it is not
/// available. For tests and benchmarks: not thread-safe, never during queries.
bool set_trace_kernel(TraceKernel kernel);
const char *trace_kernel_name(TraceKernel kernel);

/// Closest hit of one ray (same t, u, v and prim_id as intersect_ray() on the
/// binary tree). `triangles`: the caller's geometry (packet leaves read their
/// own copy; slot leaves read the geometry through bvh.prim_ids).
void intersect_ray_wide8(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                         aacbvh_hit &hit);
/// Any hit of one ray (same answer as occluded_ray()).
bool occluded_ray_wide8(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray);

/// intersect_ray_wide8() over a tree with slot leaves (triangles referenced,
/// or boxes), adding its primitive tests to counters.primitive_tests (for the
/// tests of the visiting order; nodes are not counted). The same answer.
void intersect_ray_wide8_counted(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry,
                                 const aacbvh_ray &ray, aacbvh_hit &hit, TraversalCounters &counters);

/// One kernel's entry points (each kernel's file defines one).
struct Wide8Kernel {
    void (*intersect)(const Wide8Bvh &, const Bvh &, const Geometry &, const aacbvh_ray &, aacbvh_hit &);
    /// intersect() of rays[0, count) into hits[0, count), the same answers;
    /// a kernel may trace runs of coherent rays together.
    void (*intersect_batch)(const Wide8Bvh &, const Bvh &, const Geometry &, const aacbvh_ray *rays, aacbvh_hit *hits,
                            size_t count);
    bool (*occluded)(const Wide8Bvh &, const Bvh &, const Geometry &, const aacbvh_ray &);
    /// occluded() of rays[0, count) into out[0, count) (1: occluded), the
    /// same answers; a kernel may trace runs of coherent rays together.
    void (*occluded_batch)(const Wide8Bvh &, const Bvh &, const Geometry &, const aacbvh_ray *rays, uint8_t *out,
                           size_t count);
    void (*intersect_counted)(const Wide8Bvh &, const Bvh &, const Geometry &, const aacbvh_ray &, aacbvh_hit &,
                              TraversalCounters &);
};

/// The kernel in use, for a batch of queries (looked up once).
const Wide8Kernel &wide8_kernel();

} // namespace aacbvh
