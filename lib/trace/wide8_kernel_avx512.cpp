// The 8-wide traversal's AVX-512 kernel: trace/wide8_kernel_x86.inl compiled
// for AVX-512 (F, VL, BW, DQ), called only on CPUs that have them
// (wide8_traversal.cpp). The same operations in the same order as the AVX2
// kernel, so the same answers; with 32 vector registers the runs of eight
// camera rays keep their rows out of memory and ran 8-10 % faster. Rays
// traced one by one ran slower compiled this way, so they go to the AVX2
// kernel's code (docs/PERFORMANCE.md, row 259).
#include <cstring>

#include "trace/child_order.h"
#include "trace/hit_record.h"
#include "trace/ray_primitives.h"
#include "trace/spill_stack.h"
#include "trace/wide8_traversal.h"

#if AACBVH_WIDE8_AVX512_KERNEL
#include <immintrin.h>

#include "trace/wide8_packet_sse.h"

// Everything defined from here to the end of the region is compiled for
// AVX-512; the headers above stay baseline code.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2,avx512f,avx512vl,avx512bw,avx512dq"))), \
                             apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,avx512f,avx512vl,avx512bw,avx512dq")
#endif

namespace aacbvh {

extern const Wide8Kernel kWide8Avx2;

namespace wide8_avx512 {
namespace {

#define AACBVH_WIDE8_SINGLE_RAYS_FROM_AVX2 1
#include "trace/wide8_kernel_x86.inl"

} // namespace
} // namespace wide8_avx512

extern const Wide8Kernel kWide8Avx512 = {wide8_avx512::intersect_entry, wide8_avx512::intersect_batch_entry,
                                         wide8_avx512::occluded_entry, wide8_avx512::occluded_batch_entry,
                                         wide8_avx512::intersect_counted_entry};

} // namespace aacbvh

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif
