// Compile check: the public header is valid C++ (C++11 and C++17, -pedantic
// -Wall -Wextra -Werror; see extra_tests.cmake) and its declarations have C
// linkage. Not a test program; it is only compiled.
#include <aacbvh/aacbvh.h>
#include <aacbvh/aacbvh.h>  // the include guard works

static_assert(sizeof(aacbvh_node) == 32, "aacbvh_node is 32 bytes");
static_assert(sizeof(aacbvh_ray) == 32, "aacbvh_ray is 32 bytes");
static_assert(sizeof(aacbvh_hit) == 16, "aacbvh_hit is 16 bytes");
static_assert(sizeof(aacbvh_status) == 4 && sizeof(aacbvh_param) == 4 &&
                  sizeof(aacbvh_builder) == 4,
              "enums are 32-bit");
static_assert(AACBVH_VERSION_NUMBER ==
                  AACBVH_VERSION_MAJOR * 10000 + AACBVH_VERSION_MINOR * 100 + AACBVH_VERSION_PATCH,
              "version macros agree");

// The functions keep their C types in C++: each is assignable to a pointer
// of the exact signature the header documents.
extern "C" {
typedef aacbvh_status (*create_fn)(uint32_t, aacbvh_context **);
typedef aacbvh_status (*set_triangles_fn)(aacbvh_bvh *, const float *, size_t, size_t,
                                          const uint32_t *, size_t);
typedef aacbvh_status (*intersect_fn)(const aacbvh_bvh *, const aacbvh_ray *, aacbvh_hit *,
                                      size_t);
}
create_fn header_cxx_create = aacbvh_context_create;
set_triangles_fn header_cxx_set_triangles = aacbvh_bvh_set_triangles;
intersect_fn header_cxx_intersect = aacbvh_bvh_intersect;

int header_cxx_usage(const float *xyz, size_t triangle_count);
int header_cxx_usage(const float *xyz, size_t triangle_count) {
    aacbvh_context *ctx = nullptr;
    aacbvh_bvh *bvh = nullptr;
    aacbvh_status status = aacbvh_context_create(1, &ctx);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_create(ctx, &bvh);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_PLOC);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_set_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, 1.5);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_set_triangles(bvh, xyz, 3 * triangle_count, 3 * sizeof(float),
                                          nullptr, triangle_count);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_build(bvh);
    aacbvh_stats stats = {};
    stats.struct_size = sizeof stats;
    if (status == AACBVH_OK)
        status = aacbvh_bvh_get_stats(bvh, &stats);
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    return static_cast<int>(status);
}
