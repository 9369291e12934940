// The top-down SAH builders the AAC paper compares against (Gu et al. 2013,
// section 6): full-sweep SAH (MacDonald and Booth 1990) and binned SAH with 16
// bins on the longest centroid axis (Wald 2007).
//
// Both split down to one primitive per leaf; flatten.h then decides by the SAH
// where leaves go. Because every range is split, the split choice only compares
// the children's cost A_L * N_L + A_R * N_R: the traversal and intersection
// costs scale every candidate alike and are left to the flattening pass.
//
// Node ids: a node over the range [b, e) of the builder's primitive order that
// splits at m gets id n + m - 1. Every position 1..n-1 is a split point exactly
// once, so ids are unique and depend only on the order, never on the schedule;
// leaf i is the primitive at position i.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "builders.h"
#include "memory.h"

namespace aacbvh {
namespace {

/// Splits whose two sides both hold at least this many primitives run as
/// parallel tasks; smaller sub-trees stay on the current thread.
constexpr uint32_t kForkMin = 4096;
/// Nodes between two cancellation polls.
constexpr uint32_t kCancelPoll = 4096;

/// A range of the primitive order still to split, and where to write its id.
struct RangeTask {
    uint32_t begin;
    uint32_t end;
    uint32_t *id_slot; ///< the parent's child entry, or the tree's root
    Box box;           ///< union of the range's boxes (binned builder only)
    Box centroids;     ///< bounds of the range's centroids (binned builder only)

