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

/* Field types: fixed widths, as the header documents. */
static void test_field_widths(void **state) {
    aacbvh_stats s;
    aacbvh_node n;
    aacbvh_ray r;
    aacbvh_hit h;
    (void)state;
    assert_int_equal(sizeof s.struct_size, 4);
    assert_int_equal(sizeof s.max_depth, 4);
    assert_int_equal(sizeof s.node_count, 8);
    assert_int_equal(sizeof s.sah_cost, 8);
    assert_int_equal(sizeof s.build_seconds, 8);
    assert_int_equal(sizeof n.lower, 12);
    assert_int_equal(sizeof n.first, 4);
    assert_int_equal(sizeof r.org, 12);
    assert_int_equal(sizeof r.tmax, 4);
    assert_int_equal(sizeof h.prim_id, 4);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layout_at_run_time),
        cmocka_unit_test(test_field_widths),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
