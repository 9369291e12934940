#include "build/morton.h"

#include <algorithm>
#include <atomic>
#include <vector>

#include "build/radix_sort.h"
#include "build/radix_split.h"

namespace aacbvh {

namespace {

constexpr unsigned kLowBits = 31;

/// The sorted codes where sort_by_morton_code()'s work leaves them: code i is
/// high[i] << kLowBits | low_index[i] >> 32, its input entry uint32_t(low_index[i]).
struct SortedCodes {
    const uint32_t *high;
    const uint64_t *low_index;
    uint64_t code(size_t i) const { return uint64_t(high[i]) << kLowBits | low_index[i] >> 32; }
};

/// The sort itself, in room[0, kMortonSortWords n), or in `own` (sized
/// here) without a room.
SortedCodes sort_codes(const BuildInput &input, Scheduler &scheduler, uint64_t *room, Array<uint64_t> &own) {
    // The radix sort moves the codes' high 32 bits as keys, with their low 31
    // bits and the input index as one 64-bit value: four passes of 12 bytes
    // per primitive instead of eight. Codes that share their high half (a few,
    // unless the scene is mostly one tiny cluster) are then ordered by that
    // value, low bits first, then index: the order of a stable sort of the
    // whole codes.
    const size_t n = input.size();
    // The work, 24 bytes a primitive: values, spare values, keys, spare
    // keys. In the caller's room it costs no memory of its own (AAC's build
    // peak was this sort's, 76 bytes a triangle; docs/PERFORMANCE.md, row 214).
    if (room == nullptr) {
        own.resize(kMortonSortWords * n);
        room = own.data();
    }
    uint64_t *low_index = room, *low_spare = room + n;
    uint32_t *high = reinterpret_cast<uint32_t *>(room + 2 * n), *high_spare = high + n;
    const MortonQuantizer quantizer(input.centroid_bounds);
    scheduler.parallel_for(0, n, 1u << 14, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            const uint64_t code = quantizer.centroid_code(input.box(i));
            high[i] = uint32_t(code >> kLowBits);
            low_index[i] = (code & ((uint64_t(1) << kLowBits) - 1)) << 32 | i;
        }
    });
    if (radix_sort_pairs(high, low_index, high_spare, low_spare, n, 63 - kLowBits, scheduler)) {
        std::swap(high, high_spare);
        std::swap(low_index, low_spare);
    }
    // A run of equal high halves is sorted by the chunk it starts in: short
    // runs by std::sort; long ones (most of conference's primitives lie in
    // runs of 512 and more) by bytes instead of comparisons, in a second pass
    // with scratch memory (docs/PERFORMANCE.md, change 82). A run's values
    // are in index order, so a stable sort by the low code bits in their
    // high halves is the sort by whole values.
    constexpr size_t kRadixRun = 256;
    auto for_each_run = [&high, n](size_t b, size_t e, auto &&sort_run) {
        size_t i = b;
        while (i > 0 && i < e && high[i] == high[i - 1]) ++i;
        while (i < e) {
            size_t j = i + 1;
            while (j < n && high[j] == high[i]) ++j;
            if (j - i > 1) sort_run(i, j - i);
            i = j;
        }
    };
    std::atomic<bool> long_runs{false};
    scheduler.parallel_for(0, n, 1u << 14, [&](size_t b, size_t e) {
        for_each_run(b, e, [&](size_t first, size_t length) {
            if (length >= kRadixRun)
                long_runs.store(true, std::memory_order_relaxed);
            else
                std::sort(&low_index[first], &low_index[first] + length);
        });
    });
    if (long_runs.load()) { // each run uses its own range of the spare values
        scheduler.parallel_for(0, n, 1u << 14, [&](size_t b, size_t e) {
            for_each_run(b, e, [&](size_t first, size_t length) {
                if (length >= kRadixRun) radix_sort_high_halves(&low_index[first], &low_spare[first], length);
            });
        });
    }
    return SortedCodes{high, low_index};
}

} // namespace

void sort_by_morton_code(const BuildInput &input, Scheduler &scheduler, Array<uint64_t> &codes,
                         Array<uint32_t> &order, uint64_t *room) {
    const size_t n = input.size();
    Array<uint64_t> own;
    const SortedCodes sorted = sort_codes(input, scheduler, room, own);
    codes.resize(n);
    order.resize(n);
    scheduler.parallel_for(0, n, 1u << 14, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            codes[i] = sorted.code(i);
            order[i] = uint32_t(sorted.low_index[i]);
        }
    });
}

void sort_by_morton_prefixes(const BuildInput &input, Scheduler &scheduler, Array<uint32_t> &order, uint8_t *prefix,
                             uint64_t *room) {
    const size_t n = input.size();
    Array<uint64_t> own;
    const SortedCodes sorted = sort_codes(input, scheduler, room, own);
    order.resize(n);
    scheduler.parallel_for(0, n, 1u << 14, [&](size_t b, size_t e) {
        // Local copies: a byte store may alias the closure, whose fields
        // would then be read again for every byte.
        const SortedCodes codes = sorted;
        uint8_t *const out = prefix;
        uint32_t *const ids = order.data();
        uint64_t next = codes.code(b);
        for (size_t i = b; i < e; ++i) {
            const uint64_t code = next;
            ids[i] = uint32_t(codes.low_index[i]);
            if (i + 1 == n) break;
            next = codes.code(i + 1);
            out[i] = common_prefix(code, next);
        }
    });
}

namespace {

/// refine_equal_code_runs() for one run [b, e) of equal codes; false when its
/// centroids are all one point.
bool refine_run(const BuildInput &input, Array<uint64_t> &codes, Array<uint32_t> &order, size_t b, size_t e) {
    const size_t n = e - b;
    Array<uint64_t> local;
    Array<uint32_t> rank;
    if (!local_morton_order(n, [&](size_t i) -> const Box & { return input.box(order[b + i]); }, local, rank))
        return false;
    Array<uint32_t> moved(n);
    for (size_t i = 0; i < n; ++i) moved[i] = order[b + rank[i]];
    for (size_t i = 0; i < n; ++i) {
        order[b + i] = moved[i];
        codes[b + i] = local[rank[i]];
    }
    return true;
}

} // namespace

void refine_equal_code_runs(const BuildInput &input, Array<uint64_t> &codes, Array<uint32_t> &order, size_t min_run) {
    struct Range {
        size_t b, e;
    };
    std::vector<Range> work{{0, codes.size()}};
    while (!work.empty()) {
        const Range r = work.back();
        work.pop_back();
        for (size_t i = r.b; i < r.e;) {
            size_t j = i + 1;
            while (j < r.e && codes[j] == codes[i]) ++j;
            if (j - i >= min_run && refine_run(input, codes, order, i, j)) work.push_back(Range{i, j});
            i = j;
        }
    }
}

} // namespace aacbvh
