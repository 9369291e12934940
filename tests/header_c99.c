/* Compile check: the public header is valid C99 under
 * -std=c99 -pedantic -Wall -Wextra -Werror (see extra_tests.cmake). Not a
 * cmocka program; it is only compiled. */
#include <aacbvh/aacbvh.h>
#include <aacbvh/aacbvh.h> /* the include guard works */

/* C99 has no _Static_assert: a negative array size fails the compile. */
#define HEADER_CHECK(name, cond) typedef char header_check_##name[(cond) ? 1 : -1]

HEADER_CHECK(node_size, sizeof(aacbvh_node) == 32);
HEADER_CHECK(ray_size, sizeof(aacbvh_ray) == 32);
HEADER_CHECK(hit_size, sizeof(aacbvh_hit) == 16);
HEADER_CHECK(enum_size, sizeof(aacbvh_status) == 4 && sizeof(aacbvh_param) == 4 &&
                        sizeof(aacbvh_builder) == 4);
HEADER_CHECK(version_number, AACBVH_VERSION_NUMBER == AACBVH_VERSION_MAJOR * 10000 +
                             AACBVH_VERSION_MINOR * 100 + AACBVH_VERSION_PATCH);

static bool progress(void *user_data, double fraction_done) {
    (void)user_data;
    return fraction_done <= 1.0;
}

/* Every declaration is usable from C: take each function's address. */
void (*const header_c99_functions[])(void) = {
    (void (*)(void))aacbvh_version_number,
    (void (*)(void))aacbvh_version_string,
    (void (*)(void))aacbvh_status_string,
    (void (*)(void))aacbvh_context_create,
    (void (*)(void))aacbvh_context_thread_count,
    (void (*)(void))aacbvh_context_destroy,
    (void (*)(void))aacbvh_bvh_create,
    (void (*)(void))aacbvh_bvh_destroy,
    (void (*)(void))aacbvh_bvh_last_error,
    (void (*)(void))aacbvh_bvh_set_param_int,
    (void (*)(void))aacbvh_bvh_set_param_float,
    (void (*)(void))aacbvh_bvh_get_param_int,
    (void (*)(void))aacbvh_bvh_get_param_float,
    (void (*)(void))aacbvh_bvh_set_triangles,
    (void (*)(void))aacbvh_bvh_set_boxes,
    (void (*)(void))aacbvh_bvh_set_progress_callback,
    (void (*)(void))aacbvh_bvh_build,
    (void (*)(void))aacbvh_bvh_refit,
    (void (*)(void))aacbvh_bvh_get_stats,
    (void (*)(void))aacbvh_bvh_get_nodes,
    (void (*)(void))aacbvh_bvh_get_primitive_indices,
    (void (*)(void))aacbvh_bvh_intersect,
    (void (*)(void))aacbvh_bvh_occluded,
};

/* Typical C usage type-checks (never run). */
int header_c99_usage(const float *xyz, const uint32_t *indices, size_t vertex_count,
                     size_t triangle_count);
int header_c99_usage(const float *xyz, const uint32_t *indices, size_t vertex_count,
                     size_t triangle_count) {
    aacbvh_context *ctx = NULL;
    aacbvh_bvh *bvh = NULL;
    aacbvh_stats stats = {sizeof(aacbvh_stats), 0, 0, 0, 0, 0.0, 0, 0, 0, 0.0, 0.0, 0};
    aacbvh_ray ray = {{0.0f, 0.0f, 0.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, 1e30f};
    aacbvh_hit hit;
    aacbvh_progress_fn fn = progress;
    int64_t builder = 0;
    aacbvh_status status = aacbvh_context_create(0, &ctx);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_create(ctx, &bvh);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_BUILDER, &builder);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_set_progress_callback(bvh, fn, NULL);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_set_triangles(bvh, xyz, vertex_count, 3 * sizeof(float), indices,
                                          triangle_count);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_build(bvh);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_get_stats(bvh, &stats);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_intersect(bvh, &ray, &hit, 1);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    return status == AACBVH_OK && hit.prim_id != AACBVH_INVALID_ID ? 0 : (int)status;
}
