#include "build/aac/top_rebuild.h"

#include <algorithm>
#include <type_traits>
#include <vector>

#include "build/radix_sort.h"
#include "build/reference/top_down_split.h"
#include "core/memory.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace aacbvh {

namespace {

/// A box as the sweeps read it: the low corner and the negated high corner
/// (lane 3 a spare 0), so that a union is two minima, in one SSE register
/// each where the compiler has SSE2. The same operations as Box::extend()
/// and scaled_half_area() on finite boxes, in the same order, so either
/// form gives the same areas bit for bit.
#if defined(__SSE2__)
struct SweepBox {
    __m128 lo, neg_hi;

    static SweepBox empty() { return of(Box::empty()); }
    static SweepBox of(const Box &b) {
        return SweepBox{_mm_setr_ps(b.lo[0], b.lo[1], b.lo[2], 0.0f), _mm_setr_ps(-b.hi[0], -b.hi[1], -b.hi[2], 0.0f)};
    }
    Box box() const {
        alignas(16) float l[4], h[4];
        _mm_store_ps(l, lo);
        _mm_store_ps(h, neg_hi);
        return Box{{l[0], l[1], l[2]}, {-h[0], -h[1], -h[2]}};
    }
    void extend(const SweepBox &b) {
        lo = _mm_min_ps(b.lo, lo);
        neg_hi = _mm_min_ps(b.neg_hi, neg_hi);
    }
    float scaled_half_area(float scale) const {
        const __m128 hi = _mm_xor_ps(neg_hi, _mm_set1_ps(-0.0f));
        const __m128 d = _mm_mul_ps(_mm_sub_ps(hi, lo), _mm_set1_ps(scale));
        const __m128 p = _mm_mul_ps(d, _mm_shuffle_ps(d, d, _MM_SHUFFLE(3, 0, 2, 1))); // dx dy, dy dz, dz dx
        const __m128 sum = _mm_add_ss(p, _mm_shuffle_ps(p, p, _MM_SHUFFLE(1, 1, 1, 1)));
        return _mm_cvtss_f32(_mm_add_ss(sum, _mm_shuffle_ps(p, p, _MM_SHUFFLE(2, 2, 2, 2))));
    }
};
#else
struct SweepBox {
    float lo[3], neg_hi[3];

    static SweepBox empty() { return of(Box::empty()); }
    static SweepBox of(const Box &b) { return SweepBox{{b.lo[0], b.lo[1], b.lo[2]}, {-b.hi[0], -b.hi[1], -b.hi[2]}}; }
    Box box() const { return Box{{lo[0], lo[1], lo[2]}, {-neg_hi[0], -neg_hi[1], -neg_hi[2]}}; }
    void extend(const SweepBox &b) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = b.lo[k] < lo[k] ? b.lo[k] : lo[k];
            neg_hi[k] = b.neg_hi[k] < neg_hi[k] ? b.neg_hi[k] : neg_hi[k];
        }
    }
    float scaled_half_area(float scale) const { return aacbvh::scaled_half_area(box(), scale); }
};
#endif

/// A child reference of the new top: a sub-tree below the cut (an element,
/// by its index, with this bit set) or a new node (by its local index).
constexpr uint32_t kElement = 0x80000000u;

/// The new top is built over element indices sorted by centroid on each axis
/// (sorted once, partitioned stably at every split, as the full-sweep
/// builder does; the sweeps read each element's box and primitive count
/// through its index, so a partition moves only indices); a node over the
/// sorted range [b, e) split at m gets local index m - 1, as in
/// top_down::emit_inner(), whatever the schedule.
class TopRebuild {
public:
    TopRebuild(BinaryTree &tree, ChoiceTable choices, const FlattenRule &rule, uint32_t cut_prims, BuildContext &ctx)
        : tree_(tree), choices_(choices), rule_(rule), cut_(cut_prims), ctx_(ctx), n_(tree.leaf_count()) {}

