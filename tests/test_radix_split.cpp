// build/radix_split.h against independent references: the split of a sorted
// range of codes found from the codes themselves (the first code with the
// range's highest differing bit set, by binary search, as AAC found it
// before it kept only prefix lengths), and the first minimum by a plain
// loop. Random codes with long runs of equal ones, ranges of every length
// and position (the SSE2 search's tails and unaligned starts), minima at the
// ends, all-equal ranges. (The prefix lengths come from the Morton sort,
// tests/test_morton_sort.cpp.)
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <algorithm>
#include <random>
#include <vector>

#include "build/radix_split.h"

namespace {

size_t reference_first_minimum(const uint8_t *bytes, size_t count) {
    size_t at = 0;
    for (size_t i = 1; i < count; ++i)
        if (bytes[i] < bytes[at]) at = i;
    return at;
}

/// The split from the codes: the middle when all are equal, else the first
/// index whose code has the highest differing bit of the range set.
uint32_t reference_split(const std::vector<uint64_t> &codes, uint32_t b, uint32_t e, bool &equal) {
    equal = codes[b] == codes[e - 1];
    if (equal) return b + (e - b) / 2;
    const uint64_t mask = uint64_t(1) << (63 - __builtin_clzll(codes[b] ^ codes[e - 1]));
    return uint32_t(std::partition_point(codes.begin() + b, codes.begin() + e, [&](uint64_t c) { return !(c & mask); }) -
                    codes.begin());
}

/// Sorted 63-bit codes with runs of equal codes and codes that differ only
/// in low bits or only in the top bit.
std::vector<uint64_t> make_codes(std::mt19937_64 &rng, size_t count) {
    std::vector<uint64_t> codes;
    while (codes.size() < count) {
        const uint64_t kind = rng() % 4;
        uint64_t c = rng() >> 1;
        if (kind == 1) c &= 0xFF; // low bits only
        if (kind == 2) c = (rng() & 1) << 62; // the top bit only
        const size_t run = kind == 3 ? 1 + rng() % 80 : 1;
        for (size_t k = 0; k < run && codes.size() < count; ++k) codes.push_back(c);
    }
    std::sort(codes.begin(), codes.end());
    return codes;
}

void test_first_minimum(void **) {
    std::mt19937_64 rng(7);
    std::vector<uint8_t> bytes(400); // kPrefixPadding readable past every range below
    for (uint8_t &x : bytes) x = uint8_t(rng()); // the padding: any values
    for (size_t count = 1; count <= 300; ++count)
        for (int round = 0; round < 40; ++round) {
            const int spread = round % 4 == 0 ? 2 : round % 4 == 1 ? 65 : 256;
            const size_t offset = rng() % 17; // unaligned starts
            for (size_t i = 0; i < count; ++i) bytes[offset + i] = uint8_t(255 - rng() % spread);
            if (round % 5 == 1) bytes[offset + count - 1] = 0; // the minimum last (in the scalar tail)
            if (round % 5 == 2) bytes[offset] = 0;             // and first
            const uint8_t *p = bytes.data() + offset;
            assert_int_equal(aacbvh::first_minimum(p, count), reference_first_minimum(p, count));
        }
    // All equal, 255 (the search's starting value) included.
    for (size_t count : {size_t(1), size_t(15), size_t(16), size_t(17), size_t(32), size_t(33), size_t(257)}) {
        std::vector<uint8_t> same(count + aacbvh::kPrefixPadding, 0); // padding below every value
        std::fill(same.begin(), same.begin() + count, 255);
        assert_int_equal(aacbvh::first_minimum(same.data(), count), 0);
        std::fill(same.begin(), same.begin() + count, 64);
        assert_int_equal(aacbvh::first_minimum(same.data(), count), 0);
        same[count - 1] = 63; // the last in range, the padding just past it
        assert_int_equal(aacbvh::first_minimum(same.data(), count), count - 1);
    }
}

void test_splits_match_codes(void **) {
    std::mt19937_64 rng(11);
    for (int round = 0; round < 30; ++round) {
        const size_t n = 2 + rng() % 3000;
        const std::vector<uint64_t> codes = make_codes(rng, n);
        std::vector<uint8_t> prefix(n - 1 + aacbvh::kPrefixPadding, 0);
        for (size_t i = 0; i + 1 < n; ++i) prefix[i] = aacbvh::common_prefix(codes[i], codes[i + 1]);
        for (size_t i = 0; i + 1 < n; ++i) {
            const uint64_t x = codes[i] ^ codes[i + 1];
            assert_int_equal(prefix[i], x == 0 ? 64 : __builtin_clzll(x));
        }
        for (int r = 0; r < 400; ++r) {
            uint32_t b = uint32_t(rng() % n), e = uint32_t(rng() % (n + 1));
            if (b > e) std::swap(b, e);
            if (e - b < 2) continue;
            bool equal = false;
            const uint32_t expected = reference_split(codes, b, e, equal);
            const aacbvh::RadixSplit split = aacbvh::radix_split(prefix.data(), b, e);
            assert_int_equal(split.at, expected);
            assert_int_equal(split.equal, equal);
            assert_true(split.at > b && split.at < e);
        }
    }
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_first_minimum),
        cmocka_unit_test(test_splits_match_codes),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
