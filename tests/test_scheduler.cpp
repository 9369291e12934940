// Unit tests of the work-stealing scheduler (lib/core/scheduler.h): fork/join,
// parallel_for, parallel_reduce, concurrent callers, exceptions, lifetimes,
// and the page mapper that clears a build's fresh pages on its threads.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

#include <sys/mman.h>
#include <unistd.h>

#include "core/scheduler.h"

using aacbvh::Scheduler;

namespace {

const unsigned kThreadCounts[] = {1, 2, 3, 8};

uint64_t fib(Scheduler &s, unsigned n) {
    if (n < 2) return n;
    uint64_t x = 0, y = 0;
    s.fork_join([&] { x = fib(s, n - 1); }, [&] { y = fib(s, n - 2); });
    return x + y;
}

uint64_t fib_serial(unsigned n) { return n < 2 ? n : fib_serial(n - 1) + fib_serial(n - 2); }

/// Sum of the leaves' indices of a complete binary tree of the given depth.
uint64_t tree_sum(Scheduler &s, uint64_t first, unsigned depth) {
    if (depth == 0) return first;
    uint64_t x = 0, y = 0;
    uint64_t half = uint64_t(1) << (depth - 1);
    s.fork_join([&] { x = tree_sum(s, first, depth - 1); }, [&] { y = tree_sum(s, first + half, depth - 1); });
    return x + y;
}

struct TestError : std::runtime_error {
    explicit TestError(int v) : std::runtime_error("test"), value(v) {}
    int value;
};

} // namespace

static void test_thread_count(void **) {
    for (unsigned n : kThreadCounts) {
        Scheduler s(n);
        assert_int_equal(s.thread_count(), n);
    }
    Scheduler zero(0);
    assert_int_equal(zero.thread_count(), 1);
}

static void test_nested_fork_join(void **) {
    for (unsigned n : kThreadCounts) {
        Scheduler s(n);
        assert_int_equal(fib(s, 22), fib_serial(22));
        const unsigned depth = 20;
        uint64_t leaves = uint64_t(1) << depth;
        assert_int_equal(tree_sum(s, 0, depth), leaves * (leaves - 1) / 2);
    }
}

static void test_fork_join_runs_each_once(void **) {
    for (unsigned n : kThreadCounts) {
        Scheduler s(n);
        for (int i = 0; i < 20000; ++i) {
            int a = 0, b = 0;
            s.fork_join([&] { ++a; }, [&] { ++b; });
            assert_int_equal(a, 1);
            assert_int_equal(b, 1);
        }
    }
}

static void test_parallel_for_tiny_tasks(void **) {
    const size_t count = 3000000;
    std::vector<uint8_t> hits(count, 0);
    for (unsigned n : kThreadCounts) {
        std::fill(hits.begin(), hits.end(), 0);
        Scheduler s(n);
        std::atomic<int> bad{0};
        auto start = std::chrono::steady_clock::now();
        s.parallel_for(0, count, 1, [&](size_t b, size_t e) {
            if (e != b + 1) bad++;
            hits[b]++;
        });
        double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
        std::printf("# parallel_for grain 1 over %zu items, %u threads: %.1f ms\n", count, n, ms);
        assert_int_equal(bad.load(), 0);
        for (size_t i = 0; i < count; ++i)
            if (hits[i] != 1) fail_msg("index %zu covered %d times with %u threads", i, hits[i], n);
    }
}

static void test_parallel_for_chunks(void **) {
    for (unsigned n : kThreadCounts) {
        Scheduler s(n);
        const size_t begin = 13, end = 100013, grain = 7;
        std::vector<std::atomic<int>> hits(end);
        std::atomic<size_t> calls{0};
        std::atomic<int> bad{0};
        s.parallel_for(begin, end, grain, [&](size_t b, size_t e) {
            calls.fetch_add(1, std::memory_order_relaxed);
            if (b >= e || e - b > grain || (b - begin) % grain != 0) bad++;
            for (size_t i = b; i < e; ++i) hits[i].fetch_add(1, std::memory_order_relaxed);
        });
        assert_int_equal(bad.load(), 0);
        assert_int_equal(calls.load(), (end - begin + grain - 1) / grain);
        for (size_t i = 0; i < end; ++i) assert_int_equal(hits[i].load(), i >= begin ? 1 : 0);
        // An empty range; grain 0 is taken as 1.
        std::atomic<size_t> seen{0};
        s.parallel_for(5, 5, 1, [&](size_t, size_t) { ++seen; });
        assert_int_equal(seen.load(), 0);
        s.parallel_for(5, 8, 0, [&](size_t, size_t) { ++seen; });
        assert_int_equal(seen.load(), 3);
    }
}

