// The radix-tree splits of sorted Morton codes, from one byte per code.
//
// AAC's downward phase (build/aac/aac_builder.cpp) splits a sorted range of
// codes where its highest differing bit changes. In sorted codes exactly one
// neighbouring pair of the range straddles that bit: every other pair also
// agrees on it, so it shares a longer prefix. The split is therefore the pair
// with the shortest common prefix, and the prefix lengths of neighbouring
// codes (one byte each, 64 for equal codes) decide every split without the
// codes (8 bytes each). The builder keeps the lengths instead of the codes
// through its recursion: 7 bytes a primitive off its memory peak
// (docs/PERFORMANCE.md, row 175).
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/scheduler.h"

namespace aacbvh {

/// Common prefix length of two codes: leading bits they share, 64 when equal.
inline uint8_t common_prefix(uint64_t a, uint64_t b) {
    const uint64_t x = a ^ b; // x | 1 has the leading zeros of x, or 63 when x = 0
    return uint8_t(__builtin_clzll(x | 1) + (x == 0));
}

/// Bytes readable past the end of an array that radix_split() and
/// first_minimum() search: they read 16 bytes at a time.
constexpr size_t kPrefixPadding = 16;

/// Where the sorted range [b, e) of the codes behind `prefix` splits (e - b >= 2).
struct RadixSplit {
    uint32_t at;  ///< first index of the right part, in (b, e)
    bool equal;   ///< all codes of the range are equal; `at` is then the middle
};

/// The split of [b, e): after the first pair in it with the shortest common
/// prefix; the middle when every pair is equal (prefix 64). `prefix` holds
/// kPrefixPadding readable bytes past its last pair.
RadixSplit radix_split(const uint8_t *prefix, uint32_t b, uint32_t e);

/// The first position of the smallest of bytes[0, count) (count >= 1): the
/// search radix_split() makes, SSE2 on x86-64 (reading up to
/// kPrefixPadding bytes past the end) and a plain loop elsewhere.
size_t first_minimum(const uint8_t *bytes, size_t count);

} // namespace aacbvh
