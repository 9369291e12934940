// The traversal stack: it lives on the call stack while the tree is shallow.
// Builders do not bound depth (degenerate inputs can give a depth near the
// primitive count), so entries past the fixed part spill into a heap vector,
// allocated only by rays that need it.
#pragma once

#include <cstddef>
#include <vector>

namespace aacbvh {

template <class Entry, size_t kFixed> class SpillStack {
public:
    bool empty() const { return size_ == 0; }
    void push(const Entry &e) {
        if (size_ < kFixed)
            fixed_[size_] = e;
        else
            overflow_.push_back(e);
        ++size_;
    }
    Entry pop() {
        --size_;
        if (size_ < kFixed) return fixed_[size_];
        const Entry e = overflow_.back();
        overflow_.pop_back();
        return e;
    }

private:
    size_t size_ = 0;
    Entry fixed_[kFixed];
    std::vector<Entry> overflow_;
};

} // namespace aacbvh
