/*
 * Helpers shared by the cmocka tests: a deterministic RNG, triangle and box
 * scene generators, an OBJ loader for the optional real meshes, a checker
 * that walks a built tree through the public API and verifies its invariants,
 * and the harness for "this variant answers bit for bit like the reference"
 * (ts_make_rays, ts_compare_answers, ts_compare_batch_orders).
 * A C interface (implemented in C++ in test_support.cpp); tests stay C99.
 * The double-precision ray oracle is tests/ray_reference.h.
 */
#ifndef AACBVH_TEST_SUPPORT_H
#define AACBVH_TEST_SUPPORT_H

#include <stddef.h>
#include <stdint.h>

#include "aacbvh/aacbvh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Deterministic RNG (xorshift64*) ---------------------------------- */

typedef struct ts_rng {
    uint64_t state;
} ts_rng;

void ts_rng_seed(ts_rng *rng, uint64_t seed);
uint64_t ts_rng_next(ts_rng *rng);
/** Uniform integer in [0, bound); bound > 0. */
uint32_t ts_rng_below(ts_rng *rng, uint32_t bound);
/** Uniform float in [0, 1). */
float ts_rng_float(ts_rng *rng);
/** Uniform float in [lo, hi). */
float ts_rng_range(ts_rng *rng, float lo, float hi);

/* ---- Triangle meshes -------------------------------------------------- */

/** A triangle mesh owned by the tests: vertices are packed x, y, z (stride
 *  12 bytes); indices hold 3 per triangle. Free with ts_mesh_free(). */
typedef struct ts_mesh {
    float *vertices;
    size_t vertex_count;
    uint32_t *indices;
    size_t triangle_count;
} ts_mesh;

typedef enum ts_scene_kind {
    TS_SCENE_RANDOM = 0,        /**< random triangles in the cube [-1, 1]^3 */
    TS_SCENE_GRID = 1,          /**< regular grid mesh with shared vertices (about n triangles) */
    TS_SCENE_IDENTICAL = 2,     /**< all triangles the same */
    TS_SCENE_SAME_CENTROID = 3, /**< different triangles, all with the same centroid */
    TS_SCENE_ZERO_AREA = 4,     /**< collinear and point triangles (zero area) */
    TS_SCENE_FLAT = 5,          /**< every vertex on the plane z = 0 */
    TS_SCENE_SLIVERS = 6,       /**< long thin slivers in every direction */
    TS_SCENE_WIDE_RANGE = 7,    /**< magnitudes from 1e-30 to 1e18 (float products stay finite) */
    /** Overlapping triangles (each point covered by a dozen or so) in the
     *  plane z = 0; x and y are multiples of 1/256 in [-1, 1], exact in
     *  float; no triangle has zero area. */
    TS_SCENE_COPLANAR = 8,
    /** Triangles as in TS_SCENE_COPLANAR on the planes z = 0, -1, -3 and -7
     *  (a ray from z = 1 along -z meets them at t = 1, 2, 4, 8 exactly);
     *  about a third repeat the triangle before them: the same vertices
     *  (shared or copied), rotated or reversed, or moved to another plane. */
    TS_SCENE_COPLANAR_STACK = 9,
    TS_SCENE_KIND_COUNT = 10
} ts_scene_kind;

/** A short name of a scene kind, for messages. */
const char *ts_scene_name(ts_scene_kind kind);
/** Generates a scene of `triangle_count` triangles (TS_SCENE_GRID may round
 *  it to a grid; it is exact for the other kinds). Returns 1 on success. */
int ts_make_scene(ts_scene_kind kind, size_t triangle_count, uint64_t seed, ts_mesh *out);
/**
 * Loads AACBVH_SCENES_DIR/file_name (an OBJ of v and f lines). Returns 1 on
 * success, 0 when the file or the OBJ loader is not available (out is then
 * zeroed; the caller falls back to a generated scene and says so).
 */
int ts_load_scene(const char *file_name, ts_mesh *out);
/** Frees a mesh's arrays (accepts a zeroed mesh) and zeroes it. */
void ts_mesh_free(ts_mesh *mesh);

/** Bounding boxes (6 floats each: min xyz, max xyz) of a mesh's triangles,
 *  computed exactly as min/max of the vertices. malloc'ed; free() it. */