    bool run() {
        if (tree_.is_leaf(tree_.root) || choices_.prims(tree_.root - n_) <= cut_) return false;
        collect();
        const uint32_t count = uint32_t(elements_.size());
        if (count < 3) return false; // one top node: nothing to choose
        boxes_.resize(count);
        prims_.resize(count);
        for (uint32_t i = 0; i < count; ++i) {
            boxes_[i] = SweepBox::of(tree_.boxes[elements_[i]]);
            prims_[i] = prims_of(elements_[i]);
        }
        sort_all(count);
        const uint32_t root = split_all(count);
        // The build's peak lies here (docs/PERFORMANCE.md, row 214): what
        // only the sweeps read goes before the choices come.
        release(order_[0], order_[1], order_[2], boxes_, prims_, scratch_, right_area_, right_prims_, goes_left_);
        choose(count, root);
        // The root's flattened cost, stored in single precision as the
        // choices store it: the new top only where it is strictly cheaper.
        if (!(float(node_choice_[root].cost) < float(choices_.get(tree_.root - n_).cost))) return false;
        commit(count, root);
        return true;
    }

private:
    /// Work on both sides of a node forks into parallel tasks where each
    /// side holds this many elements (sub-trees below the cut) or more. At
    /// 1,024 the bunny's top (about 2,000 sub-trees) was split on one thread
    /// only; 256 made two-thread AAC-HQ builds of the bunny 2.7-4.8 %
    /// faster (docs/PERFORMANCE.md, row 301).
    static constexpr uint32_t kForkMin = 256;

    template <class... Arrays> static void release(Arrays &...arrays) { (std::decay_t<Arrays>().swap(arrays), ...); }

    /// The elements' indices sorted by centroid on each axis (order_).
    void sort_all(uint32_t count) {
        Array<uint64_t> keys[3];
        for (int axis = 0; axis < 3; ++axis) {
            keys[axis].resize(count);
            order_[axis].resize(count);
        }
        // The three sorts as parallel tasks where they are big enough to pay
        // for a task (the top-down builders' kForkMin).
        Scheduler &scheduler = ctx_.scheduler();
        if (count >= top_down::kForkMin) {
            scheduler.fork_join([&] { sort_axis(0, keys[0]); }, [&] {
                scheduler.fork_join([&] { sort_axis(1, keys[1]); }, [&] { sort_axis(2, keys[2]); });
            });
        } else {
            for (int axis = 0; axis < 3; ++axis) sort_axis(axis, keys[axis]);
        }
    }

    /// The maximal sub-trees of at most cut_ primitives (elements_, left to
    /// right) and the inner nodes above them (top_ids_, depth first, left
    /// first).
    void collect() { collect_below(tree_.root, elements_, top_ids_); }

    /// collect() below `root`, appended to `elements` and `tops`. On several
    /// threads, a node whose two children each hold kForkMin sub-trees' worth
    /// of primitives or more collects them as parallel tasks, each into lists
    /// of its own, appended in order: the same lists at any thread count.
    void collect_below(uint32_t root, std::vector<uint32_t> &elements, std::vector<uint32_t> &tops) {
        // One thread: no lists to join (the same lists either way).
        const bool may_fork = ctx_.scheduler().thread_count() > 1;
        const uint64_t fork_prims = uint64_t(kForkMin) * cut_;
        std::vector<uint32_t> stack{root};
        while (!stack.empty()) {
            const uint32_t id = stack.back();
            stack.pop_back();
            if (tree_.is_leaf(id) || choices_.prims(id - n_) <= cut_) {
                elements.push_back(id);
                continue;
            }
            tops.push_back(id);
            const uint32_t l = tree_.left(id), r = tree_.right(id);
            // The node's own count first: its children's are not read yet
            // (asked for below), and most nodes are too small to fork.
            if (may_fork && choices_.prims(id - n_) >= 2 * fork_prims && prims_of(l) >= fork_prims &&
                prims_of(r) >= fork_prims) {
                std::vector<uint32_t> left_elements, left_tops, right_elements, right_tops;
                ctx_.scheduler().fork_join([&] { collect_below(l, left_elements, left_tops); },
                                           [&] { collect_below(r, right_elements, right_tops); });
                elements.insert(elements.end(), left_elements.begin(), left_elements.end());
                elements.insert(elements.end(), right_elements.begin(), right_elements.end());
                tops.insert(tops.end(), left_tops.begin(), left_tops.end());
                tops.insert(tops.end(), right_tops.begin(), right_tops.end());
                continue;
            }
            // Both children's counts and child entries are read soon, from
            // ids scattered over the tree: ask for them now.
            for (const uint32_t c : {l, r})
                if (!tree_.is_leaf(c)) {
                    choices_.prefetch_counts(c - n_);
                    __builtin_prefetch(&tree_.children[2 * size_t(c - n_)]);
                }
            stack.push_back(r);
            stack.push_back(l);
        }
    }

    uint32_t prims_of(uint32_t id) const { return tree_.is_leaf(id) ? 1u : choices_.prims(id - n_); }
    SubtreeChoice choice_of(uint32_t id) const {
        return tree_.is_leaf(id) ? rule_.leaf(tree_.boxes[id]) : choices_.get(id - n_);
    }

    /// order_[axis]: element indices by centroid on `axis`, ties by index
    /// (the elements' left-to-right order). `keys` and order_[axis] are
    /// allocated by the calling thread (MemoryMeter counts them), sized
    /// to the element count.
    void sort_axis(int axis, Array<uint64_t> &keys) {
        const uint32_t count = uint32_t(elements_.size());
        Array<uint32_t> &order = order_[axis];
        for (uint32_t i = 0; i < count; ++i) {
            keys[i] = top_down::float_order_key(tree_.boxes[elements_[i]].centroid(axis));
            order[i] = i;
        }
        radix_sort_pairs(keys, order, 32, ctx_.scheduler()); // stable: ties in index order
    }

    struct Range {
        uint32_t begin, end;
        uint32_t *slot; ///< the parent's child entry, or the root's
    };

    /// Splits every range of two or more elements; returns the root's local index.
    uint32_t split_all(uint32_t count) {
        node_box_.resize(count - 1);
        node_child_.resize(2 * size_t(count - 1));
        scratch_.resize(count);
        right_area_.resize(count);
        right_prims_.resize(count);
        goes_left_.resize(count);
        uint32_t root = 0;
        split_below(Range{0, count, &root});
        return root;
    }

    /// Splits `range` and everything below it with an explicit stack (a
    /// sweep's tree can be as deep as its element count); splits whose two
    /// sides both hold kForkMin elements or more run as parallel tasks. Each
    /// range writes only its own positions of the orders and scratch, its own
    /// elements' sides and its own node (local index m - 1), so the result
    /// does not depend on the schedule.
    void split_below(Range range) {
        std::vector<Range> stack{range};
        PollingCounter work(ctx_);
        while (!stack.empty()) {
            const Range r = stack.back();
            stack.pop_back();
            if (r.end - r.begin == 1) {
                *r.slot = kElement | order_[0][r.begin];
                continue;
            }
            work.add(r.end - r.begin);
            const uint32_t m = split(r.begin, r.end);
            const uint32_t k = m - 1;
            *r.slot = k;
            const Range left{r.begin, m, &node_child_[2 * size_t(k)]};
            const Range right{m, r.end, &node_child_[2 * size_t(k) + 1]};
            if (m - r.begin >= kForkMin && r.end - m >= kForkMin) {
                ctx_.scheduler().fork_join([&] { split_below(left); }, [&] { split_below(right); });
            } else {
                stack.push_back(right);
                stack.push_back(left);
            }
        }
    }

    /// The full sweep of [b, e) on all three axes: minimises SA(left) *
    /// N(left) + SA(right) * N(right), N counting primitives (ties:
    /// top_down::better_split(), then the lower axis); partitions the other
    /// axes' orders to match and sets the node's box. Returns the split.
    uint32_t split(uint32_t b, uint32_t e) {
        const float scale = rule_.extent_scale;
        double best_cost = INFINITY;
        uint32_t best_m = b + 1;
        int best_axis = 0;
        SweepBox node_box = SweepBox::empty();
        for (int axis = 0; axis < 3; ++axis) {
            const uint32_t *order = order_[axis].data();
            SweepBox acc = SweepBox::empty();
            uint32_t acc_prims = 0; // at most the tree's primitive count
            for (uint32_t i = e - 1; i > b; --i) {
                acc.extend(boxes_[order[i]]);
                acc_prims += prims_[order[i]];
                right_area_[i] = acc.scaled_half_area(scale);
                right_prims_[i] = acc_prims;
            }
            acc = SweepBox::empty();
            acc_prims = 0;
            for (uint32_t m = b + 1; m < e; ++m) {
                acc.extend(boxes_[order[m - 1]]);
                acc_prims += prims_[order[m - 1]];
                const double cost = double(acc.scaled_half_area(scale)) * double(acc_prims) +
                                    double(right_area_[m]) * double(right_prims_[m]);
                if (top_down::better_split(cost, m, best_cost, best_m, b, e)) {
                    best_cost = cost;
                    best_m = m;
                    best_axis = axis;
                }
            }
            if (axis == 0) {
                acc.extend(boxes_[order[e - 1]]);
                node_box = acc;
            }
        }
        node_box_[best_m - 1] = node_box.box();
        const uint32_t *chosen = order_[best_axis].data();
        for (uint32_t i = b; i < e; ++i) goes_left_[chosen[i]] = i < best_m;
        for (int axis = 0; axis < 3; ++axis) {
            if (axis == best_axis) continue;
            uint32_t *order = order_[axis].data();
            uint32_t l = b, r = b;
            for (uint32_t i = b; i < e; ++i) { // branch-free: the side is a coin flip
                const uint32_t p = order[i];
                const uint32_t left = goes_left_[p];
                order[l] = p; // l <= i: never past what is read
                scratch_[r] = p;
                l += left;
                r += 1 - left;
            }
            std::copy(&scratch_[b], &scratch_[b] + (r - b), order + l);
        }
        return best_m;
    }

    SubtreeChoice child_choice(uint32_t ref) const {
        return (ref & kElement) != 0 ? choice_of(elements_[ref & ~kElement]) : node_choice_[ref];
    }

    /// Every new node's choice, children first.
    void choose(uint32_t count, uint32_t root) {
        node_choice_.resize(count - 1);
        choose_below(root, 0, count);
    }

    /// The choices of new node k's sub-tree, which holds the elements of the
    /// sorted range [b, e): node k is its split m less 1, so its left
    /// sub-tree holds [b, k + 1) and its right [k + 1, e). On several threads,
    /// where both sides hold kForkMin elements or more they are chosen as
    /// parallel tasks, as split_below() splits them; below (and on one
    /// thread), by a walk that meets each node twice, the second time
    /// (marked) once its children are done. A node's choice depends on its
    /// children's alone, so the schedule changes nothing.
    void choose_below(uint32_t k, uint32_t b, uint32_t e) {
        const uint32_t l = node_child_[2 * size_t(k)], r = node_child_[2 * size_t(k) + 1];
        if (ctx_.scheduler().thread_count() > 1 && k + 1 - b >= kForkMin && e - (k + 1) >= kForkMin) {
            ctx_.scheduler().fork_join([&] { choose_below(l, b, k + 1); }, [&] { choose_below(r, k + 1, e); });
            node_choice_[k] = rule_.inner(node_box_[k], child_choice(l), child_choice(r));
            return;
        }
        constexpr uint32_t kChildrenDone = 0x80000000u;
        std::vector<uint32_t> stack{k};
        while (!stack.empty()) {
            const uint32_t top = stack.back();
            const uint32_t node = top & ~kChildrenDone;
            const uint32_t nl = node_child_[2 * size_t(node)], nr = node_child_[2 * size_t(node) + 1];
            if ((top & kChildrenDone) == 0) {
                stack.back() = top | kChildrenDone;
                if ((nr & kElement) == 0) stack.push_back(nr);
                if ((nl & kElement) == 0) stack.push_back(nl);
                continue;
            }
            stack.pop_back();
            node_choice_[node] = rule_.inner(node_box_[node], child_choice(nl), child_choice(nr));
        }
    }

    uint32_t tree_id(uint32_t ref) const {
        return (ref & kElement) != 0 ? elements_[ref & ~kElement] : top_ids_[ref];
    }

    /// The new top written over the old one's ids.
    void commit(uint32_t count, uint32_t root) {
        for (uint32_t k = 0; k + 1 < count; ++k) {
            const uint32_t id = top_ids_[k];
            tree_.boxes[id] = node_box_[k];
            tree_.set_children(id, tree_id(node_child_[2 * size_t(k)]), tree_id(node_child_[2 * size_t(k) + 1]));
            choices_.set(id - n_, node_choice_[k]);
        }
        tree_.root = top_ids_[root];
    }

    BinaryTree &tree_;
    ChoiceTable choices_;
    const FlattenRule &rule_;
    const uint32_t cut_;
    BuildContext &ctx_;
    const uint32_t n_;
    std::vector<uint32_t> elements_; ///< tree ids of the sub-trees below the cut
    std::vector<uint32_t> top_ids_;  ///< tree ids of the old top's inner nodes
    Array<uint32_t> order_[3];
    Array<SweepBox> boxes_;          ///< per element
    Array<uint32_t> prims_;          ///< per element: primitives below it
    Array<Box> node_box_;            ///< per new node
    Array<uint32_t> node_child_;     ///< per new node, two child references
    Array<SubtreeChoice> node_choice_;
    Array<uint32_t> scratch_;
    Array<float> right_area_;
    Array<uint32_t> right_prims_;
    Array<uint8_t> goes_left_;
};

} // namespace

bool rebuild_top(BinaryTree &tree, ChoiceTable choices, const FlattenRule &rule, uint32_t cut_prims,
                 BuildContext &ctx) {
    return TopRebuild(tree, choices, rule, cut_prims, ctx).run();
}

} // namespace aacbvh
