// The 8-wide traversal's AVX2 kernel: trace/wide8_kernel_x86.inl compiled
// for AVX2.
#define AACBVH_WIDE8_X86_TARGET "avx2"
#define AACBVH_WIDE8_X86_NAMESPACE wide8_avx2
#define AACBVH_WIDE8_X86_TABLE kWide8Avx2
#include "trace/wide8_kernel_x86.inl"
