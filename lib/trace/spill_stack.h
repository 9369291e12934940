// The traversal stack: it lives on the call stack while the tree is shallow.
// Builders do not bound depth (degenerate inputs can give a depth near the
// primitive count), so entries past the fixed part spill into a heap block
// (SpillBlock), allocated only by rays that need it.
//
// The block is a separate object that the stack refers to, and only the
// block is handed to the (out-of-line) code that grows it: the stack's own
// address never escapes, so the compiler keeps its size in a register
// instead of reloading and storing it around every push and pop.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <new>
#include <type_traits>

namespace aacbvh {

/// The entries past a SpillStack's fixed part, on the heap.
template <class Entry> class SpillBlock {
    static_assert(std::is_trivially_copyable<Entry>::value, "entries are moved as bytes");

public:
    SpillBlock() = default;
    SpillBlock(const SpillBlock &) = delete;
    SpillBlock &operator=(const SpillBlock &) = delete;
    ~SpillBlock() {
        if (data_ != nullptr) std::free(data_);
    }

    const Entry &operator[](size_t i) const { return data_[i]; }
    /// Stores `e` at index i <= the count stored so far, growing the block
    /// (doubling) when needed; throws std::bad_alloc when it cannot. `e` by
    /// value: a reference would make every push build its entry in memory.
    [[gnu::noinline, gnu::cold]] static void put(SpillBlock &block, size_t i, Entry e) {
        if (i == block.capacity_) {
            const size_t capacity = block.capacity_ == 0 ? 64 : 2 * block.capacity_;
            void *grown = std::realloc(block.data_, capacity * sizeof(Entry));
            if (grown == nullptr) throw std::bad_alloc();
            block.data_ = static_cast<Entry *>(grown);
            block.capacity_ = capacity;
        }
        block.data_[i] = e;
    }

private:
    Entry *data_ = nullptr;
    size_t capacity_ = 0;
};

template <class Entry, size_t kFixed> class SpillStack {
public:
    explicit SpillStack(SpillBlock<Entry> &spill) : spill_(spill) {}
    SpillStack(const SpillStack &) = delete;
    SpillStack &operator=(const SpillStack &) = delete;

    bool empty() const { return size_ == 0; }
    /// Throws std::bad_alloc when the spill block cannot grow.
    void push(const Entry &e) {
        if (size_ < kFixed)
            fixed_[size_] = e;
        else
            SpillBlock<Entry>::put(spill_, size_ - kFixed, e);
        ++size_;
    }
    Entry pop() {
        --size_;
        if (size_ < kFixed) return fixed_[size_];
        return spill_[size_ - kFixed];
    }

private:
    size_t size_ = 0;
    SpillBlock<Entry> &spill_;
    Entry fixed_[kFixed];
};

} // namespace aacbvh
