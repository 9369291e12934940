// Morton (Z-order) codes of primitive centroids, 21 bits per axis (63 bits in
// all) so that large scenes do not tie (the paper used 30 bits).
#pragma once

#include <algorithm>
#include <cstdint>

#include "build/build_input.h"
#include "core/box.h"
#include "core/memory.h"
#include "core/scheduler.h"

namespace aacbvh {

/// Spreads the low 21 bits of x so that bit i lands on bit 3i.
inline uint64_t spread_bits_21(uint64_t x) {
    x &= 0x1FFFFF;
    x = (x | x << 32) & 0x1F00000000FFFFull;
    x = (x | x << 16) & 0x1F0000FF0000FFull;
    x = (x | x << 8) & 0x100F00F00F00F00Full;
    x = (x | x << 4) & 0x10C30C30C30C30C3ull;
    x = (x | x << 2) & 0x1249249249249249ull;
    return x;
}

/// Maps points of `bounds` onto a grid of 2^21 cells per axis. The cells are
/// cubes (one scale, from the largest extent), so the radix-tree splits of an
/// elongated scene stay balanced in world space; per-axis scales would split
/// a long, flat room as often across its height as along its length. This
/// gave slightly cheaper trees on most scenes (figures: docs/PERFORMANCE.md,
/// "Tree quality: cubic Morton cells"). Computed in double so that bounds spanning
/// most of the float range do not overflow.
class MortonQuantizer {
public:
    explicit MortonQuantizer(const Box &bounds) {
        double largest = 0.0;
        for (int k = 0; k < 3; ++k) largest = std::max(largest, double(bounds.hi[k]) - double(bounds.lo[k]));
        for (int k = 0; k < 3; ++k) {
            origin_[k] = bounds.lo[k];
            scale_[k] = largest > 0.0 ? double(kCells) / largest : 0.0;
        }
    }
    uint64_t code(const float p[3]) const {
        uint64_t q[3];
        for (int k = 0; k < 3; ++k) {
            const double cell = (double(p[k]) - origin_[k]) * scale_[k];
            q[k] = cell <= 0.0 ? 0 : cell >= double(kCells - 1) ? kCells - 1 : uint64_t(cell);
        }
        return spread_bits_21(q[0]) << 2 | spread_bits_21(q[1]) << 1 | spread_bits_21(q[2]);
    }

private:
    static constexpr uint64_t kCells = uint64_t(1) << 21;
    double origin_[3];
    double scale_[3];
};

/// Sorts the input's primitives by the Morton codes of their box centroids
/// (quantised in input.centroid_bounds): codes[i] is the i-th smallest code
/// and order[i] the input entry it belongs to. Equal codes keep input order.
void sort_by_morton_code(const BuildInput &input, Scheduler &scheduler, Array<uint64_t> &codes,
                         Array<uint32_t> &order);

} // namespace aacbvh
