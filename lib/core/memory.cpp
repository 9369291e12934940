#include "core/memory.h"

namespace aacbvh {
namespace testing {

std::atomic<int64_t> alloc_fail_countdown{0};
std::atomic<int64_t> system_block_bytes{0};

bool take_injected_failure() noexcept {
    int64_t left = alloc_fail_countdown.load(std::memory_order_relaxed);
    // Several threads may count down at once: exactly one of them sees 1.
    while (left > 0 && !alloc_fail_countdown.compare_exchange_weak(left, left - 1, std::memory_order_relaxed)) {
    }
    return left == 1;
}

} // namespace testing
} // namespace aacbvh
