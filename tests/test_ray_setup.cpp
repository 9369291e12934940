// The per-ray set-up the traversals share (lib/trace/ray_primitives.h,
// lib/trace/spill_stack.h):
// - ray_is_plain(), the vector fast path, says "plain" exactly when
//   ray_is_valid() holds and ScaledRay leaves the ray as it is (shift 0), on
//   random rays and on every field set to the values at its edges (NaN,
//   +-inf, +-FLT_MAX, +-0, denormals, 2^+-32 and their neighbours);
//   traced_ray() hands back the caller's ray, the scaled twin, or null
//   accordingly;
// - SpillStack returns what was pushed, last in first out, also past its
//   fixed part (the heap block grows through several doublings), also when
//   pushes into room that has_room() promised (push_within(), the 8-wide
//   traversal's node loop) mix with growing pushes and reserve(); under
//   AddressSanitizer a push past the block's end would fail here.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "trace/ray_primitives.h"
#include "trace/spill_stack.h"

#include "xorshift_rng.h"

namespace {

using namespace aacbvh;

using Rng = XorshiftRng;

/// The definition ray_is_plain() must agree with.
bool plain_by_definition(const aacbvh_ray &ray) { return ray_is_valid(ray) && ScaledRay(ray).shift == 0; }

bool same_bits(const aacbvh_ray &a, const aacbvh_ray &b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void check(const aacbvh_ray &ray, int &plain_count, int &other_count) {
    const bool want = plain_by_definition(ray);
    if (ray_is_plain(ray) != want) {
        std::fprintf(stderr, "ray_is_plain(org %a %a %a, tmin %a, dir %a %a %a, tmax %a) is %d, want %d\n",
                     double(ray.org[0]), double(ray.org[1]), double(ray.org[2]), double(ray.tmin),
                     double(ray.dir[0]), double(ray.dir[1]), double(ray.dir[2]), double(ray.tmax), !want, want);
        fail();
    }
    ScaledRay scaled;
    const aacbvh_ray *traced = traced_ray(ray, scaled);
    if (!ray_is_valid(ray)) {
        assert_null(traced);
    } else if (want) {
        assert_ptr_equal(traced, &ray);
        assert_int_equal(scaled.shift, 0);
    } else {
        const ScaledRay expected(ray);
        assert_ptr_equal(traced, &scaled.ray);
        assert_int_equal(scaled.shift, expected.shift);
        assert_true(same_bits(scaled.ray, expected.ray));
    }
    (want ? plain_count : other_count)++;
}

float from_bits(uint32_t u) {
    float f;
    std::memcpy(&f, &u, sizeof f);
    return f;
}

/// Each field in turn set to each edge value, the others those of an ordinary
/// ray; then the direction's three components drawn from the edge values
/// together (which decides the scale and the zero direction).
void test_edge_values(void **) {
    const float edges[] = {0.0f, -0.0f, NAN, -NAN, INFINITY, -INFINITY, FLT_MAX, -FLT_MAX,
                           std::nextafter(FLT_MAX, 0.0f), FLT_MIN, -FLT_MIN, from_bits(1), from_bits(0x80000001u),
                           0x1p32f, -0x1p32f, std::nextafter(0x1p32f, INFINITY), std::nextafter(0x1p32f, 0.0f),
                           0x1p-32f, -0x1p-32f, std::nextafter(0x1p-32f, 0.0f), std::nextafter(0x1p-32f, 1.0f),
                           1.0f, -1.0f, 0.5f, 3e-20f, 7e25f};
    const aacbvh_ray base = {{0.25f, -1.5f, 3.0f}, 0.0f, {0.3f, -0.4f, 0.5f}, INFINITY};
    int plain = 0, other = 0;
    for (int field = 0; field < 8; ++field)
        for (float e : edges) {
            aacbvh_ray ray = base;
            float *f = field < 3 ? &ray.org[field] : field == 3 ? &ray.tmin : field < 7 ? &ray.dir[field - 4] : &ray.tmax;
            *f = e;
            check(ray, plain, other);
        }
    for (float x : edges)
        for (float y : edges)
            for (float z : edges) {
                aacbvh_ray ray = base;
                ray.dir[0] = x;
                ray.dir[1] = y;
                ray.dir[2] = z;
                check(ray, plain, other);
            }
    // Both answers occur, so neither way of being wrong goes unseen.
    assert_true(plain > 1000);
    assert_true(other > 1000);
}

/// Random bit patterns (every exponent, NaN and inf included) and random
/// ordinary rays.
void test_random_rays(void **) {
    Rng rng{0x9E3779B97F4A7C15ull};
    int plain = 0, other = 0;
    for (int i = 0; i < 200000; ++i) {
        aacbvh_ray ray;
        float *f = &ray.org[0];
        for (int k = 0; k < 8; ++k) {
            const uint64_t r = rng.next();
            // Half the fields ordinary numbers, half any bit pattern.
            f[k] = (r & 1) != 0 ? from_bits(uint32_t(r >> 32))
                                : float(int64_t(r >> 40) - (int64_t(1) << 23)) * 0x1p-20f;
        }
        check(ray, plain, other);
    }
    assert_true(plain > 1000);
    assert_true(other > 1000);
}

struct Item {
    uint32_t a, b;
    float t;
};

/// Pushes and pops in a pattern that crosses the fixed part's end many
/// times and grows the spill block past several doublings; every pop must
/// return the matching push.
void test_spill_stack(void **) {
    SpillBlock<Item> spill;
    SpillStack<Item, 16> stack(spill);
    std::vector<Item> mirror;
    Rng rng{12345};
    for (int step = 0; step < 200000; ++step) {
        const uint64_t r = rng.next();
        // Drift upwards for the first half (deep spills), then down.
        const bool push = mirror.empty() || (step < 100000 ? (r % 8) < 5 : (r % 8) < 3);
        if (push) {
            const Item it{uint32_t(r), uint32_t(r >> 32), float(step)};
            stack.push(it);
            mirror.push_back(it);
        } else {
            assert_false(stack.empty());
            const Item got = stack.pop();
            const Item want = mirror.back();
            mirror.pop_back();
            assert_int_equal(got.a, want.a);
            assert_int_equal(got.b, want.b);
            assert_true(got.t == want.t);
        }
        assert_int_equal(stack.empty(), mirror.empty());
    }
    assert_true(mirror.size() < 200000);
    while (!mirror.empty()) {
        assert_int_equal(stack.pop().a, mirror.back().a);
        mirror.pop_back();
    }
    assert_true(stack.empty());
}

/// The 8-wide traversal's protocol: a node asks has_room(7), reserve()s
/// when there is none, then push_within()s up to seven entries; growing
/// pushes and pops mixed in. has_room() must hold after reserve(), and
/// every pop return the matching push.
void test_spill_stack_room(void **) {
    SpillBlock<Item> spill;
    SpillStack<Item, 16> stack(spill);
    std::vector<Item> mirror;
    Rng rng{777};
    size_t reserves = 0;
    for (int step = 0; step < 100000; ++step) {
        const uint64_t r = rng.next();
        const unsigned kind = unsigned(r % 8);
        if (kind < 3 || mirror.empty()) { // a node's children
            if (!stack.has_room(7)) {
                stack.reserve(7);
                ++reserves;
            }
            assert_true(stack.has_room(7));
            const unsigned n = 1 + unsigned((r >> 8) % 7);
            for (unsigned i = 0; i < n; ++i) {
                const Item it{uint32_t(r >> 16) + i, uint32_t(step), float(i)};
                stack.push_within(it);
                mirror.push_back(it);
            }
        } else if (kind == 3) { // a growing push
            const Item it{uint32_t(r), uint32_t(step), -1.0f};
            stack.push(it);
            mirror.push_back(it);
        } else {
            const unsigned n = step < 50000 ? 2 : 6; // deep first, then back down
            for (unsigned i = 0; i < n && !mirror.empty(); ++i) {
                const Item got = stack.pop();
                assert_int_equal(got.a, mirror.back().a);
                assert_int_equal(got.b, mirror.back().b);
                assert_true(got.t == mirror.back().t);
                mirror.pop_back();
            }
        }
        assert_int_equal(stack.empty(), mirror.empty());
    }
    assert_true(reserves > 3); // the block grew through several doublings
    while (!mirror.empty()) {
        assert_int_equal(stack.pop().a, mirror.back().a);
        mirror.pop_back();
    }
    assert_true(stack.empty());
}

} // namespace

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_edge_values),
        cmocka_unit_test(test_random_rays),
        cmocka_unit_test(test_spill_stack),
        cmocka_unit_test(test_spill_stack_room),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
