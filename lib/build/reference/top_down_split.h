// What the top-down SAH builders (sweep, binned) share: the split recursion
// over ranges of the primitive order, the inner node it writes, and the tie
// rule between equal-cost splits.
//
// Both split down to one primitive per leaf; build/flatten.h then decides by
// the SAH where leaves go. Because every range is split, the split choice only
// compares the children's cost A_L * N_L + A_R * N_R: the traversal and
// intersection costs scale every candidate alike and are left to flattening.
//
// Node ids: a node over the range [b, e) of the builder's primitive order that
// splits at m gets id n + m - 1. Every position 1..n-1 is a split point exactly
// once, so ids are unique and depend only on the order, never on the schedule;
// leaf i is the primitive at position i.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "core/box.h"

namespace aacbvh {
namespace top_down {

/// Splits whose two sides both hold at least this many primitives run as
/// parallel tasks; smaller sub-trees stay on the current thread.
constexpr uint32_t kForkMin = 4096;

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
    PollingCounter work(ctx); // a split sweeps its range: polls follow the primitives swept
    while (!stack.empty()) {
        const RangeTask task = stack.back();
        stack.pop_back();
        work.add(task.size());
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
inline void emit_inner(BinaryTree &out, uint32_t n, const RangeTask &task, uint32_t mid, const Box &box,
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

/// Maps a float to an unsigned key with the same order (for sorting).
inline uint32_t float_order_key(float f) {
    uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

/// Whether a split of [b, e) at `m` with cost `cost` beats the best so far:
/// lower cost wins, and of equal costs the more balanced split, so that equal
/// boxes give a balanced tree instead of a list.
inline bool better_split(double cost, uint32_t m, double best_cost, uint32_t best_m, uint32_t b, uint32_t e) {
    if (cost != best_cost) return cost < best_cost;
    const int64_t twice_mid = int64_t(b) + e;
    return std::abs(2 * int64_t(m) - twice_mid) < std::abs(2 * int64_t(best_m) - twice_mid);
}

} // namespace top_down
} // namespace aacbvh
