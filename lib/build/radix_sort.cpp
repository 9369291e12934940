#include "build/radix_sort.h"

#include <algorithm>
#include <vector>

namespace aacbvh {

namespace {

/// Digits of 8 bits: each pass scatters into 256 places of two arrays. With
/// 11 bits (2,048 places, three passes for 32-bit keys instead of four) the
/// scatter stalled on its stores once the arrays outgrew the caches: the
/// dragon's sort took 26 ms against 19 (docs/PERFORMANCE.md, row 215).
constexpr unsigned kDigitBits = 8;
constexpr size_t kBuckets = size_t(1) << kDigitBits;
constexpr size_t kMinChunk = 1u << 14;
/// Fewer pairs than this are sorted on the calling thread whatever the
/// thread count: each pass's parallel count and scatter cost more in
/// hand-offs and in lines moved between the cores than they save (at two
/// threads the sort phase of sponza's build took 1.79 ms against 1.37 on
/// one, and the builds of the scenes below this size ran 0.2-3.5 % faster
/// alone; docs/PERFORMANCE.md, row 300).
constexpr size_t kAloneBelow = size_t(1) << 18;

} // namespace

template <class Key, class Value>
bool sort_pairs(Key *keys, Value *values, Key *keys_tmp, Value *values_tmp, size_t n, unsigned key_bits,
                Scheduler &scheduler) {
    bool in_tmp = false;
    if (n < 2) return in_tmp;
    const unsigned passes = (key_bits + kDigitBits - 1) / kDigitBits;
    // Each chunk counts and scatters its own slice; the scatter of chunk c
    // starts where chunks 0..c-1 of the same digit end, so the sort is stable
    // and its result independent of the chunk count.
    // One thread, or fewer than kAloneBelow pairs, sort in one chunk.
    const size_t chunks = scheduler.thread_count() == 1 || n < kAloneBelow
                              ? 1
                              : std::max<size_t>(1, std::min<size_t>(scheduler.thread_count() * 4, n / kMinChunk));
    const size_t chunk_size = (n + chunks - 1) / chunks;

    std::vector<uint32_t> counts(chunks * kBuckets);
    // With one chunk, a pass's counts are those of the whole array, in any
    // order: every pass's counts (up to four) from one read of the keys.
    std::vector<uint32_t> pass_counts;
    if (chunks == 1 && passes <= 4) {
        pass_counts.assign(4 * kBuckets, 0u);
        uint32_t *c0 = pass_counts.data(), *c1 = c0 + kBuckets, *c2 = c1 + kBuckets, *c3 = c2 + kBuckets;
        for (size_t i = 0; i < n; ++i) {
            const Key k = keys[i];
            ++c0[k & (kBuckets - 1)];
            ++c1[(k >> kDigitBits) & (kBuckets - 1)];
            ++c2[(k >> (2 * kDigitBits)) & (kBuckets - 1)];
            ++c3[(k >> (3 * kDigitBits)) & (kBuckets - 1)];
        }
    }
    for (unsigned p = 0; p < passes; ++p) {
        const unsigned shift = p * kDigitBits;
        if (!pass_counts.empty()) {
            std::copy(&pass_counts[p * kBuckets], &pass_counts[p * kBuckets] + kBuckets, counts.begin());
        } else {
            std::fill(counts.begin(), counts.end(), 0u);
            scheduler.parallel_for(0, chunks, 1, [&](size_t c0, size_t c1) {
                for (size_t c = c0; c < c1; ++c) {
                    uint32_t *count = &counts[c * kBuckets];
                    const size_t e = std::min(n, (c + 1) * chunk_size);
                    for (size_t i = c * chunk_size; i < e; ++i) ++count[(keys[i] >> shift) & (kBuckets - 1)];
                }
            });
        }
        // Skip a digit on which every key agrees.
        const size_t first_digit = (keys[0] >> shift) & (kBuckets - 1);
        size_t same = 0;
        for (size_t c = 0; c < chunks; ++c) same += counts[c * kBuckets + first_digit];
        if (same == n) continue;
        // Exclusive prefix over (digit, chunk).
        uint32_t sum = 0;
        for (size_t d = 0; d < kBuckets; ++d)
            for (size_t c = 0; c < chunks; ++c) {
                const uint32_t k = counts[c * kBuckets + d];
                counts[c * kBuckets + d] = sum;
                sum += k;
            }
        scheduler.parallel_for(0, chunks, 1, [&](size_t c0, size_t c1) {
            for (size_t c = c0; c < c1; ++c) {
                uint32_t *offset = &counts[c * kBuckets];
                const size_t e = std::min(n, (c + 1) * chunk_size);
                for (size_t i = c * chunk_size; i < e; ++i) {
                    const Key k = keys[i];
                    const uint32_t dst = offset[(k >> shift) & (kBuckets - 1)]++;
                    keys_tmp[dst] = k;
                    values_tmp[dst] = values[i];
                }
            }
        });
        std::swap(keys, keys_tmp);
        std::swap(values, values_tmp);
        in_tmp = !in_tmp;
    }
    return in_tmp;
}

/// The sort of whole arrays: the spare pair allocated here, and the arrays
/// swapped when the result ends in it.
template <class Key, class Value>
void sort_arrays(Array<Key> &keys, Array<Value> &values, unsigned key_bits, Scheduler &scheduler) {
    const size_t n = keys.size();
    if (n < 2) return;
    Array<Key> keys_tmp(n);
    Array<Value> values_tmp(n);
    if (sort_pairs(keys.data(), values.data(), keys_tmp.data(), values_tmp.data(), n, key_bits, scheduler)) {
        keys.swap(keys_tmp);
        values.swap(values_tmp);
    }
}

void radix_sort_pairs(Array<uint64_t> &keys, Array<uint32_t> &values, unsigned key_bits, Scheduler &scheduler) {
    sort_arrays(keys, values, key_bits, scheduler);
}

void radix_sort_pairs(Array<uint32_t> &keys, Array<uint64_t> &values, unsigned key_bits, Scheduler &scheduler) {
    sort_arrays(keys, values, key_bits, scheduler);
}

bool radix_sort_pairs(uint32_t *keys, uint64_t *values, uint32_t *keys_tmp, uint64_t *values_tmp, size_t n,
                      unsigned key_bits, Scheduler &scheduler) {
    return sort_pairs(keys, values, keys_tmp, values_tmp, n, key_bits, scheduler);
}

void radix_sort_high_halves(uint64_t *values, uint64_t *scratch, size_t count) {
    uint32_t histogram[4][256] = {};
    for (size_t i = 0; i < count; ++i) {
        const uint64_t v = values[i];
        for (int d = 0; d < 4; ++d) ++histogram[d][(v >> (32 + 8 * d)) & 255];
    }
    uint64_t *from = values, *to = scratch;
    for (int d = 0; d < 4; ++d) {
        const unsigned shift = 32 + 8 * unsigned(d);
        uint32_t *h = histogram[d];
        if (h[(from[0] >> shift) & 255] == count) continue; // one byte for all
        uint32_t sum = 0;
        for (unsigned b = 0; b < 256; ++b) {
            const uint32_t c = h[b];
            h[b] = sum;
            sum += c;
        }
        for (size_t i = 0; i < count; ++i) {
            const uint64_t v = from[i];
            to[h[(v >> shift) & 255]++] = v;
        }
        std::swap(from, to);
    }
    if (from != values) std::copy(from, from + count, values);
}

} // namespace aacbvh
