#include "core/memory.h"

#include <sys/mman.h>

namespace aacbvh {
namespace testing {

std::atomic<int64_t> alloc_fail_countdown{0};
std::atomic<int64_t> system_block_bytes{0};
std::atomic<int64_t> system_block_mapped{0};

bool take_injected_failure() noexcept {
    int64_t left = alloc_fail_countdown.load(std::memory_order_relaxed);
    // Several threads may count down at once: exactly one of them sees 1.
    while (left > 0 && !alloc_fail_countdown.compare_exchange_weak(left, left - 1, std::memory_order_relaxed)) {
    }
    return left == 1;
}

} // namespace testing

namespace {
thread_local const PageMapper *tl_page_mapper = nullptr;
} // namespace

const PageMapper *PageMapper::current() noexcept { return tl_page_mapper; }

PageMapper::Scope::Scope(const PageMapper *mapper) noexcept : previous_(tl_page_mapper) { tl_page_mapper = mapper; }

PageMapper::Scope::~Scope() { tl_page_mapper = previous_; }

void map_pages(void *p, size_t bytes) noexcept {
#ifdef MADV_POPULATE_WRITE
    // Every page of a build array is written soon, so map them all now, in
    // one call, instead of one page fault each: on a virtual machine a fault
    // costs microseconds beyond the page's clearing (docs/PERFORMANCE.md,
    // change 86). Kernels before 5.14 refuse the advice; the pages then fault
    // in as before.
    madvise(p, bytes, MADV_POPULATE_WRITE);
#else
    (void)p;
    (void)bytes;
#endif
}

void *allocate_system_block(size_t rounded_bytes) {
    // Map one alignment unit more, then unmap the unaligned head and the tail.
    const size_t span = rounded_bytes + kHugePageBytes;
    void *mapped = mmap(nullptr, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapped == MAP_FAILED) throw std::bad_alloc();
    const uintptr_t start = reinterpret_cast<uintptr_t>(mapped);
    const uintptr_t aligned = (start + kHugePageBytes - 1) & ~uintptr_t(kHugePageBytes - 1);
    if (aligned > start) munmap(mapped, aligned - start);
    const uintptr_t end = start + span, used_end = aligned + rounded_bytes;
    if (end > used_end) munmap(reinterpret_cast<void *>(used_end), end - used_end);
    void *p = reinterpret_cast<void *>(aligned);
#ifdef MADV_HUGEPAGE
    madvise(p, rounded_bytes, MADV_HUGEPAGE); // advice only: failure is harmless
#endif
    if (const PageMapper *mapper = PageMapper::current())
        mapper->map(static_cast<char *>(p), rounded_bytes);
    else
        map_pages(p, rounded_bytes);
    testing::count_system_block(int64_t(rounded_bytes));
    return p;
}

void free_system_block(void *p, size_t rounded_bytes) noexcept {
    testing::count_system_block(-int64_t(rounded_bytes));
    munmap(p, rounded_bytes);
}

} // namespace aacbvh
