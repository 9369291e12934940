#include "radix_sort.h"

#include <cstring>

namespace aacbvh {

void radix_sort_pairs(Array<uint64_t> &keys, Array<uint32_t> &values, unsigned key_bits) {
    constexpr unsigned kDigitBits = 11;
    constexpr size_t kBuckets = size_t(1) << kDigitBits;
    const size_t n = keys.size();
    if (n < 2) return;
    const unsigned passes = (key_bits + kDigitBits - 1) / kDigitBits;

    // One read of the keys builds every pass's histogram.
    std::vector<uint32_t> histograms(passes * kBuckets, 0);
    for (size_t i = 0; i < n; ++i) {
        const uint64_t k = keys[i];
        for (unsigned p = 0; p < passes; ++p) ++histograms[p * kBuckets + ((k >> (p * kDigitBits)) & (kBuckets - 1))];
    }

    Array<uint64_t> keys_tmp(n);
    Array<uint32_t> values_tmp(n);
    for (unsigned p = 0; p < passes; ++p) {
        uint32_t *hist = &histograms[p * kBuckets];
        const unsigned shift = p * kDigitBits;
        if (hist[(keys[0] >> shift) & (kBuckets - 1)] == n) continue; // all keys agree on this digit
        uint32_t sum = 0;
        for (size_t b = 0; b < kBuckets; ++b) {
            const uint32_t c = hist[b];
            hist[b] = sum;
            sum += c;
        }
        for (size_t i = 0; i < n; ++i) {
            const uint64_t k = keys[i];
            const uint32_t dst = hist[(k >> shift) & (kBuckets - 1)]++;
            keys_tmp[dst] = k;
            values_tmp[dst] = values[i];
        }
        keys.swap(keys_tmp);
        values.swap(values_tmp);
    }
}

} // namespace aacbvh
