// The benchmark's own unit tests (test_*.cpp here) count failed checks and
// go on, so that one run reports every failure; no test framework needed.
#pragma once

#include <cstdio>

namespace bench_test {

inline int failures = 0;

/// The exit status of a test program: 0 when every check passed.
inline int finish(const char *program) {
    if (failures) {
        std::fprintf(stderr, "%s: %d check(s) failed\n", program, failures);
        return 1;
    }
    std::printf("%s: all checks passed\n", program);
    return 0;
}

}  // namespace bench_test

#define CHECK(cond)                                                                        \
    do {                                                                                   \
        if (!(cond)) {                                                                     \
            std::fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
            ++bench_test::failures;                                                        \
        }                                                                                  \
    } while (0)
