#include "build/build_context.h"

namespace aacbvh {
namespace testing {

std::atomic<int> poll_interval_ms{5};
std::atomic<uint64_t> distance_evaluations{0};
std::atomic<bool> counting_distances{false};

} // namespace testing
} // namespace aacbvh