float *ts_mesh_boxes(const ts_mesh *mesh);
/** Bounding boxes of triangles given as in aacbvh_bvh_set_triangles(). */
float *ts_triangle_boxes(const float *vertices, size_t vertex_stride_bytes,
                         const uint32_t *indices, size_t triangle_count);
/** `count` random boxes (6 floats each) with corners in [-1, 1]^3 and
 *  extents up to max_extent. malloc'ed; free() it. */
float *ts_random_boxes(size_t count, float max_extent, uint64_t seed);

/* ---- BVH helpers -------------------------------------------------------- */

/** A copy of a built tree, read through the public API. */
typedef struct ts_tree {
    aacbvh_stats stats;
    aacbvh_node *nodes;
    size_t node_count;
    uint32_t *prims;
    size_t prim_count;
} ts_tree;

/** Reads stats, nodes and primitive indices. Returns AACBVH_OK or the first
 *  failing status (out is then zeroed). Free with ts_tree_free(). */
aacbvh_status ts_tree_fetch(const aacbvh_bvh *bvh, ts_tree *out);
void ts_tree_free(ts_tree *tree);
/** 1 when the two trees have the same nodes and primitive indices. */
int ts_tree_equal(const ts_tree *a, const ts_tree *b);

/** SAH cost of a tree, recomputed in double with the formula of aacbvh_stats. */
double ts_tree_sah_cost(const ts_tree *tree, double traversal_cost, double intersection_cost);

/**
 * Checks every invariant of a built tree against its primitives' boxes
 * (prim_boxes: 6 floats per primitive, prim_total primitives in the scene):
 * each primitive expected in the tree (present == NULL: all; else those with
 * present[i] != 0) is in exactly one leaf and no other is; child boxes lie in
 * their parent's (exact compare); each leaf box contains its primitives'
 * boxes; node count = 2 * leaves - 1; leaves hold 1..max_leaf_size primitives;
 * inner nodes have count 0 and children in range; each node is reached once;
 * the stats agree with a recount (sah_cost within 1e-6 relative, with the
 * costs currently set on the BVH). Returns 1 when all hold, else 0 with a
 * message in msg.
 */
int ts_check_tree(const aacbvh_bvh *bvh, const float *prim_boxes, size_t prim_total,
                  const unsigned char *present, uint32_t max_leaf_size,
                  char *msg, size_t msg_size);

/** 1 when the two trees have the same nodes and primitive indices; else 0
 *  with the first difference (counts, node or primitive slot) in msg. */
int ts_tree_diff(const ts_tree *a, const ts_tree *b, char *msg, size_t msg_size);

/* ---- Comparing answers: "this variant answers bit for bit like that" ------ */

/**
 * `count` rays over a scene whose coordinates are `coords` (coord_count
 * floats, x y z triples: vertices, or box corners), for comparing two BVHs;
 * deterministic in the seed. malloc'ed (NULL when out of memory); free() it.
 * Directions: half aim at one of the scene's points, the rest at a point of
 * its box; a quarter run along an axis (the other components +0 or -0, the
 * origin level with the target), some have one zero component (the origin on
 * the target's coordinate plane). Origins: around the box, one in eight on a
 * coordinate plane of the scene. Intervals: mostly [0, inf), then bounded,
 * (-inf, inf), partly and wholly negative, one point (t = 1 at the target
 * half the time) and empty. One ray in twenty is invalid: a NaN or infinite
 * field, or a zero direction.
 */
aacbvh_ray *ts_make_rays(const float *coords, size_t coord_count, size_t count, uint64_t seed);

/* ThreadSanitizer checks every memory access (tests run 10-15 times slower
 * under it). Tests that repeat the same checks over thousands of rays use
 * TS_RAYS(n) rays: n, or under ThreadSanitizer at most 1100, which still
 * splits every batch into tasks (grains of 256 and 1024 rays). The checks are
 * the same; the Release and AddressSanitizer runs trace all n. */
#if defined(__SANITIZE_THREAD__)
#define TS_UNDER_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define TS_UNDER_TSAN 1
#endif
#endif
#ifndef TS_UNDER_TSAN
#define TS_UNDER_TSAN 0
#endif
#define TS_RAYS(n) (TS_UNDER_TSAN && (n) > 1100 ? 1100 : (n))