static void test_parallel_reduce(void **) {
    const size_t count = 1 << 20;
    std::vector<double> values(count);
    for (size_t i = 0; i < count; ++i) values[i] = std::sin(double(i)) * 1e3 + 1.0 / double(i + 1);
    uint64_t serial_int = 0;
    for (size_t i = 0; i < count; ++i) serial_int += i * i % 1000003;

    double first_double = 0;
    for (unsigned n : kThreadCounts) {
        Scheduler s(n);
        uint64_t sum = s.parallel_reduce(
            0, count, 1000, uint64_t(0),
            [&](size_t b, size_t e) {
                uint64_t acc = 0;
                for (size_t i = b; i < e; ++i) acc += i * i % 1000003;
                return acc;
            },
            [](uint64_t x, uint64_t y) { return x + y; });
        assert_int_equal(sum, serial_int);

        double d = s.parallel_reduce(
            0, count, 333, 0.0,
            [&](size_t b, size_t e) {
                double acc = 0;
                for (size_t i = b; i < e; ++i) acc += values[i];
                return acc;
            },
            [](double x, double y) { return x + y; });
        // The split tree does not depend on the thread count: bitwise equal.
        if (n == kThreadCounts[0]) first_double = d;
        assert_memory_equal(&d, &first_double, sizeof d);

        assert_int_equal(s.parallel_reduce(
                             7, 7, 1, 42, [](size_t, size_t) { return 0; }, [](int x, int y) { return x + y; }),
                         42);
    }
}

static void test_concurrent_callers(void **) {
    for (unsigned n : kThreadCounts) {
        Scheduler s(n);
        std::atomic<int> failures{0};
        std::vector<std::thread> callers;
        for (int c = 0; c < 4; ++c)
            callers.emplace_back([&, c] {
                for (int round = 0; round < 5; ++round) {
                    if (fib(s, 18 + c % 2) != fib_serial(18 + c % 2)) failures++;
                    std::vector<int> hits(50000, 0);
                    s.parallel_for(0, hits.size(), 3, [&](size_t b, size_t e) {
                        for (size_t i = b; i < e; ++i) hits[i]++;
                    });
                    for (int h : hits)
                        if (h != 1) failures++;
                    uint64_t sum = s.parallel_reduce(
                        0, 100000, 64, uint64_t(0),
                        [](size_t b, size_t e) {
                            uint64_t acc = 0;
                            for (size_t i = b; i < e; ++i) acc += i;
                            return acc;
                        },
                        [](uint64_t x, uint64_t y) { return x + y; });
                    if (sum != uint64_t(100000) * 99999 / 2) failures++;
                    try {
                        s.parallel_for(0, 1000, 1, [&](size_t b, size_t) {
                            if (b == 500 + size_t(c)) throw TestError(c);
                        });
                        failures++;
                    } catch (const TestError &e) {
                        if (e.value != c) failures++;
                    }
                }
            });
        for (std::thread &t : callers) t.join();
        assert_int_equal(failures.load(), 0);
    }
}

static void test_create_destroy(void **) {
    for (int i = 0; i < 200; ++i) {
        unsigned n = 1 + unsigned(i) % 8;
        Scheduler s(n);
        if (i % 3 == 0) continue; // destroy without ever forking
        assert_int_equal(fib(s, 10), 55);
    }
}

static void test_exceptions(void **) {
    for (unsigned n : kThreadCounts) {
        Scheduler s(n);
        // From a, from b, from both (a's wins).
        try {
            s.fork_join([] { throw TestError(1); }, [] {});
            fail_msg("no exception from a");
        } catch (const TestError &e) {
            assert_int_equal(e.value, 1);
        }
        try {
            int ran_a = 0;
            s.fork_join([&] { ran_a = 1; }, [] { throw TestError(2); });
            fail_msg("no exception from b");
        } catch (const TestError &e) {
            assert_int_equal(e.value, 2);
        }
        try {
            s.fork_join([] { throw TestError(3); }, [] { throw TestError(4); });
            fail_msg("no exception from a and b");
        } catch (const TestError &e) {
            assert_true(e.value == 3 || e.value == 4);
        }
        // Deep inside a recursion, on whatever thread runs it.
        std::function<void(unsigned, uint64_t)> rec = [&](unsigned depth, uint64_t id) {
            if (depth == 0) {
                if (id == 4096 + 777) throw TestError(int(id));
                return;
            }
            s.fork_join([&] { rec(depth - 1, 2 * id); }, [&] { rec(depth - 1, 2 * id + 1); });
        };
        try {
            rec(12, 1);
            fail_msg("no exception from the recursion");
        } catch (const TestError &e) {
            assert_int_equal(e.value, 4096 + 777);
        }
        // From a parallel_for chunk; other exception types pass through too.
        try {
            s.parallel_for(0, 100000, 10, [](size_t b, size_t) {
                if (b == 54320) throw std::out_of_range("chunk");
            });
            fail_msg("no exception from parallel_for");
        } catch (const std::out_of_range &) {
        }
        // Still usable afterwards.
        assert_int_equal(fib(s, 20), fib_serial(20));
    }
}

static void test_nested_schedulers(void **) {
    // A task of one Scheduler forking on another: the worker borrows a slot.
    Scheduler outer(3), inner(2);
    std::atomic<uint64_t> total{0};
    outer.parallel_for(0, 16, 1, [&](size_t, size_t) { total += fib(inner, 15); });
    assert_int_equal(total.load(), 16 * fib_serial(15));
}

