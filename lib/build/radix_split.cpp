#include "build/radix_split.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace aacbvh {

#if defined(__SSE2__)
namespace {

/// The smallest of the 16 bytes of v, in every byte.
inline __m128i broadcast_minimum(__m128i v) {
    v = _mm_min_epu8(v, _mm_srli_si128(v, 8));
    v = _mm_min_epu8(v, _mm_srli_si128(v, 4));
    v = _mm_min_epu8(v, _mm_srli_si128(v, 2));
    v = _mm_min_epu8(v, _mm_srli_si128(v, 1));
    return _mm_set1_epi8(char(_mm_cvtsi128_si32(v) & 0xFF));
}

inline __m128i load16(const uint8_t *p) { return _mm_loadu_si128(reinterpret_cast<const __m128i *>(p)); }

} // namespace
#endif

size_t first_minimum(const uint8_t *bytes, size_t count) {
#if defined(__SSE2__)
    if (count <= 16) {
        // One read of 16 bytes (kPrefixPadding), the lanes past count raised to 0xFF.
        const __m128i lane = _mm_setr_epi8(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
        const __m128i past = _mm_cmpgt_epi8(lane, _mm_set1_epi8(char(count - 1)));
        const __m128i v = _mm_or_si128(load16(bytes), past);
        const int hits = _mm_movemask_epi8(_mm_cmpeq_epi8(v, broadcast_minimum(v)));
        return size_t(__builtin_ctz(unsigned(hits))); // lane 0 is in range: a minimum is at or before it
    }
    // Whole 16-byte steps and a last step that overlaps the one before it:
    // the minimum, then the first step that holds it.
    const size_t last = count - 16;
    __m128i m = load16(bytes + last);
    for (size_t i = 0; i < last; i += 16) m = _mm_min_epu8(m, load16(bytes + i));
    const __m128i least = broadcast_minimum(m);
    for (size_t i = 0;; i += 16) {
        const size_t at = i < last ? i : last;
        const int hits = _mm_movemask_epi8(_mm_cmpeq_epi8(load16(bytes + at), least));
        if (hits != 0) return at + size_t(__builtin_ctz(unsigned(hits)));
    }
#else
    size_t at = 0;
    for (size_t i = 1; i < count; ++i)
        if (bytes[i] < bytes[at]) at = i;
    return at;
#endif
}

RadixSplit radix_split(const uint8_t *prefix, uint32_t b, uint32_t e) {
    // The pairs of [b, e) are prefix[b, e - 1).
    const size_t k = first_minimum(prefix + b, e - 1 - b);
    if (prefix[b + k] == 64) return {b + (e - b) / 2, true};
    return {uint32_t(b + k + 1), false};
}

} // namespace aacbvh
