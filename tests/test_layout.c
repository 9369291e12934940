/* Frozen ABI: struct sizes and offsets, enum values and enum sizes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "test_support.h"

#define CHECK_LAYOUT(X)                                              \
    X(sizeof(aacbvh_node) == 32)                                     \
    X(offsetof(aacbvh_node, lower) == 0)                             \
    X(offsetof(aacbvh_node, upper) == 12)                            \
    X(offsetof(aacbvh_node, first) == 24)                            \
    X(offsetof(aacbvh_node, count) == 28)                            \
    X(sizeof(aacbvh_ray) == 32)                                      \
    X(offsetof(aacbvh_ray, org) == 0)                                \
    X(offsetof(aacbvh_ray, tmin) == 12)                              \
    X(offsetof(aacbvh_ray, dir) == 16)                               \
    X(offsetof(aacbvh_ray, tmax) == 28)                              \
    X(sizeof(aacbvh_hit) == 16)                                      \
    X(offsetof(aacbvh_hit, t) == 0)                                  \
    X(offsetof(aacbvh_hit, u) == 4)                                  \
    X(offsetof(aacbvh_hit, v) == 8)                                  \
    X(offsetof(aacbvh_hit, prim_id) == 12)                           \
    X(sizeof(aacbvh_stats) == 88)                                    \
    X(offsetof(aacbvh_stats, struct_size) == 0)                      \
    X(offsetof(aacbvh_stats, max_depth) == 4)                        \
    X(offsetof(aacbvh_stats, node_count) == 8)                       \
    X(offsetof(aacbvh_stats, leaf_count) == 16)                      \
    X(offsetof(aacbvh_stats, primitive_count) == 24)                 \
    X(offsetof(aacbvh_stats, sah_cost) == 32)                        \
    X(offsetof(aacbvh_stats, memory_bytes) == 40)                    \
    X(offsetof(aacbvh_stats, invalid_primitive_count) == 48)         \
    X(offsetof(aacbvh_stats, build_peak_bytes) == 56)                \
    X(offsetof(aacbvh_stats, built_sah_cost) == 64)                  \
    X(offsetof(aacbvh_stats, build_seconds) == 72)                   \
    X(offsetof(aacbvh_stats, kept_build_bytes) == 80)                \
    X(sizeof(aacbvh_status) == 4)                                    \
    X(sizeof(aacbvh_builder) == 4)                                   \
    X(sizeof(aacbvh_param) == 4)                                     \
    X(AACBVH_OK == 0)                                                \
    X(AACBVH_ERROR_INVALID_ARGUMENT == 1)                            \
    X(AACBVH_ERROR_INVALID_OPERATION == 2)                           \
    X(AACBVH_ERROR_OUT_OF_MEMORY == 3)                               \
    X(AACBVH_ERROR_INVALID_GEOMETRY == 4)                            \
    X(AACBVH_ERROR_CANCELLED == 5)                                   \
    X(AACBVH_ERROR_INTERNAL == 6)                                    \
    X(AACBVH_STATUS_MAX_ENUM == 0x7FFFFFFF)                          \
    X(AACBVH_BUILDER_AAC_HQ == 0)                                    \
    X(AACBVH_BUILDER_AAC_FAST == 1)                                  \
    X(AACBVH_BUILDER_AAC == 2)                                       \
    X(AACBVH_BUILDER_SWEEP_SAH == 3)                                 \
    X(AACBVH_BUILDER_BINNED_SAH == 4)                                \
    X(AACBVH_BUILDER_LOCALLY_ORDERED == 5)                           \
    X(AACBVH_BUILDER_PLOC == 6)                                      \
    X(AACBVH_BUILDER_MAX_ENUM == 0x7FFFFFFF)                         \
    X(AACBVH_PARAM_BUILDER == 0)                                     \
    X(AACBVH_PARAM_AAC_DELTA == 1)                                   \
    X(AACBVH_PARAM_MAX_LEAF_SIZE == 2)                               \
    X(AACBVH_PARAM_AAC_C == 3)                                       \
    X(AACBVH_PARAM_AAC_ALPHA == 4)                                   \
    X(AACBVH_PARAM_TRAVERSAL_COST == 5)                              \
    X(AACBVH_PARAM_INTERSECTION_COST == 6)                           \
    X(AACBVH_PARAM_PLOC_RADIUS == 7)                                 \
    X(AACBVH_PARAM_SKIP_INVALID_PRIMITIVES == 8)                     \
    X(AACBVH_PARAM_TRAVERSAL_LAYOUT == 9)                            \
    X(AACBVH_LAYOUT_BINARY == 0)                                     \
    X(AACBVH_LAYOUT_WIDE4 == 1)                                      \
    X(AACBVH_LAYOUT_WIDE8 == 2)                                      \
    X(sizeof(aacbvh_layout) == 4)                                    \
    X(AACBVH_PARAM_TRIANGLE_STORAGE == 10)                           \
    X(AACBVH_TRIANGLES_REFERENCED == 0)                              \
    X(AACBVH_TRIANGLES_COPIED == 1)                                  \
    X(AACBVH_TRIANGLE_STORAGE_MAX_ENUM == 0x7FFFFFFF)                \
    X(sizeof(aacbvh_triangle_storage) == 4)                          \
    X(AACBVH_PARAM_KEEP_BUILD_MEMORY == 11)                          \
    X(AACBVH_PARAM_MAX_ENUM == 0x7FFFFFFF)                           \
    X(AACBVH_INVALID_ID == 0xFFFFFFFFu)

/* Compile time: a layout change does not even build. */
#define STATIC_CHECK(cond) _Static_assert(cond, #cond);
CHECK_LAYOUT(STATIC_CHECK)

