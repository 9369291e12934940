// sort_by_morton_code (build/morton.h) against an independent reference: the
// codes computed one by one (MortonQuantizer, itself checked against the
// arithmetic interleave on every cell coordinate and on points on and beyond
// the bounds) and std::stable_sort, on random scenes, on scenes
// where most codes share their high half (a tiny cluster in a huge scene, so
// the sort's second stage orders long runs), on equal codes, and at one and
// several threads.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "build/morton.h"
#include "build/radix_sort.h"
#include "build/radix_split.h"
#include "box_input.h"

namespace {

using aacbvh::Box;

using aacbvh_test::box_input;

/// Fails unless sort_by_morton_code gives the stable sort of the codes.
void check_sorted(const std::vector<Box> &boxes, unsigned threads) {
    const aacbvh::BuildInput in = box_input(boxes);
    const aacbvh::MortonQuantizer quantizer(in.centroid_bounds);
    std::vector<uint64_t> code(boxes.size());
    std::vector<uint32_t> want(boxes.size());
    for (size_t i = 0; i < boxes.size(); ++i) {
        const float c[3] = {boxes[i].centroid(0), boxes[i].centroid(1), boxes[i].centroid(2)};
        code[i] = quantizer.code(c);
        want[i] = uint32_t(i);
    }
    std::stable_sort(want.begin(), want.end(), [&](uint32_t a, uint32_t b) { return code[a] < code[b]; });

    aacbvh::Scheduler scheduler(threads);
    // The sort in memory of its own and in the caller's room (filled with
    // junk first: the sort must not read what it did not write).
    std::vector<uint64_t> room(aacbvh::kMortonSortWords * boxes.size(), 0x5A5A5A5A5A5A5A5Aull);
    for (uint64_t *work : {static_cast<uint64_t *>(nullptr), room.data()}) {
        aacbvh::Array<uint64_t> codes;
        aacbvh::Array<uint32_t> order;
        aacbvh::sort_by_morton_code(in, scheduler, codes, order, work);
        assert_int_equal(codes.size(), boxes.size());
        assert_int_equal(order.size(), boxes.size());
        for (size_t i = 0; i < boxes.size(); ++i) {
            if (order[i] != want[i] || codes[i] != code[want[i]])
                fail_msg("%zu boxes, %u threads, %s: entry %zu is %u (code %llx), expected %u (code %llx)",
                         boxes.size(), threads, work ? "room" : "own", i, order[i], (unsigned long long)codes[i],
                         want[i], (unsigned long long)code[want[i]]);
        }
        // The order and the neighbours' common prefix lengths alone.
        aacbvh::Array<uint32_t> order2;
        std::vector<uint8_t> prefix(boxes.size() + 1, 0xEE);
        aacbvh::sort_by_morton_prefixes(in, scheduler, order2, prefix.data(), work);
        assert_int_equal(order2.size(), boxes.size());
        for (size_t i = 0; i < boxes.size(); ++i) {
            if (order2[i] != want[i])
                fail_msg("%zu boxes, %u threads: prefix sort's entry %zu is %u, expected %u", boxes.size(), threads, i,
                         order2[i], want[i]);
            const uint8_t expected = i + 1 < boxes.size() ? aacbvh::common_prefix(code[want[i]], code[want[i + 1]]) : 0xEE;
            if (prefix[i] != expected)
                fail_msg("%zu boxes, %u threads: prefix %zu is %u, expected %u", boxes.size(), threads, i, prefix[i],
                         expected);
        }
        assert_int_equal(prefix[boxes.size()], 0xEE); // nothing written past the last pair
    }
}

Box point_box(float x, float y, float z) { return Box{{x, y, z}, {x, y, z}}; }

/// The code as the quantizer's first form computed it: the cell in double,
/// clamped, converted to uint64_t, spread by shifts and masks.
uint64_t reference_code(const Box &bounds, const float p[3]) {
    constexpr uint64_t cells = uint64_t(1) << 21;
    double largest = 0.0;
    for (int k = 0; k < 3; ++k) largest = std::max(largest, double(bounds.hi[k]) - double(bounds.lo[k]));
    uint64_t q[3];
    for (int k = 0; k < 3; ++k) {
        const double scale = largest > 0.0 ? double(cells) / largest : 0.0;
        const double cell = (double(p[k]) - double(bounds.lo[k])) * scale;
        q[k] = cell <= 0.0 ? 0 : cell >= double(cells - 1) ? cells - 1 : uint64_t(cell);
    }
    return aacbvh::spread_bits_21(q[0]) << 2 | aacbvh::spread_bits_21(q[1]) << 1 | aacbvh::spread_bits_21(q[2]);
}

/// The quantizer's byte tables spread every 21-bit coordinate on every axis
/// as the arithmetic form does; its codes equal the reference's for random
/// points, the bounds' corners, points a hair inside and beyond them, cell
/// edges, bounds spanning most of the float range and flat or empty extents.
void test_codes(void **) {
    // A cube of side 2^21 puts point (x, y, z) in cell (x, y, z).
    const aacbvh::MortonQuantizer cube(Box{{0.0f, 0.0f, 0.0f}, {2097152.0f, 2097152.0f, 2097152.0f}});
    for (uint32_t c = 0; c < (1u << 21); ++c) {
        const float on_axis[3][3] = {{float(c), 0.0f, 0.0f}, {0.0f, float(c), 0.0f}, {0.0f, 0.0f, float(c)}};
        for (int a = 0; a < 3; ++a) {
            const uint64_t want = aacbvh::spread_bits_21(c) << (2 - a);
            const uint64_t got = cube.code(on_axis[a]);
            if (got != want)
                fail_msg("coordinate %u on axis %d: code %llx, expected %llx", c, a, (unsigned long long)got,
                         (unsigned long long)want);
        }
    }
    std::mt19937 rng(17);
    const Box bounds_list[] = {
        Box{{-100.0f, -3.0f, 7.0f}, {250.0f, 4.0f, 7.5f}},
        Box{{-3.0e38f, -3.0e38f, -3.0e38f}, {3.0e38f, 3.0e38f, 3.0e38f}},
        Box{{1.0f, 2.0f, 3.0f}, {1.0f, 2.0f, 3.0f}},       // one point: scale 0
        Box{{0.0f, 5.0f, -1.0f}, {1e-30f, 5.0f, 1.0f}},    // flat and tiny extents
        Box{{1e6f, 1e6f, 1e6f}, {1e6f + 1.0f, 1e6f + 0.125f, 1e6f + 0.5f}},
    };
    for (const Box &b : bounds_list) {
        const aacbvh::MortonQuantizer q(b);
        std::vector<std::array<float, 3>> points;
        for (int corner = 0; corner < 8; ++corner)
            points.push_back({corner & 1 ? b.hi[0] : b.lo[0], corner & 2 ? b.hi[1] : b.lo[1],
                              corner & 4 ? b.hi[2] : b.lo[2]});
        for (int i = 0; i < 20000; ++i) {
            std::array<float, 3> p;
            for (int k = 0; k < 3; ++k) {
                const float lo = b.lo[k], hi = b.hi[k];
                const float t = std::uniform_real_distribution<float>(-0.01f, 1.01f)(rng);
                float v = lo + (hi - lo) * t;
                if (i % 5 == 1) v = std::nextafter(t < 0.5f ? lo : hi, t < 0.25f || t > 0.75f ? -INFINITY : INFINITY);
                if (!std::isfinite(v)) v = t < 0.5f ? lo : hi;
                p[k] = v;
            }
            points.push_back(p);
        }
        for (const auto &p : points) {
            const uint64_t want = reference_code(b, p.data()), got = q.code(p.data());
            if (got != want)
                fail_msg("point (%g, %g, %g): code %llx, expected %llx", double(p[0]), double(p[1]), double(p[2]),
                         (unsigned long long)got, (unsigned long long)want);
        }
    }
}

void test_random_scenes(void **) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-100.0f, 100.0f);
    for (size_t n : {size_t(1), size_t(2), size_t(17), size_t(1000), size_t(70000)}) {
        std::vector<Box> boxes;
        for (size_t i = 0; i < n; ++i) {
            const float x = u(rng), y = u(rng), z = u(rng);
            boxes.push_back(Box{{x, y, z}, {x + 0.5f, y + 0.25f, z + 1.0f}});
        }
        for (unsigned threads : {1u, 3u}) check_sorted(boxes, threads);
    }
}

