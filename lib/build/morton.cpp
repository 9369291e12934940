#include "build/morton.h"

#include "build/radix_sort.h"

namespace aacbvh {

void sort_by_morton_code(const BuildInput &input, Scheduler &scheduler, Array<uint64_t> &codes,
                         Array<uint32_t> &order) {
    const size_t n = input.size();
    codes.resize(n);
    order.resize(n);
    const MortonQuantizer quantizer(input.centroid_bounds);
    scheduler.parallel_for(0, n, 1u << 14, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            const Box &box = input.boxes[i];
            const float c[3] = {box.centroid(0), box.centroid(1), box.centroid(2)};
            codes[i] = quantizer.code(c);
            order[i] = uint32_t(i);
        }
    });
    radix_sort_pairs(codes, order, 63, scheduler);
}

} // namespace aacbvh
