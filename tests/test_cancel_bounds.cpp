// A cancel is noticed after a bounded amount of work, for the settings that
// once ran for seconds (or minutes) without calling the progress callback:
// AAC with delta 2^20 (one combine of every primitive, O(n^2) in its first
// nearest-neighbour scan), AAC with c = 1 and alpha = 1 (nothing merges below
// the root), PLOC with radius 1024, and locally-ordered clustering.
//
// Work is counted, not timed: the library counts the distances its
// clustering builders evaluate (aacbvh::testing::distance_evaluations, added
// up where the rows and windows are computed, once the test turns counting
// on), and with the poll interval set to 0 every poll calls the callback. The
// callback records the count at each call; the most distances evaluated
// between two calls must stay under a fixed bound, and the build must return
// AACBVH_ERROR_CANCELLED soon after the callback asks for it. Linked
// statically with the library (aacbvh_core and capi.cpp) to reach the testing
// counters.
#include <aacbvh/aacbvh.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>

// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include "build/build_context.h"

namespace {

using aacbvh::testing::distance_evaluations;

/// Most distances evaluated between two progress calls: 2^20 per poll plus
/// one row or window of the largest case (2^17 clusters) on either side.
constexpr uint64_t kBound = (uint64_t(1) << 20) + 4 * (uint64_t(1) << 17);

struct Watch {
    int calls = 0;
    int busy_calls = 0; ///< calls since distances began to be evaluated
    int cancel_at = 0;  ///< cancels at this many busy calls
    uint64_t start = 0; ///< the counter when the build began
    uint64_t last = 0;
    uint64_t largest_gap = 0;
    uint64_t after_cancel = 0; ///< distances evaluated after the cancel was asked
};

bool watch_callback(void *user, double) {
    Watch &w = *static_cast<Watch *>(user);
    const uint64_t now = distance_evaluations.load();
    if (w.calls > 0 && now - w.last > w.largest_gap) w.largest_gap = now - w.last;
    w.last = now;
    ++w.calls;
    if (now > w.start) ++w.busy_calls;
    return w.busy_calls < w.cancel_at;
}

std::vector<float> random_triangles(size_t n, uint64_t seed) {
    std::vector<float> v;
    v.reserve(9 * n);
    uint64_t x = seed;
    auto next = [&x] {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        return float(x >> 40) / float(1 << 24);
    };
    for (size_t t = 0; t < n; ++t) {
        const float c[3] = {next(), next(), next()};
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) v.push_back(c[k] + 0.01f * next());
    }
    return v;
}

/// Builds `n` random triangles on one thread with `setup` applied, cancelling
/// at the 5th progress call after the clustering began (the phases before
/// evaluate no distances); checks the gaps and the prompt return.
template <class Setup> void check_cancel(const char *what, size_t n, Setup &&setup) {
    const std::vector<float> v = random_triangles(n, 0x5eed + n);
    aacbvh_context *ctx = nullptr;
    aacbvh_bvh *bvh = nullptr;
    assert_int_equal(aacbvh_context_create(1, &ctx), AACBVH_OK);
    assert_int_equal(aacbvh_bvh_create(ctx, &bvh), AACBVH_OK);
    setup(bvh);
    assert_int_equal(aacbvh_bvh_set_triangles(bvh, v.data(), 3 * n, 12, nullptr, n), AACBVH_OK);
    Watch w;
    w.cancel_at = 5;
    w.start = w.last = distance_evaluations.load();
    assert_int_equal(aacbvh_bvh_set_progress_callback(bvh, watch_callback, &w), AACBVH_OK);
    const aacbvh_status s = aacbvh_bvh_build(bvh);
    const uint64_t after = distance_evaluations.load() - w.last;
    std::printf("%-34s %d calls, at most %llu distances between two, %llu after the cancel\n", what, w.calls,
                (unsigned long long)w.largest_gap, (unsigned long long)after);
    if (s != AACBVH_ERROR_CANCELLED) fail_msg("%s: build returned %s, not cancelled", what, aacbvh_status_string(s));
    if (w.busy_calls != w.cancel_at) fail_msg("%s: the callback was called %d times", what, w.calls);
    if (w.largest_gap > kBound)
        fail_msg("%s: %llu distances between two progress calls (bound %llu)", what,
                 (unsigned long long)w.largest_gap, (unsigned long long)kBound);
    if (after > kBound)
        fail_msg("%s: %llu distances evaluated after the cancel", what, (unsigned long long)after);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
}

int set_up(void **) {
    aacbvh::testing::poll_interval_ms.store(0);
    aacbvh::testing::counting_distances.store(true);
    return 0;
}

void test_aac_one_huge_combine(void **) {
    check_cancel("AAC delta 2^20, 120 K triangles", 120000, [](aacbvh_bvh *bvh) {
        assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_AAC_DELTA, 1 << 20), AACBVH_OK);
    });
}

void test_aac_no_merges_below_the_root(void **) {
    check_cancel("AAC c = 1, alpha = 1, 120 K triangles", 120000, [](aacbvh_bvh *bvh) {
        assert_int_equal(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_C, 1.0), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_AAC_ALPHA, 1.0), AACBVH_OK);
    });
}

void test_ploc_widest_radius(void **) {
    check_cancel("PLOC radius 1024, 120 K triangles", 120000, [](aacbvh_bvh *bvh) {
        assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_PLOC), AACBVH_OK);
        assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_PLOC_RADIUS, 1024), AACBVH_OK);
    });
}

void test_locally_ordered(void **) {
    check_cancel("locally-ordered, 120 K triangles", 120000, [](aacbvh_bvh *bvh) {
        assert_int_equal(aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_LOCALLY_ORDERED),
                         AACBVH_OK);
    });
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_aac_one_huge_combine),
        cmocka_unit_test(test_aac_no_merges_below_the_root),
        cmocka_unit_test(test_ploc_widest_radius),
        cmocka_unit_test(test_locally_ordered),
    };
    return cmocka_run_group_tests(tests, set_up, nullptr);
}