/// Most centroids inside one cell of the high half's grid (2^10.3 cells per
/// axis): a run of tens of thousands of equal high halves, ordered by the low
/// bits; plus exact duplicates, which must keep their input order.
void test_runs_of_equal_high_bits(void **) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> tiny(0.0f, 1e-4f);
    std::vector<Box> boxes;
    boxes.push_back(point_box(-1000.0f, -1000.0f, -1000.0f));
    boxes.push_back(point_box(1000.0f, 1000.0f, 1000.0f));
    for (int i = 0; i < 60000; ++i) {
        if (i % 7 == 0)
            boxes.push_back(point_box(0.5f, 0.5f, 0.5f)); // duplicates
        else
            boxes.push_back(point_box(tiny(rng), tiny(rng), tiny(rng)));
    }
    std::shuffle(boxes.begin() + 2, boxes.end(), rng);
    for (unsigned threads : {1u, 2u, 5u}) check_sorted(boxes, threads);
}

/// Pairs of centroids a hair apart, shuffled: runs of two equal high halves
/// whose low halves decide the order, in either input order.
void test_close_pairs(void **) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-100.0f, 100.0f);
    std::vector<Box> boxes;
    for (int i = 0; i < 4000; ++i) {
        const float x = u(rng), y = u(rng), z = u(rng);
        boxes.push_back(point_box(x, y, z));
        boxes.push_back(point_box(x + 1e-3f, y + 1e-3f, z + 1e-3f));
    }
    std::shuffle(boxes.begin(), boxes.end(), rng);
    for (unsigned threads : {1u, 2u}) check_sorted(boxes, threads);
}

