/* Version macros against the run-time queries and CMake; status names. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "test_support.h"

static void test_version_macros_match_runtime(void **state) {
    char expected[64];
    unsigned major = 0, minor = 0, patch = 0;
    (void)state;
    assert_int_equal(AACBVH_VERSION_NUMBER,
                     AACBVH_VERSION_MAJOR * 10000 + AACBVH_VERSION_MINOR * 100 + AACBVH_VERSION_PATCH);
    assert_int_equal(aacbvh_version_number(), AACBVH_VERSION_NUMBER);
    assert_non_null(aacbvh_version_string());
    assert_string_equal(aacbvh_version_string(), AACBVH_VERSION_STRING);
    snprintf(expected, sizeof expected, "%d.%d.%d", AACBVH_VERSION_MAJOR, AACBVH_VERSION_MINOR,
             AACBVH_VERSION_PATCH);
    assert_string_equal(AACBVH_VERSION_STRING, expected);
    assert_int_equal(sscanf(aacbvh_version_string(), "%u.%u.%u", &major, &minor, &patch), 3);
    assert_int_equal(major * 10000 + minor * 100 + patch, aacbvh_version_number());
    /* Static storage: the same pointer every time. */
    assert_ptr_equal(aacbvh_version_string(), aacbvh_version_string());
}

/* CMake's project version (the library's VERSION and SOVERSION) is read from
 * the header's macros: the two must agree. 1.x: the SONAME libaacbvh.so.1
 * stays for every minor version (docs/ABI.md). */
static void test_version_matches_cmake(void **state) {
    (void)state;
    assert_string_equal(AACBVH_PROJECT_VERSION, AACBVH_VERSION_STRING);
    assert_string_equal(AACBVH_PROJECT_VERSION, aacbvh_version_string());
    assert_int_equal(AACBVH_VERSION_MAJOR, 1);
    /* 1.1 is the first version with AACBVH_PARAM_TRIANGLE_STORAGE and
     * AACBVH_PARAM_KEEP_BUILD_MEMORY, 1.2 the first with AACBVH_LAYOUT_WIDE8,
     * AACBVH_PARAM_OPTIMIZE_PASSES and aacbvh_bvh_optimize (CHANGELOG.md). */
    assert_true(AACBVH_VERSION_NUMBER >= 10200);
    assert_int_equal(AACBVH_LAYOUT_WIDE8, 2);
    assert_int_equal(AACBVH_PARAM_OPTIMIZE_PASSES, 12);
}

static void test_status_strings(void **state) {
    const aacbvh_status codes[] = {
        AACBVH_OK, AACBVH_ERROR_INVALID_ARGUMENT, AACBVH_ERROR_INVALID_OPERATION,
        AACBVH_ERROR_OUT_OF_MEMORY, AACBVH_ERROR_INVALID_GEOMETRY, AACBVH_ERROR_CANCELLED,
        AACBVH_ERROR_INTERNAL,
    };
    const size_t n = sizeof codes / sizeof codes[0];
    const aacbvh_status unknown[] = {(aacbvh_status)7, (aacbvh_status)-1, (aacbvh_status)1000,
                                     AACBVH_STATUS_MAX_ENUM};
    size_t i, j;
    (void)state;
    for (i = 0; i < n; ++i) {
        const char *s = aacbvh_status_string(codes[i]);
        assert_non_null(s);
        assert_true(strlen(s) > 0);
        for (j = 0; j < i; ++j) assert_string_not_equal(s, aacbvh_status_string(codes[j]));
    }
    assert_string_equal(aacbvh_status_string(AACBVH_OK), "AACBVH_OK");
    for (i = 0; i < sizeof unknown / sizeof unknown[0]; ++i) {
        const char *s = aacbvh_status_string(unknown[i]);
        assert_non_null(s);
        assert_true(strlen(s) > 0);
        for (j = 0; j < n; ++j) assert_string_not_equal(s, aacbvh_status_string(codes[j]));
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_version_macros_match_runtime),
        cmocka_unit_test(test_version_matches_cmake),
        cmocka_unit_test(test_status_strings),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
