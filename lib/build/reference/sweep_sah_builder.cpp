// Top-down full-sweep SAH (MacDonald and Booth 1990), the quality reference
// the AAC paper compares against (Gu et al. 2013, section 6).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "build/reference/reference_builders.h"
#include "build/reference/top_down_split.h"
#include "core/memory.h"

namespace aacbvh {
namespace {

using top_down::RangeTask;

/// Keeps the primitives (index and box) sorted by centroid on each axis,
/// sorted once; sweeps all three lists at every node and partitions them
/// stably, O(n log n) for balanced trees.
class SweepSahBuilder {
public:
    SweepSahBuilder(const BuildInput &input, BuildContext &ctx, BinaryTree &out)
        : input_(input), ctx_(ctx), out_(out), n_(uint32_t(input.size())),
          extent_scale_(extent_scale_of(input.bounds)) {}

    void build() {
        out_.resize(n_);
        for (auto &order : order_) order.resize(n_);
        for (auto &boxes : sorted_boxes_) boxes.resize(n_);
        scratch_.resize(n_);
        scratch_boxes_.resize(n_);
        right_area_.resize(n_);
        goes_left_.resize(n_);
        Scheduler &s = ctx_.scheduler();
        s.fork_join([&] { sort_axis(0); }, [&] { s.fork_join([&] { sort_axis(1); }, [&] { sort_axis(2); }); });
        ctx_.poll();

        top_down::split_all(ctx_, RangeTask{0, n_, &out_.root, Box::empty(), Box::empty()},
                  [this](const RangeTask &t, RangeTask &l, RangeTask &r) { split(t, l, r); });

        // After the last split every range holds one primitive, which is then
        // the same in all three orders.
        gather_leaves(input_, order_[0].data(), s, out_);
    }

private:
    void sort_axis(int axis) {
        // Key: centroid order in the high half, the index in the low half, so
        // ties keep input order and the sort is deterministic.
        Array<uint64_t> keys(n_);
        for (uint32_t i = 0; i < n_; ++i)
            keys[i] = uint64_t(top_down::float_order_key(input_.boxes[i].centroid(axis))) << 32 | i;
        std::sort(keys.begin(), keys.end());
        for (uint32_t i = 0; i < n_; ++i) {
            const uint32_t p = uint32_t(keys[i]);
            order_[axis][i] = p;
            sorted_boxes_[axis][i] = input_.boxes[p];
        }
    }

    void split(const RangeTask &task, RangeTask &left, RangeTask &right) {
        const uint32_t b = task.begin, e = task.end;
        float *right_area = right_area_.data();
        double best_cost = INFINITY;
        uint32_t best_m = b + 1;
        int best_axis = 0;
        Box node_box = Box::empty();
        for (int axis = 0; axis < 3; ++axis) {
            const Box *boxes = sorted_boxes_[axis].data();
            // right_area[i]: area of the primitives [i, e).
            Box acc = Box::empty();
            for (uint32_t i = e - 1; i > b; --i) {
                acc.extend(boxes[i]);
                right_area[i] = scaled_half_area(acc, extent_scale_);
            }
            acc = Box::empty();
            for (uint32_t m = b + 1; m < e; ++m) {
                acc.extend(boxes[m - 1]);
                const double cost =
                    double(scaled_half_area(acc, extent_scale_)) * (m - b) + double(right_area[m]) * (e - m);
                if (top_down::better_split(cost, m, best_cost, best_m, b, e)) {
                    best_cost = cost;
                    best_m = m;
                    best_axis = axis;
                }
            }
            if (axis == 0) {
                acc.extend(boxes[e - 1]);
                node_box = acc;
            }
        }

        const uint32_t *chosen = order_[best_axis].data();
        uint8_t *goes_left = goes_left_.data();
        for (uint32_t i = b; i < e; ++i) goes_left[chosen[i]] = i < best_m;
        for (int axis = 0; axis < 3; ++axis) {
            if (axis == best_axis) continue;
            // Stable partition through the scratch range [b, e), which no
            // other task touches.
            uint32_t *order = order_[axis].data();
            Box *boxes = sorted_boxes_[axis].data();
            uint32_t *scratch = scratch_.data();
            Box *scratch_boxes = scratch_boxes_.data();
            uint32_t l = b, r = b;
            for (uint32_t i = b; i < e; ++i) {
                const uint32_t p = order[i];
                if (goes_left[p]) {
                    boxes[l] = boxes[i];
                    order[l++] = p;
                } else {
                    scratch_boxes[r] = boxes[i];
                    scratch[r++] = p;
                }
            }
            std::copy(scratch + b, scratch + r, order + l);
            std::copy(scratch_boxes + b, scratch_boxes + r, boxes + l);
        }
        top_down::emit_inner(out_, n_, task, best_m, node_box, left, right);
    }

    const BuildInput &input_;
    BuildContext &ctx_;
    BinaryTree &out_;
    uint32_t n_;
    Array<uint32_t> order_[3];   ///< primitive indices sorted by centroid, per axis
    Array<Box> sorted_boxes_[3]; ///< their boxes, so that sweeps read memory in order
    Array<uint32_t> scratch_;    ///< partition buffers, indexed like the orders
    Array<Box> scratch_boxes_;
    /// Areas on extents scaled by the scene's extent_scale_of() (core/box.h):
    /// unscaled, the areas of a scene with coordinates near 1e20 overflowed
    /// single precision and every split cost the same.
    const float extent_scale_;
    Array<float> right_area_;    ///< suffix areas of the sweep, indexed like the orders
    Array<uint8_t> goes_left_;   ///< per primitive: side of the current split
};

} // namespace

void build_sweep_sah(const BuildInput &input, BuildContext &ctx, BinaryTree &out) {
    SweepSahBuilder(input, ctx, out).build();
}

} // namespace aacbvh