/// Many cells, each holding hundreds to thousands of centroids (as the chairs
/// of conference do): runs long enough for the sort's byte-wise pass, with
/// duplicates inside them and neighbouring cells' runs side by side.
void test_many_long_runs(void **) {
    std::mt19937 rng(23);
    std::uniform_real_distribution<float> u(-1000.0f, 1000.0f), tiny(0.0f, 0.05f);
    std::vector<Box> boxes;
    for (int cell = 0; cell < 40; ++cell) {
        const float x = u(rng), y = u(rng), z = u(rng);
        const int count = 100 + int(rng() % 3000);
        for (int i = 0; i < count; ++i) {
            if (i % 11 == 0)
                boxes.push_back(point_box(x, y, z)); // duplicates
            else
                boxes.push_back(point_box(x + tiny(rng), y + tiny(rng), z + tiny(rng)));
        }
    }
    std::shuffle(boxes.begin(), boxes.end(), rng);
    for (unsigned threads : {1u, 3u}) check_sorted(boxes, threads);
}

/// radix_sort_high_halves() against std::stable_sort by high halves: random
/// values, values that share all but one byte of their high halves, few
/// distinct high halves (stability decides), every value equal, and sizes
/// around the one-byte-for-all skip.
void test_sort_by_high_halves(void **) {
    std::mt19937_64 rng(3);
    for (size_t n : {size_t(1), size_t(2), size_t(255), size_t(256), size_t(300), size_t(5000), size_t(100000)}) {
        for (int pattern = 0; pattern < 5; ++pattern) {
            std::vector<uint64_t> v(n);
            for (auto &x : v) {
                x = rng();
                if (pattern == 1) x = 0x1234567800000000ull | (x & 0xFF0000FFFFFFFFull);
                if (pattern == 2) x = (x % 5) << 32 | (x & 0xFFFFFFFF);
                if (pattern == 3) x = 0x42;
                if (pattern == 4) x = (x & 0x7FFFFFFF00000000ull) | (x % 64); // morton.cpp's values
            }
            std::vector<uint64_t> want = v, scratch(n);
            std::stable_sort(want.begin(), want.end(), [](uint64_t a, uint64_t b) { return a >> 32 < b >> 32; });
            aacbvh::radix_sort_high_halves(v.data(), scratch.data(), v.size());
            if (v != want) fail_msg("%zu values, pattern %d: not the stable order of the high halves", n, pattern);
        }
    }
}

