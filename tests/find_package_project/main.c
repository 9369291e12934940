/* Built against an installed libaacbvh through find_package(aacbvh): checks
 * that header and library agree on the version, then intersects one ray. */
#include <aacbvh/aacbvh.h>

#include <math.h>
#include <stdio.h>

int main(void) {
    static const float triangle[] = {-1.0f, -1.0f, 2.0f, 1.0f, -1.0f, 2.0f, 0.0f, 1.0f, 2.0f};
    aacbvh_ray ray = {{0.0f, 0.0f, 0.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, INFINITY};
    aacbvh_hit hit = {0.0f, 0.0f, 0.0f, AACBVH_INVALID_ID};
    aacbvh_context *ctx = NULL;
    aacbvh_bvh *bvh = NULL;
    aacbvh_status status;

    if (aacbvh_version_number() != AACBVH_VERSION_NUMBER) {
        fprintf(stderr, "header %s, library %s\n", AACBVH_VERSION_STRING, aacbvh_version_string());
        return 1;
    }
    status = aacbvh_context_create(1, &ctx);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_create(ctx, &bvh);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_set_triangles(bvh, triangle, 3, 3 * sizeof(float), NULL, 1);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_build(bvh);
    if (status == AACBVH_OK)
        status = aacbvh_bvh_intersect(bvh, &ray, &hit, 1);
    if (status != AACBVH_OK)
        fprintf(stderr, "%s: %s\n", aacbvh_status_string(status), aacbvh_bvh_last_error(bvh));
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    if (status != AACBVH_OK || hit.prim_id != 0 || hit.t != 2.0f) {
        fprintf(stderr, "unexpected hit: prim %u at t = %g\n", (unsigned)hit.prim_id, hit.t);
        return 1;
    }
    printf("find_package consumer: libaacbvh %s, hit at t = %g\n", aacbvh_version_string(), hit.t);
    return 0;
}