    uint32_t size() const { return end - begin; }
};

/// Splits `root` and everything below it. split(task, left, right) fills the
/// two halves of a range of two or more primitives. Sub-trees are walked with
/// an explicit stack, so deep, unbalanced trees cannot overflow the thread's
/// stack; only splits with two large sides fork (at most n / kForkMin deep).
template <class Split>
void split_all(BuildContext &ctx, RangeTask root, const Split &split) {
    std::vector<RangeTask> stack{root};
    uint32_t until_poll = kCancelPoll;
    while (!stack.empty()) {
        const RangeTask task = stack.back();
        stack.pop_back();
        if (--until_poll == 0) {
            ctx.poll();
            until_poll = kCancelPoll;
        }
        if (task.size() < 2) {
            *task.id_slot = task.begin;
            continue;
        }
        RangeTask left, right;
        split(task, left, right);
        if (left.size() >= kForkMin && right.size() >= kForkMin) {
            ctx.scheduler().fork_join([&] { split_all(ctx, left, split); },
                                      [&] { split_all(ctx, right, split); });
        } else {
            stack.push_back(right);
            stack.push_back(left);
        }
    }
}

/// Writes the inner node for `task`, split at `mid`, and aims the halves at its children.
void emit_inner(BinaryTree &out, uint32_t n, const RangeTask &task, uint32_t mid, const Box &box,
                RangeTask &left, RangeTask &right) {
    const uint32_t id = n + mid - 1;
    *task.id_slot = id;
    out.boxes[id] = box;
    uint32_t *children = &out.children[2 * size_t(mid - 1)];
    left.begin = task.begin;
    left.end = mid;
    left.id_slot = children;
    right.begin = mid;
    right.end = task.end;
    right.id_slot = children + 1;
}

/// Whether a split of [b, e) at `m` with cost `cost` beats the best so far:
/// lower cost wins, and of equal costs the more balanced split, so that equal
/// boxes give a balanced tree instead of a list.
inline bool better_split(double cost, uint32_t m, double best_cost, uint32_t best_m, uint32_t b, uint32_t e) {
    if (cost != best_cost) return cost < best_cost;
    const int64_t twice_mid = int64_t(b) + e;
    return std::abs(2 * int64_t(m) - twice_mid) < std::abs(2 * int64_t(best_m) - twice_mid);
}

/// Maps a float to an unsigned key with the same order (for sorting).
inline uint32_t float_order_key(float f) {
    uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

// ---------------------------------------------------------------------------
// Full-sweep SAH
// ---------------------------------------------------------------------------

/// Keeps the primitives (index and box) sorted by centroid on each axis,
/// sorted once; sweeps all three lists at every node and partitions them
/// stably, O(n log n) for balanced trees.
class SweepSahBuilder {
public:
    SweepSahBuilder(const BuildInput &input, BuildContext &ctx, BinaryTree &out)
        : input_(input), ctx_(ctx), out_(out), n_(uint32_t(input.size())) {}

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

        split_all(ctx_, RangeTask{0, n_, &out_.root, Box::empty(), Box::empty()},
                  [this](const RangeTask &t, RangeTask &l, RangeTask &r) { split(t, l, r); });

        // After the last split every range holds one primitive, which is then
        // the same in all three orders.
        const uint32_t *order = order_[0].data();
        s.parallel_for(0, n_, 1 << 16, [&](size_t b, size_t e) {
            for (size_t i = b; i < e; ++i) {
                out_.prim_ids[i] = input_.prim_ids[order[i]];
                out_.boxes[i] = input_.boxes[order[i]];
            }
        });
    }

private:
    void sort_axis(int axis) {
        // Key: centroid order in the high half, the index in the low half, so
        // ties keep input order and the sort is deterministic.
        Array<uint64_t> keys(n_);
        for (uint32_t i = 0; i < n_; ++i)
            keys[i] = uint64_t(float_order_key(input_.boxes[i].centroid(axis))) << 32 | i;
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
                right_area[i] = acc.half_area();
            }
            acc = Box::empty();
            for (uint32_t m = b + 1; m < e; ++m) {
                acc.extend(boxes[m - 1]);
                const double cost = double(acc.half_area()) * (m - b) + double(right_area[m]) * (e - m);
                if (better_split(cost, m, best_cost, best_m, b, e)) {
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
        emit_inner(out_, n_, task, best_m, node_box, left, right);
    }

    const BuildInput &input_;
    BuildContext &ctx_;
    BinaryTree &out_;
    uint32_t n_;
    Array<uint32_t> order_[3];   ///< primitive indices sorted by centroid, per axis
    Array<Box> sorted_boxes_[3]; ///< their boxes, so that sweeps read memory in order
    Array<uint32_t> scratch_;    ///< partition buffers, indexed like the orders
    Array<Box> scratch_boxes_;
    Array<float> right_area_;    ///< suffix areas of the sweep, indexed like the orders
    Array<uint8_t> goes_left_;   ///< per primitive: side of the current split
};

// ---------------------------------------------------------------------------
// Binned SAH
// ---------------------------------------------------------------------------

/// Binned SAH: 16 bins over the longest axis of the range's centroid bounds
/// (Wald 2007), O(n) per tree level.
class BinnedSahBuilder {
public:
    static constexpr int kBins = 16;

    BinnedSahBuilder(const BuildInput &input, BuildContext &ctx, BinaryTree &out)
        : input_(input), ctx_(ctx), out_(out), n_(uint32_t(input.size())) {}

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
        split_all(ctx_, root, [this](const RangeTask &t, RangeTask &l, RangeTask &r) { split(t, l, r); });

        ctx_.scheduler().parallel_for(0, n_, 1 << 16, [&](size_t b, size_t e) {
            for (size_t i = b; i < e; ++i) {
                out_.prim_ids[i] = input_.prim_ids[order_[i]];
                out_.boxes[i] = input_.boxes[order_[i]];
            }
        });
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
                right_area[j] = acc.half_area();
            }
            double best_cost = INFINITY;
            int best_j = 0;
            uint32_t best_count = 0, count = 0;
            acc = Box::empty();
            for (int j = 1; j < kBins; ++j) {
                acc.extend(bins[j - 1].box);
                count += bins[j - 1].count;
                if (count == 0 || count == e - b) continue;
                const double cost = double(acc.half_area()) * count + double(right_area[j]) * (e - b - count);
                if (better_split(cost, b + count, best_cost, b + best_count, b, e)) {
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
        emit_inner(out_, n_, task, mid, task.box, left, right);
    }

    const BuildInput &input_;
    BuildContext &ctx_;
    BinaryTree &out_;
    uint32_t n_;
    Array<uint32_t> order_; ///< primitive indices, partitioned in place
};

} // namespace

void build_sweep_sah(const BuildInput &input, double traversal_cost, double intersection_cost,
                     BuildContext &ctx, BinaryTree &out) {
    // Every range is split, so the costs only matter to the flattening pass.
    (void)traversal_cost;
    (void)intersection_cost;
    SweepSahBuilder(input, ctx, out).build();
}

void build_binned_sah(const BuildInput &input, double traversal_cost, double intersection_cost,
                      BuildContext &ctx, BinaryTree &out) {
    (void)traversal_cost;
    (void)intersection_cost;
    BinnedSahBuilder(input, ctx, out).build();
}

} // namespace aacbvh