/// Both radix_sort_pairs() forms on arrays against std::stable_sort by the
/// keys (all below 2^key_bits): key widths of one to five digits and beyond
/// (the counts of every pass from one read, then a read a pass), few
/// distinct keys (stability decides), keys that agree on whole digits (the
/// top one included), sizes up to 70,000 (one chunk: several chunks are
/// test_radix_sort_pairs_in_chunks()'s), one thread and three.
void test_radix_sort_pairs(void **) {
    std::mt19937_64 rng(5);
    for (size_t n : {size_t(0), size_t(1), size_t(2), size_t(1000), size_t(70000)}) {
        for (unsigned key_bits : {5u, 8u, 9u, 24u, 32u, 40u, 64u}) {
            for (int pattern = 0; pattern < 3; ++pattern) { // random, few distinct, the top digit all 0
                for (unsigned threads : {1u, 3u}) {
                    aacbvh::Scheduler scheduler(threads);
                    const uint64_t mask = key_bits == 64 ? ~uint64_t(0) : (uint64_t(1) << key_bits) - 1;
                    aacbvh::Array<uint64_t> keys(n);
                    aacbvh::Array<uint32_t> values(n);
                    for (size_t i = 0; i < n; ++i) {
                        keys[i] = (pattern == 0   ? rng()
                                   : pattern == 1 ? rng() % 7 << (key_bits > 3 ? key_bits - 3 : 0)
                                                  : (rng() & mask) >> 8) &
                                  mask;
                        values[i] = uint32_t(i);
                    }
                    std::vector<uint32_t> want(values.begin(), values.end());
                    std::stable_sort(want.begin(), want.end(),
                                     [&](uint32_t a, uint32_t b) { return keys[a] < keys[b]; });
                    // The 32-bit form on the low halves (at most 32 key bits).
                    const unsigned bits32 = std::min(key_bits, 32u);
                    const uint64_t mask32 = bits32 == 32 ? 0xFFFFFFFFull : (uint64_t(1) << bits32) - 1;
                    aacbvh::Array<uint32_t> keys32(n);
                    aacbvh::Array<uint64_t> values64(n);
                    for (size_t i = 0; i < n; ++i) {
                        keys32[i] = uint32_t(keys[i] & mask32);
                        values64[i] = uint64_t(i) << 32 | 0xABCDu;
                    }
                    std::vector<uint32_t> want32(n);
                    for (size_t i = 0; i < n; ++i) want32[i] = uint32_t(i);
                    std::stable_sort(want32.begin(), want32.end(), [&](uint32_t a, uint32_t b) {
                        return keys32[a] < keys32[b];
                    });
                    const aacbvh::Array<uint64_t> original = keys;
                    const aacbvh::Array<uint32_t> original32 = keys32;
                    aacbvh::radix_sort_pairs(keys, values, key_bits, scheduler);
                    aacbvh::radix_sort_pairs(keys32, values64, bits32, scheduler);
                    for (size_t i = 0; i < n; ++i) {
                        if (values[i] != want[i] || keys[i] != original[want[i]])
                            fail_msg("64-bit keys, %zu pairs, %u bits, pattern %d, %u threads: entry %zu is %u, "
                                     "expected %u", n, key_bits, pattern, threads, i, values[i], want[i]);
                        if (values64[i] != (uint64_t(want32[i]) << 32 | 0xABCDu) || keys32[i] != original32[want32[i]])
                            fail_msg("32-bit keys, %zu pairs, %u bits, pattern %d, %u threads: entry %zu wrong", n,
                                     bits32, pattern, threads, i);
                    }
                }
            }
        }
    }
}

/// The sort in several chunks, which only arrays of at least 2^18 pairs get
/// (fewer are sorted on the calling thread, build/radix_sort.cpp): random
/// keys and keys of few values (stability decides), 32 and 64 key bits,
/// against std::stable_sort, on two and three threads.
void test_radix_sort_pairs_in_chunks(void **) {
    std::mt19937_64 rng(11);
    const size_t n = (size_t(1) << 18) + 12345;
    for (unsigned key_bits : {32u, 64u}) {
        for (int pattern = 0; pattern < 2; ++pattern) {
            const uint64_t mask = key_bits == 64 ? ~uint64_t(0) : (uint64_t(1) << key_bits) - 1;
            aacbvh::Array<uint64_t> keys(n);
            for (size_t i = 0; i < n; ++i) keys[i] = (pattern == 0 ? rng() : rng() % 5 << (key_bits - 3)) & mask;
            std::vector<uint32_t> want(n);
            for (size_t i = 0; i < n; ++i) want[i] = uint32_t(i);
            std::stable_sort(want.begin(), want.end(), [&](uint32_t a, uint32_t b) { return keys[a] < keys[b]; });
            for (unsigned threads : {2u, 3u}) {
                aacbvh::Scheduler scheduler(threads);
                aacbvh::Array<uint64_t> sorted(keys);
                aacbvh::Array<uint32_t> values(n);
                for (size_t i = 0; i < n; ++i) values[i] = uint32_t(i);
                aacbvh::radix_sort_pairs(sorted, values, key_bits, scheduler);
                for (size_t i = 0; i < n; ++i)
                    if (values[i] != want[i] || sorted[i] != keys[want[i]])
                        fail_msg("%u bits, pattern %d, %u threads: entry %zu is %u, expected %u", key_bits, pattern,
                                 threads, i, values[i], want[i]);
            }
        }
    }
}

/// Every code equal: the input order.
void test_all_equal(void **) {
    std::vector<Box> boxes(5000, point_box(3.0f, 3.0f, 3.0f));
    for (unsigned threads : {1u, 4u}) check_sorted(boxes, threads);
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_codes),
        cmocka_unit_test(test_random_scenes),
        cmocka_unit_test(test_runs_of_equal_high_bits),
        cmocka_unit_test(test_close_pairs),
        cmocka_unit_test(test_all_equal),
        cmocka_unit_test(test_many_long_runs),
        cmocka_unit_test(test_sort_by_high_halves),
        cmocka_unit_test(test_radix_sort_pairs),
        cmocka_unit_test(test_radix_sort_pairs_in_chunks),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