/* AddressSanitizer (with UBSan in the suite's second stage): tests run 2-4
 * times slower. The few tests that repeat one check thousands of times (rays
 * that meet every triangle of a degenerate scene, every thread count) run a
 * lighter load under either sanitizer; the Release stage runs them in full. */
#if defined(__SANITIZE_ADDRESS__)
#define TS_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TS_UNDER_ASAN 1
#endif
#endif
#ifndef TS_UNDER_ASAN
#define TS_UNDER_ASAN 0
#endif
#define TS_UNDER_SANITIZER (TS_UNDER_TSAN || TS_UNDER_ASAN)

/** The answers of one BVH to a batch of rays. */
typedef struct ts_answers {
    aacbvh_hit *hits;
    uint8_t *occluded;
    size_t count;
} ts_answers;

/** Runs aacbvh_bvh_intersect and aacbvh_bvh_occluded on the rays, into
 *  buffers prefilled with garbage that changes from call to call; fails the
 *  running cmocka test when a call fails. Free with ts_answers_free(). */
void ts_answers_query(const aacbvh_bvh *bvh, const aacbvh_ray *rays, size_t count, ts_answers *out);
void ts_answers_free(ts_answers *answers);

/**
 * 1 when `variant` answers every ray like `reference`, bit for bit: t, u and
 * v (memcmp), prim_id, and occluded. Each side must also be well formed: a
 * miss is (t, u, v) = (+inf, 0, 0), occluded is 0 or 1 and says whether the
 * closest hit found something. Else 0, with the first mismatch in msg (the
 * ray's index, the ray, both answers; floats in %a, which shows -0). rays may
 * be NULL (the message then leaves the ray out).
 */
int ts_answers_equal(const ts_answers *reference, const ts_answers *variant, const aacbvh_ray *rays, char *msg,
                     size_t msg_size);

/** Queries both BVHs with the rays and fails the running cmocka test with
 *  `what` and the first mismatch (see ts_answers_equal). Returns how many
 *  rays hit something. */
size_t ts_compare_answers(const aacbvh_bvh *reference, const aacbvh_bvh *variant, const aacbvh_ray *rays,
                          size_t count, const char *what);

/** Queries one BVH with the rays in their order, in reverse and shuffled
 *  (deterministic in the seed) and fails the running cmocka test with `what`
 *  unless each ray gets the same answer, bit for bit, in every order. */
void ts_compare_batch_orders(const aacbvh_bvh *bvh, const aacbvh_ray *rays, size_t count, uint64_t seed,
                             const char *what);

/* ---- Small conveniences ------------------------------------------------- */

/** A context and a BVH on it, or fails the running cmocka test. */
void ts_create(uint32_t threads, aacbvh_context **ctx, aacbvh_bvh **bvh);

/** aacbvh_bvh_set_triangles() of the mesh (stride 12 bytes), or fails the running cmocka test. */
void ts_set_mesh(aacbvh_bvh *bvh, const ts_mesh *mesh);

/** Moves each vertex coordinate by up to 5% of the sum of the mesh's extents
 *  (ts_jitter_coords; deterministic in the seed). */
void ts_jitter_mesh(ts_mesh *mesh, uint64_t seed);

/** Bounds of xyz coordinates (coord_count floats); (-1, 1) on each axis when empty. */
void ts_coords_bounds(const float *coords, size_t coord_count, float lo[3], float hi[3]);

/** Moves every coordinate by up to +-scale (deterministic in the seed). */
void ts_jitter_coords(float *coords, size_t coord_count, float scale, uint64_t seed);

/** stats.memory_bytes of a built BVH, or fails the running cmocka test. */
uint64_t ts_memory_bytes(const aacbvh_bvh *bvh);

/** Fails the running cmocka test with the status names when `got != want`. */
#define TS_EXPECT_STATUS(got, want)                                                   \
    do {                                                                              \
        aacbvh_status ts_got_ = (got), ts_want_ = (want);                             \
        if (ts_got_ != ts_want_)                                                      \
            fail_msg("%s:%d: %s returned %s, expected %s", __FILE__, __LINE__, #got,  \
                     aacbvh_status_string(ts_got_), aacbvh_status_string(ts_want_));  \
    } while (0)

#ifdef __cplusplus
}
#endif

#endif /* AACBVH_TEST_SUPPORT_H */
