#include "bvh/compact_topology.h"

#include <utility>

namespace aacbvh {

namespace {
constexpr uint32_t kNone = 0xFFFFFFFFu;
constexpr uint32_t kTop = 0xFFFFFFFFu;
} // namespace

void CompactTopology::clear() {
    Array<uint8_t>().swap(shape_);
    Array<uint32_t>().swap(targets_);
    Array<Part>().swap(parts_);
    Array<Frame>().swap(frames_);
    Array<PartResult>().swap(results_);
    task_depth_ = 0;
}

bool CompactTopology::encode(const Bvh &bvh, const uint32_t *sources, size_t slot_count) {
    const size_t n = bvh.nodes.size();
    if (n == 0 || n >= kNone) return false;
    const Node *nodes = bvh.nodes.data();
    // The counts go in as the walk below meets the nodes; the marks first.
    Array<uint8_t> shape(n, 0);
    Array<uint32_t> slot_of(n); // binary node -> the wide slot it stands behind (marked nodes only)
    for (size_t s = 0; s < slot_count; ++s) {
        const uint32_t b = sources[s];
        if (b == kNone) continue;
        if (b >= n || (shape[b] & kSourceBit)) return false;
        shape[b] = kSourceBit;
        slot_of[b] = uint32_t(s);
    }

    // One walk over the whole tree in the order walk() takes: checks that
    // every `first` is where the counters say, finds the tasks and sizes
    // their stacks, and lists the marked nodes in walk order with their part.
    struct Mark {
        uint32_t part, slot;
    };
    struct Step {
        uint32_t pos, child, depth;
        bool has_left;
    };
    uint32_t task_depth = 0;
    while (task_depth < kMaxTaskDepth && (n >> task_depth) >= 2 * size_t(kTaskNodes)) ++task_depth;
    std::vector<Part> tasks;
    std::vector<Mark> marks;
    std::vector<Step> stack;
    uint32_t pos = 0, depth = 0, pair = 1, slot = 0, part = kTop;
    size_t task_base = 0, top_height = 0;
    const size_t slots = bvh.prim_ids.size();
    for (;;) {
        for (;;) {
            if (part == kTop && depth == task_depth) {
                part = uint32_t(tasks.size());
                tasks.push_back(Part{pos, depth, pair, slot, 0, 0, 0, 0, 1});
                task_base = stack.size();
            }
            const Node &node = nodes[pos];
            if (node.count != 0) {
                if (node.first != slot || node.count > slots - slot || node.count > kMaxLeafCount) return false;
                shape[pos] |= uint8_t(node.count);
                slot += node.count;
                break;
            }
            if (node.first != pair || size_t(pair) + 1 >= n) return false;
            stack.push_back(Step{pos, pair, depth, false});
            if (part == kTop)
                top_height = std::max(top_height, stack.size());
            else
                tasks[part].height = std::max<uint32_t>(tasks[part].height, uint32_t(stack.size() - task_base));
            pos = pair;
            pair += 2;
            ++depth;
        }
        bool done = false;
        for (;;) {
            if (shape[pos] & kSourceBit) marks.push_back(Mark{part, slot_of[pos]});
            if (part != kTop && pos == tasks[part].root) {
                tasks[part].pairs_used = pair - tasks[part].pair;
                tasks[part].slots_used = slot - tasks[part].slot;
                part = kTop;
            }
            if (stack.empty()) {
                done = true;
                break;
            }
            Step &f = stack.back();
            if (!f.has_left) {
                f.has_left = true;
                pos = f.child + 1;
                depth = f.depth + 1;
                break;
            }
            pos = f.pos;
            stack.pop_back();
        }
        if (done) break;
    }
    if (pair != n || slot != slots) return false;
    std::vector<Step>().swap(stack);
    Array<uint32_t>().swap(slot_of);

    // Each part's marks together: the tasks' (met in task order), then the top's.
    Array<uint32_t> targets(marks.size());
    std::vector<uint32_t> task_marks(tasks.size(), 0);
    size_t t = 0;
    for (const Mark &m : marks)
        if (m.part != kTop) {
            targets[t++] = m.slot;
            ++task_marks[m.part];
        }
    const uint32_t top_target = uint32_t(t);
    for (const Mark &m : marks)
        if (m.part == kTop) targets[t++] = m.slot;
    Array<Part> parts(tasks.size() + 1);
    uint32_t target = 0, frame = 0;
    for (size_t i = 0; i < tasks.size(); ++i) {
        parts[i] = tasks[i];
        parts[i].target = target;
        parts[i].frame = frame;
        target += task_marks[i];
        frame += parts[i].height;
    }
    parts[tasks.size()] = Part{0, 0, 1, 0, top_target, pair - 1, slot, frame, uint32_t(std::max<size_t>(top_height, 1))};
    frame += parts[tasks.size()].height;
    Array<Frame> frames(frame);
    Array<PartResult> results(tasks.size());

    shape_ = std::move(shape);
    targets_ = std::move(targets);
    parts_ = std::move(parts);
    frames_ = std::move(frames);
    results_ = std::move(results);
    task_depth_ = task_depth;
    return true;
}

void CompactTopology::decode(Array<Node> &nodes) const {
    const size_t n = shape_.size();
    nodes.resize(n);
    if (n == 0) return;
    // The emitted layout's own walk: left first, a pair for each inner node as it is met.
    std::vector<uint32_t> stack{0u};
    uint32_t pair = 1, slot = 0;
    while (!stack.empty()) {
        const uint32_t pos = stack.back();
        stack.pop_back();
        Node &node = nodes[pos];
        node.box = Box::empty();
        node.count = shape_[pos] & ~uint32_t(kSourceBit);
        if (node.count != 0) {
            node.first = slot;
            slot += node.count;
        } else {
            node.first = pair;
            stack.push_back(pair + 1);
            stack.push_back(pair);
            pair += 2;
        }
    }
}

} // namespace aacbvh
