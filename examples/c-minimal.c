/* The smallest complete use of libaacbvh, in C99: two triangles making the
 * unit square at z = 0, one ray shot down at it, the hit printed. */
#include <aacbvh/aacbvh.h>

#include <math.h>
#include <stdio.h>

static int fail(const char *what, aacbvh_status status, const aacbvh_bvh *bvh) {
    fprintf(stderr, "%s: %s %s\n", what, aacbvh_status_string(status),
            bvh ? aacbvh_bvh_last_error(bvh) : "");
    return 1;
}

int main(void) {
    static const float vertices[] = {
        0.0f, 0.0f, 0.0f,
        1.0f, 0.0f, 0.0f,
        1.0f, 1.0f, 0.0f,
        0.0f, 1.0f, 0.0f,
    };
    static const uint32_t indices[] = {0, 1, 2, 0, 2, 3};
    aacbvh_context *ctx = NULL;
    aacbvh_bvh *bvh = NULL;
    aacbvh_status status;
    aacbvh_ray ray = {{0.25f, 0.75f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
    aacbvh_hit hit;
    int result = 1;

    printf("libaacbvh %s\n", aacbvh_version_string());
    status = aacbvh_context_create(1, &ctx);
    if (status != AACBVH_OK)
        return fail("aacbvh_context_create", status, NULL);
    status = aacbvh_bvh_create(ctx, &bvh);
    if (status != AACBVH_OK) {
        fail("aacbvh_bvh_create", status, NULL);
        goto done;
    }
    /* The library keeps pointers to these arrays: they must outlive the BVH. */
    status = aacbvh_bvh_set_triangles(bvh, vertices, 4, 3 * sizeof(float), indices, 2);
    if (status != AACBVH_OK) {
        fail("aacbvh_bvh_set_triangles", status, bvh);
        goto done;
    }
    status = aacbvh_bvh_build(bvh);
    if (status != AACBVH_OK) {
        fail("aacbvh_bvh_build", status, bvh);
        goto done;
    }
    status = aacbvh_bvh_intersect(bvh, &ray, &hit, 1);
    if (status != AACBVH_OK) {
        fail("aacbvh_bvh_intersect", status, bvh);
        goto done;
    }
    if (hit.prim_id == AACBVH_INVALID_ID) {
        printf("miss\n");
    } else {
        printf("hit triangle %u at t = %g (u = %g, v = %g)\n", (unsigned)hit.prim_id, hit.t, hit.u,
               hit.v);
        result = 0;
    }
done:
    aacbvh_bvh_destroy(bvh);
    aacbvh_context_destroy(ctx);
    return result;
}
