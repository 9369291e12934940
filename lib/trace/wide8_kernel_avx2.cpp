// The 8-wide traversal's AVX2 kernel (trace/wide8_kernel_x86.inl compiled
// for AVX2), called only on CPUs that have it (wide8_traversal.cpp).
#include <cstring>

#include "trace/child_order.h"
#include "trace/hit_record.h"
#include "trace/ray_primitives.h"
#include "trace/spill_stack.h"
#include "trace/wide8_traversal.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>

#include "trace/wide8_packet_sse.h"

// Everything defined from here to the end of the region is compiled for
// AVX2; the headers above stay baseline code, so no out-of-line copy of a
// shared inline function is ever AVX2 code.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif

namespace aacbvh {
namespace wide8_avx2 {
namespace {

#include "trace/wide8_kernel_x86.inl"

} // namespace
} // namespace wide8_avx2

extern const Wide8Kernel kWide8Avx2 = {wide8_avx2::intersect_entry, wide8_avx2::intersect_batch_entry,
                                       wide8_avx2::occluded_entry, wide8_avx2::occluded_batch_entry,
                                       wide8_avx2::intersect_counted_entry};

} // namespace aacbvh

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif
