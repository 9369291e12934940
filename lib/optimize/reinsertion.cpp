#include "optimize/reinsertion.h"

#include <algorithm>

#include "core/memory.h"

namespace aacbvh {

namespace {

/// Levels a search walks up from the node's parent: places further away are
/// not looked at (Meister and Bittner search the whole tree; a bound keeps a
/// round linear). On AAC-HQ's bunny, 24 levels or 128 visits instead of 12
/// and 32 find the same SAH after 6 passes within 0.3% (docs/PERFORMANCE.md).
constexpr int kReinsertLevels = 12;
/// Nodes a search may visit below the levels it walked up.
constexpr int kReinsertVisits = 32;
/// Moves are taken only if they gain more than this fraction of the root's
/// area, so that rounding noise never moves anything.
constexpr double kMinGain = 1e-9;
/// Longest ancestor walk when checking a move against those taken before it;
/// deeper targets are skipped (this keeps the greedy step linear).
constexpr int kMaxWalk = 256;

constexpr uint32_t kNone = UINT32_MAX;

} // namespace

uint64_t Reinsertion::round() {
    undo_log_.clear();
    root_before_ = t_.root;
    if (n_ < 3 || choices_.leaves(t_.root - n_) < 3) return 0;
    const size_t slots = 2 * size_t(n_);
    parent_.resize(slots);
    order_.resize(slots);
    stack_.resize(slots);
    flags_.assign(slots, 0);
    const size_t count = preorder();
    moves_.resize(count);
    area_scale_ = extent_scale_of(t_.boxes[t_.root]);
    root_area_ = half_area(t_.boxes[t_.root]);
    ctx_.poll();

    // Searches, on the tree as it is: order_[0, count) are every node in
    // pre-order; the root and its children cannot move.
    ctx_.scheduler().parallel_for(0, count, 256, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) moves_[i] = search(order_[i]);
        ctx_.poll();
    });

    // The moves found, packed to the front and sorted where they lie, best
    // first; node ids break ties so the order is fixed. (Sorting indices
    // into the moves read each compared move through its index: after a
    // refit the dragon finds 400 K moves a round, whose sort took 50 ms.)
    size_t nf = 0;
    for (size_t i = 0; i < count; ++i)
        if (moves_[i].target != kNone) moves_[nf++] = moves_[i];
    std::sort(moves_.begin(), moves_.begin() + nf, [](const Move &a, const Move &b) {
        if (a.delta != b.delta) return a.delta < b.delta;
        return a.node < b.node;
    });
    ctx_.poll(); // the last chance to cancel with the tree untouched

    undo_log_.reserve(3 * nf); // before the first move: a failure leaves the tree as it was
    uint64_t made = 0;
    for (size_t k = 0; k < nf; ++k)
        if (take(moves_[k])) ++made;
    return made;
}

uint32_t Reinsertion::sibling(uint32_t id) const {
    const uint32_t p = parent_[id];
    return t_.left(p) == id ? t_.right(p) : t_.left(p);
}

/// Parents, and every node in pre-order into order_; returns the count.
size_t Reinsertion::preorder() {
    size_t count = 0, top = 0;
    parent_[t_.root] = kNone;
    stack_[top++] = t_.root;
    while (top > 0) {
        const uint32_t id = stack_[--top];
        order_[count++] = id;
        if (atomic(id)) continue;
        const uint32_t l = t_.left(id), r = t_.right(id);
        parent_[l] = id;
        parent_[r] = id;
        stack_[top++] = r;
        stack_[top++] = l;
    }
    return count;
}

