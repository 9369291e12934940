// Top-down binned SAH with 16 bins on the longest centroid axis (Wald 2007),
// as in the AAC paper's comparison (Gu et al. 2013, section 6).
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "build/reference/reference_builders.h"
#include "build/reference/top_down_split.h"
#include "core/memory.h"

namespace aacbvh {
namespace {

using top_down::RangeTask;


/// Binned SAH: 16 bins over the longest axis of the range's centroid bounds
/// (Wald 2007), O(n) per tree level.
class BinnedSahBuilder {
public:
    static constexpr int kBins = 16;

    BinnedSahBuilder(const BuildInput &input, BuildContext &ctx, BinaryTree &out)
        : input_(input), ctx_(ctx), out_(out), n_(uint32_t(input.size())),
          extent_scale_(extent_scale_of(input.bounds)) {}

    void build() {
        out_.resize(n_);
        order_.resize(n_);
        RangeTask root{0, n_, &out_.root, Box::empty(), Box::empty()};
        for (uint32_t i = 0; i < n_; ++i) {
            order_[i] = i;
            root.box.extend(input_.boxes[i]);
            const float c[3] = {centroid(i, 0), centroid(i, 1), centroid(i, 2)};
            root.centroids.extend(c);
        }
        top_down::split_all(ctx_, root, [this](const RangeTask &t, RangeTask &l, RangeTask &r) { split(t, l, r); });

        gather_leaves(input_, order_.data(), ctx_.scheduler(), out_);
    }

private:
    struct Bin {
        Box box = Box::empty();
        Box centroids = Box::empty();
        uint32_t count = 0;
    };

    float centroid(uint32_t prim, int axis) const { return input_.boxes[prim].centroid(axis); }

    /// In double: c - lo overflows float when the centroids spread over most
    /// of its range (and inf * 0 would be NaN).
    static int bin_of(float c, float lo, double scale) {
        const double t = (double(c) - lo) * scale;
        return t <= 0.0 ? 0 : t >= double(kBins - 1) ? kBins - 1 : int(t);
    }

    void split(const RangeTask &task, RangeTask &left, RangeTask &right) {
        const uint32_t b = task.begin, e = task.end;
        const Box &cb = task.centroids;
        int axis = 0;
        for (int k = 1; k < 3; ++k)
            if (cb.extent(k) > cb.extent(axis)) axis = k;
        const float lo = cb.lo[axis];
        const double extent = double(cb.hi[axis]) - cb.lo[axis];
        const double scale = kBins / extent;

        uint32_t mid = 0;
        if (extent > 0.0 && std::isfinite(scale)) {
            Bin bins[kBins];
            for (uint32_t i = b; i < e; ++i) {
                const uint32_t p = order_[i];
                const float c[3] = {centroid(p, 0), centroid(p, 1), centroid(p, 2)};
                Bin &bin = bins[bin_of(c[axis], lo, scale)];
                bin.box.extend(input_.boxes[p]);
                bin.centroids.extend(c);
                ++bin.count;
            }
            float right_area[kBins];
            Box acc = Box::empty();
            for (int j = kBins - 1; j > 0; --j) {
                acc.extend(bins[j].box);
                right_area[j] = area(acc);
            }
            double best_cost = INFINITY;
            int best_j = 0;
            uint32_t best_count = 0, count = 0;
            acc = Box::empty();
            for (int j = 1; j < kBins; ++j) {
                acc.extend(bins[j - 1].box);
                count += bins[j - 1].count;
                if (count == 0 || count == e - b) continue;
                const double cost = double(area(acc)) * count + double(right_area[j]) * (e - b - count);
                if (top_down::better_split(cost, b + count, best_cost, b + best_count, b, e)) {
                    best_cost = cost;
                    best_j = j;
                    best_count = count;
                }
            }
            if (best_j > 0) {
                // Hoare-style partition: deterministic, not stable.
                uint32_t i = b, k = e;
                while (i < k) {
                    if (bin_of(centroid(order_[i], axis), lo, scale) < best_j) {
                        ++i;
                    } else {
                        std::swap(order_[i], order_[--k]);
                    }
                }
                mid = i;
                left.box = right.box = Box::empty();
                left.centroids = right.centroids = Box::empty();
                for (int j = 0; j < kBins; ++j) {
                    RangeTask &side = j < best_j ? left : right;
                    side.box.extend(bins[j].box);
                    side.centroids.extend(bins[j].centroids);
                }
            }
        }
        if (mid == 0) {
            // All centroids coincide on the longest axis, hence on every axis:
            // split the range in the middle.
            mid = b + (e - b) / 2;
            left.box = right.box = Box::empty();
            for (uint32_t i = b; i < e; ++i) (i < mid ? left : right).box.extend(input_.boxes[order_[i]]);
            left.centroids = right.centroids = cb;
        }
        top_down::emit_inner(out_, n_, task, mid, task.box, left, right);
    }

    const BuildInput &input_;
    BuildContext &ctx_;
    BinaryTree &out_;
    uint32_t n_;
    /// Areas on extents scaled by the scene's extent_scale_of() (core/box.h):
    /// unscaled, the areas of a scene with coordinates near 1e20 overflowed
    /// single precision and every split cost the same.
    const float extent_scale_;
    float area(const Box &b) const { return b.is_empty() ? 0.0f : scaled_half_area(b, extent_scale_); }
    Array<uint32_t> order_; ///< primitive indices, partitioned in place
};

} // namespace

void build_binned_sah(const BuildInput &input, BuildContext &ctx, BinaryTree &out) {
    BinnedSahBuilder(input, ctx, out).build();
}

} // namespace aacbvh
