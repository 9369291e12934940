// The traversal stack: it lives on the call stack while the tree is shallow.
// Builders do not bound depth (degenerate inputs can give a depth near the
// primitive count), so entries past the fixed part spill into a heap block
// (SpillBlock), allocated only by rays that need it.
//
// The block is a separate object that the stack refers to, and only the
// block is handed to the (out-of-line) code that grows it: the stack's own
// address never escapes, so the compiler keeps its size in a register
// instead of reloading and storing it around every push and pop.
//
// A loop that must contain no call (a call clobbers every vector register,
// so the compiler would keep the ray's rows in memory for the whole loop)
// asks has_room() and pushes with push_within(); when there is no room it
// leaves the loop, reserve()s outside it, and comes back.
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
    Entry &operator[](size_t i) { return data_[i]; }
    size_t capacity() const { return capacity_; }
    /// Makes room for at least `count` entries (doubling); throws
    /// std::bad_alloc when it cannot.
    [[gnu::noinline, gnu::cold]] static void grow(SpillBlock &block, size_t count) {
        size_t capacity = block.capacity_ == 0 ? 64 : 2 * block.capacity_;
        while (capacity < count) capacity *= 2;
        void *grown = std::realloc(block.data_, capacity * sizeof(Entry));
        if (grown == nullptr) throw std::bad_alloc();
        block.data_ = static_cast<Entry *>(grown);
        block.capacity_ = capacity;
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
        if (size_ >= kFixed) reserve(1);
        push_within(e);
    }
    /// Whether `count` more entries fit without growing: push_within() may
    /// then take them.
    bool has_room(size_t count) const { return room_ - size_ >= count; }
    /// Pushes into room that has_room() promised: never a call.
    void push_within(const Entry &e) {
        if (size_ < kFixed)
            fixed_[size_] = e;
        else
            spill_[size_ - kFixed] = e;
        ++size_;
    }
    /// Grows the room so that `count` more entries fit (out of line, on the
    /// block only); throws std::bad_alloc when it cannot.
    void reserve(size_t count) {
        if (has_room(count)) return;
        SpillBlock<Entry>::grow(spill_, size_ + count - kFixed);
        room_ = kFixed + spill_.capacity();
    }
    Entry pop() {
        --size_;
        if (size_ < kFixed) return fixed_[size_];
        return spill_[size_ - kFixed];
    }

private:
    size_t size_ = 0;
    size_t room_ = kFixed; ///< entries that fit before the block must grow
    SpillBlock<Entry> &spill_;
    Entry fixed_[kFixed];
};

} // namespace aacbvh