/* Run time: the same checks, so that cmocka has something to report. */
#define RUNTIME_CHECK(cond) assert_true(cond);
static void test_layout_at_run_time(void **state) {
    (void)state;
    CHECK_LAYOUT(RUNTIME_CHECK)
}

/* Field types, as the header documents: each field's width and kind.
 * Offsets alone would miss a field that changes type in place (uint64_t to
 * uint32_t before an 8-aligned field), which abidiff's suppression for the
 * growth of aacbvh_stats does not report either (docs/ABI.md). */

/* An unsigned integer of `bytes`: 0 - 1 wraps to a positive value, 1 / 2 is 0. */
#define EXPECT_UNSIGNED(obj, field, bytes)               \
    do {                                                 \
        assert_int_equal(sizeof(obj).field, bytes);      \
        (obj).field = 0;                                 \
        (obj).field -= 1;                                \
        assert_true((obj).field > 0);                    \
        (obj).field = 1;                                 \
        (obj).field /= 2;                                \
        assert_true((obj).field == 0);                   \
    } while (0)

/* A floating-point number of `bytes`: keeps a half and a sign. */
#define EXPECT_FLOATING(obj, field, bytes)               \
    do {                                                 \
        assert_int_equal(sizeof(obj).field, bytes);      \
        (obj).field = 1;                                 \
        (obj).field /= 2;                                \
        assert_true((obj).field == 0.5);                 \
        (obj).field = -1;                                \
        assert_true((obj).field < 0);                    \
    } while (0)

static void test_field_types(void **state) {
    aacbvh_stats s;
    aacbvh_node n;
    aacbvh_ray r;
    aacbvh_hit h;
    (void)state;
    EXPECT_UNSIGNED(s, struct_size, 4);
    EXPECT_UNSIGNED(s, max_depth, 4);
    EXPECT_UNSIGNED(s, node_count, 8);
    EXPECT_UNSIGNED(s, leaf_count, 8);
    EXPECT_UNSIGNED(s, primitive_count, 8);
    EXPECT_FLOATING(s, sah_cost, 8);
    EXPECT_UNSIGNED(s, memory_bytes, 8);
    EXPECT_UNSIGNED(s, invalid_primitive_count, 8);
    EXPECT_UNSIGNED(s, build_peak_bytes, 8);
    EXPECT_FLOATING(s, built_sah_cost, 8);
    EXPECT_FLOATING(s, build_seconds, 8);

    assert_int_equal(sizeof n.lower, 12);
    assert_int_equal(sizeof n.upper, 12);
    EXPECT_FLOATING(n, lower[0], 4);
    EXPECT_FLOATING(n, upper[0], 4);
    EXPECT_UNSIGNED(n, first, 4);
    EXPECT_UNSIGNED(n, count, 4);

    assert_int_equal(sizeof r.org, 12);
    assert_int_equal(sizeof r.dir, 12);
    EXPECT_FLOATING(r, org[0], 4);
    EXPECT_FLOATING(r, tmin, 4);
    EXPECT_FLOATING(r, dir[0], 4);
    EXPECT_FLOATING(r, tmax, 4);

    EXPECT_FLOATING(h, t, 4);
    EXPECT_FLOATING(h, u, 4);
    EXPECT_FLOATING(h, v, 4);
    EXPECT_UNSIGNED(h, prim_id, 4);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layout_at_run_time),
        cmocka_unit_test(test_field_types),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
