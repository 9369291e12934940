// The 8-wide traversal's AVX-512 kernel: trace/wide8_kernel_x86.inl compiled
// for AVX-512 (F, VL, BW, DQ). The same operations in the same order as the
// AVX2 kernel, so the same answers; with 32 vector registers the runs of
// eight camera rays keep their rows out of memory and ran 2-14 % faster.
// Rays traced one by one ran slower compiled this way, so they go to the
// AVX2 kernel's code (docs/PERFORMANCE.md, row 259).
#define AACBVH_WIDE8_X86_TARGET "avx2,avx512f,avx512vl,avx512bw,avx512dq"
#define AACBVH_WIDE8_X86_NAMESPACE wide8_avx512
#define AACBVH_WIDE8_X86_TABLE kWide8Avx512
#define AACBVH_WIDE8_SINGLE_RAYS_FROM_AVX2 1
#include "trace/wide8_kernel_x86.inl"