static void test_idle_then_work(void **) {
    // Workers fall asleep between bursts and must wake up for the next one.
    Scheduler s(4);
    for (int i = 0; i < 20; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        assert_int_equal(fib(s, 16), fib_serial(16));
    }
}

namespace {

/// A fresh mapping of `bytes` on a 2 MiB boundary, none of its pages touched;
/// unmapped with its span.
struct FreshRegion {
    char *p = nullptr;
    void *mapped = nullptr;
    size_t span = 0;
    explicit FreshRegion(size_t bytes) : span(bytes + aacbvh::kHugePageBytes) {
        mapped = mmap(nullptr, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        assert_true(mapped != MAP_FAILED);
        const uintptr_t a = (uintptr_t(mapped) + aacbvh::kHugePageBytes - 1) & ~uintptr_t(aacbvh::kHugePageBytes - 1);
        p = reinterpret_cast<char *>(a);
    }
    ~FreshRegion() { munmap(mapped, span); }
    /// Pages of [p, p + bytes) in memory.
    size_t resident(size_t bytes) const {
        const size_t page = size_t(sysconf(_SC_PAGESIZE));
        std::vector<unsigned char> in((bytes + page - 1) / page);
        assert_int_equal(mincore(p, bytes, in.data()), 0);
        return size_t(std::count_if(in.begin(), in.end(), [](unsigned char c) { return (c & 1) != 0; }));
    }
};

} // namespace

static void test_parallel_page_mapper(void **) {
    // The parallel mapper leaves every page of a block as mapped as one
    // map_pages() call does (all of them where the kernel has
    // MADV_POPULATE_WRITE): its pieces cover the block, the odd tail included.
    // Under ParallelPageMapper::kParallelFrom (the allocating thread maps
    // them), at it, and above it with a piece's tail.
    const size_t sizes[] = {aacbvh::kHugePageBytes, 2 * aacbvh::kHugePageBytes + 4096, 9 * aacbvh::kHugePageBytes,
                            aacbvh::ParallelPageMapper::kParallelFrom, 23 * aacbvh::kHugePageBytes + 12288,
                            37 * aacbvh::kHugePageBytes + 4096};
    static_assert(aacbvh::ParallelPageMapper::kParallelFrom <= 23 * aacbvh::kHugePageBytes,
                  "the last sizes must be mapped in pieces");
    for (unsigned threads : kThreadCounts) {
        Scheduler s(threads);
        const aacbvh::ParallelPageMapper mapper(s);
        for (size_t bytes : sizes) {
            FreshRegion one(bytes), shared(bytes);
            aacbvh::map_pages(one.p, bytes);
            mapper.map(shared.p, bytes);
            const size_t expected = one.resident(bytes);
            assert_int_equal(shared.resident(bytes), expected);
            // Fresh pages read as zero whoever mapped them.
            for (size_t i = 0; i < bytes; i += 4096) assert_int_equal(shared.p[i], 0);
            assert_int_equal(shared.p[bytes - 1], 0);
        }
    }
}

static void test_page_mapper_scope(void **) {
    // A big block allocated with a mapper installed is mapped by it, once,
    // whole; without one (and after the scope) by the allocating thread.
    struct Counting final : aacbvh::PageMapper {
        mutable std::vector<std::pair<char *, size_t>> calls;
        void map(char *p, size_t bytes) const noexcept override {
            calls.emplace_back(p, bytes);
            aacbvh::map_pages(p, bytes);
        }
    } counting;
    assert_null(aacbvh::PageMapper::current());
    const size_t bytes = 3 * aacbvh::kHugePageBytes;
    {
        const aacbvh::PageMapper::Scope scope(&counting);
        assert_ptr_equal(aacbvh::PageMapper::current(), &counting);
        void *block = aacbvh::allocate_system_block(bytes);
        assert_int_equal(counting.calls.size(), 1);
        assert_ptr_equal(counting.calls[0].first, block);
        assert_int_equal(counting.calls[0].second, bytes);
        aacbvh::free_system_block(block, bytes);
        // Another thread has no mapper of its own.
        std::thread([] { assert_null(aacbvh::PageMapper::current()); }).join();
    }
    assert_null(aacbvh::PageMapper::current());
    void *block = aacbvh::allocate_system_block(bytes);
    assert_int_equal(counting.calls.size(), 1);
    aacbvh::free_system_block(block, bytes);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_thread_count),
        cmocka_unit_test(test_nested_fork_join),
        cmocka_unit_test(test_fork_join_runs_each_once),
        cmocka_unit_test(test_parallel_for_tiny_tasks),
        cmocka_unit_test(test_parallel_for_chunks),
        cmocka_unit_test(test_parallel_reduce),
        cmocka_unit_test(test_concurrent_callers),
        cmocka_unit_test(test_create_destroy),
        cmocka_unit_test(test_exceptions),
        cmocka_unit_test(test_nested_schedulers),
        cmocka_unit_test(test_idle_then_work),
        cmocka_unit_test(test_parallel_page_mapper),
        cmocka_unit_test(test_page_mapper_scope),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
