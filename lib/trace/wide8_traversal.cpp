// Picks the 8-wide traversal's kernel once from the CPU and forwards to it.
#include "trace/wide8_traversal.h"

#include <atomic>

namespace aacbvh {

extern const Wide8Kernel kWide8Scalar;
#if defined(__SSE2__)
extern const Wide8Kernel kWide8Sse2;
#endif
#if AACBVH_WIDE8_X86_KERNELS
extern const Wide8Kernel kWide8Avx2;
extern const Wide8Kernel kWide8Avx512;
#endif

bool trace_kernel_available(TraceKernel kernel) {
    switch (kernel) {
    case TraceKernel::Scalar: return true;
    case TraceKernel::Sse2:
#if defined(__SSE2__)
        return true;
#else
        return false;
#endif
#if AACBVH_WIDE8_X86_KERNELS
    case TraceKernel::Avx2: return __builtin_cpu_supports("avx2");
    case TraceKernel::Avx512:
        return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("avx512f") &&
               __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
               __builtin_cpu_supports("avx512dq");
#else
    case TraceKernel::Avx2:
    case TraceKernel::Avx512: return false;
#endif
    }
    return false;
}

namespace {

/// The fastest kernel this build and CPU can run.
TraceKernel best_kernel() {
    for (TraceKernel k : {TraceKernel::Avx512, TraceKernel::Avx2, TraceKernel::Sse2})
        if (trace_kernel_available(k)) return k;
    return TraceKernel::Scalar;
}

const Wide8Kernel &kernel_table(TraceKernel k) {
    switch (k) {
#if AACBVH_WIDE8_X86_KERNELS
    case TraceKernel::Avx512: return kWide8Avx512;
    case TraceKernel::Avx2: return kWide8Avx2;
#endif
#if defined(__SSE2__)
    case TraceKernel::Sse2: return kWide8Sse2;
#endif
    default: return kWide8Scalar;
    }
}

std::atomic<TraceKernel> &current_kernel() {
    static std::atomic<TraceKernel> k{best_kernel()};
    return k;
}

} // namespace

TraceKernel trace_kernel() { return current_kernel().load(std::memory_order_relaxed); }

bool set_trace_kernel(TraceKernel kernel) {
    if (!trace_kernel_available(kernel)) return false;
    current_kernel().store(kernel, std::memory_order_relaxed);
    return true;
}

const char *trace_kernel_name(TraceKernel kernel) {
    switch (kernel) {
    case TraceKernel::Scalar: return "scalar";
    case TraceKernel::Sse2: return "sse2";
    case TraceKernel::Avx2: return "avx2";
    case TraceKernel::Avx512: return "avx512";
    }
    return "unknown";
}

const Wide8Kernel &wide8_kernel() { return kernel_table(trace_kernel()); }

void intersect_ray_wide8(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray,
                         aacbvh_hit &hit) {
    kernel_table(trace_kernel()).intersect(wide, bvh, geometry, ray, hit);
}

void intersect_ray_wide8_counted(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry,
                                 const aacbvh_ray &ray, aacbvh_hit &hit, TraversalCounters &counters) {
    kernel_table(trace_kernel()).intersect_counted(wide, bvh, geometry, ray, hit, counters);
}

bool occluded_ray_wide8(const Wide8Bvh &wide, const Bvh &bvh, const Geometry &geometry, const aacbvh_ray &ray) {
    return kernel_table(trace_kernel()).occluded(wide, bvh, geometry, ray);
}

} // namespace aacbvh