/// The best place for `node`, or target kNone. Reads only.
Reinsertion::Move Reinsertion::search(uint32_t node) const {
    Move best{0.0, node, kNone};
    const uint32_t p = parent_[node];
    if (p == kNone || parent_[p] == kNone) return best;
    const Box nb = t_.boxes[node];
    const double node_area = half_area(nb);
    double best_delta = -kMinGain * root_area_;

    // A target X in the sub-tree of another child of ancestor Y costs,
    // besides the fixed part (minus the areas the removal takes away
    // below Y), the growth of X's ancestors below Y and the new node's
    // A(X + node). Each X is weighed when it is reached; the heap holds
    // the sub-trees below reached nodes, by a lower bound of their cost:
    // the growth down to them plus A(node).
    struct Entry {
        double bound, cost; ///< cost: of X's children, their ancestors' growth included
        uint32_t id;
    };
    Entry heap[kReinsertLevels + 2 * kReinsertVisits + 2];
    int size = 0;
    auto consider = [&](double delta, uint32_t target) {
        if (delta < best_delta) {
            best_delta = delta;
            best.delta = delta;
            best.target = target;
        }
    };
    auto reach = [&](double cost, uint32_t id) {
        const Box &xb = t_.boxes[id];
        const double joined = joined_half_area(xb, nb);
        consider(cost + joined, id);
        if (atomic(id)) return;
        const double below = cost + (joined - half_area(xb)); // id grows by the node
        const double bound = below + node_area;
        if (!(bound < best_delta) || size == int(sizeof heap / sizeof heap[0])) return;
        int i = size++;
        while (i > 0 && heap[(i - 1) / 2].bound > bound) {
            heap[i] = heap[(i - 1) / 2];
            i = (i - 1) / 2;
        }
        heap[i] = {bound, below, id};
    };
    auto pop = [&]() {
        const Entry top = heap[0];
        const Entry last = heap[--size];
        int i = 0;
        for (;;) {
            int c = 2 * i + 1;
            if (c >= size) break;
            if (c + 1 < size && heap[c + 1].bound < heap[c].bound) ++c;
            if (!(heap[c].bound < last.bound)) break;
            heap[i] = heap[c];
            i = c;
        }
        heap[i] = last;
        return top;
    };

    // Taking the node out removes its parent; the sibling takes its place.
    double fixed = -half_area(t_.boxes[p]);
    const uint32_t s = sibling(node);
    reach(fixed, s);
    Box without = t_.boxes[s]; // the current ancestor's contents without the node
    uint32_t on_path = p;
    for (int level = 0; level < kReinsertLevels; ++level) {
        const uint32_t y = parent_[on_path];
        if (y == kNone) break;
        const uint32_t other = t_.left(y) == on_path ? t_.right(y) : t_.left(y);
        reach(fixed, other); // y keeps the node: unchanged
        without = unite(without, t_.boxes[other]);
        const double y_area = half_area(t_.boxes[y]);
        fixed -= y_area - half_area(without); // y shrinks once the node leaves it
        // Inserting above y: the new node has y's current box.
        consider(fixed + y_area, y);
        on_path = y;
    }
    int visits = 0;
    while (size > 0 && visits < kReinsertVisits) {
        const Entry e = pop();
        if (!(e.bound < best_delta)) break;
        ++visits;
        reach(e.cost, t_.left(e.id));
        reach(e.cost, t_.right(e.id));
    }
    return best;
}

/// Makes the move unless it touches a node an earlier move changed (its
/// gain was weighed on the tree before them) or its target now lies below
/// the node (which would close a cycle). parent_ is kept current.
bool Reinsertion::take(const Move &m) {
    const uint32_t node = m.node, target = m.target;
    // An earlier move that went above the root made the node, or its
    // parent, the root (both flagged): it has no sibling or grandparent to
    // look at now.
    const uint32_t p = parent_[node];
    if (p == kNone || parent_[p] == kNone) return false;
    const uint32_t s = sibling(node), g = parent_[p], tp = parent_[target];
    const uint32_t touched[6] = {node, p, s, g, target, tp};
    for (uint32_t id : touched)
        if (id != kNone && flags_[id]) return false;
    int walk = 0;
    for (uint32_t a = target; a != kNone; a = parent_[a])
        if (a == node || ++walk > kMaxWalk) return false;
    for (uint32_t id : touched)
        if (id != kNone) flags_[id] = 1;

    // Out: s replaces p under g. In: p, reused, joins target and node
    // where target was.
    remember(g);
    if (tp != kNone) remember(tp);
    remember(p);
    replace_child(g, p, s);
    parent_[s] = g;
    if (tp == kNone)
        t_.root = p;
    else
        replace_child(tp, target, p);
    parent_[p] = tp;
    t_.set_children(p, target, node);
    parent_[target] = p;
    parent_[node] = p;
    return true;
}

void Reinsertion::undo() {
    for (size_t k = undo_log_.size(); k-- > 0;) {
        const Children &c = undo_log_[k];
        t_.set_children(c.node, c.left, c.right);
    }
    undo_log_.clear();
    t_.root = root_before_;
}

void Reinsertion::replace_child(uint32_t parent, uint32_t from, uint32_t to) {
    if (t_.left(parent) == from)
        t_.set_children(parent, to, t_.right(parent));
    else
        t_.set_children(parent, t_.left(parent), to);
}

} // namespace aacbvh
