/*
 * libaacbvh: bounding volume hierarchies built by Approximate Agglomerative
 * Clustering (Gu, He, Fatahalian, Blelloch, "Efficient BVH Construction via
 * Approximate Agglomerative Clustering", HPG 2013).
 *
 * How to use (error checks left out):
 *
 *     aacbvh_context *ctx;  aacbvh_bvh *bvh;
 *     aacbvh_context_create(0, &ctx);               // 0 = one thread per core
 *     aacbvh_bvh_create(ctx, &bvh);
 *     aacbvh_bvh_set_param_int(bvh, AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST);
 *     aacbvh_bvh_set_triangles(bvh, xyz, vertex_count, 3 * sizeof(float),
 *                              indices, triangle_count);  // buffers are NOT copied
 *     aacbvh_bvh_build(bvh);
 *     aacbvh_bvh_intersect(bvh, rays, hits, ray_count);   // closest hits
 *     ... move vertices in place, then aacbvh_bvh_refit(bvh) each frame ...
 *     aacbvh_bvh_destroy(bvh);  aacbvh_context_destroy(ctx);
 *
 * Every fallible call returns an aacbvh_status: the ones its comment lists,
 * and besides them AACBVH_ERROR_OUT_OF_MEMORY from any call that allocates
 * and AACBVH_ERROR_INTERNAL (a library bug) from any call. After a failure
 * on a BVH handle, aacbvh_bvh_last_error() explains it to the thread that
 * made the call, and aacbvh_last_error() explains failures without a handle
 * (both per thread). The library never prints, exits or aborts, and no C++
 * exception crosses this interface.
 *
 * Thread safety: a handle may be used by one thread at a time, except that
 * aacbvh_bvh_intersect(), aacbvh_bvh_occluded(), aacbvh_bvh_get_stats(),
 * aacbvh_bvh_get_nodes() and aacbvh_bvh_get_primitive_indices() may run
 * concurrently with each other on a built BVH. Different BVH handles are
 * independent, also when they share a context.
 *
 * This header compiles as C99 and as C++. ABI policy: docs/ABI.md.
 */
#ifndef AACBVH_AACBVH_H
#define AACBVH_AACBVH_H

#include <stddef.h>
#include <stdint.h>
#include <stdbool.h>

#ifndef AACBVH_API
#  if defined(_WIN32)
#    define AACBVH_API
#  else
#    define AACBVH_API __attribute__((visibility("default")))
#  endif
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ===================================================================== */
/* Version                                                               */
/* ===================================================================== */

#define AACBVH_VERSION_MAJOR 1
#define AACBVH_VERSION_MINOR 2
#define AACBVH_VERSION_PATCH 0
#define AACBVH_VERSION_NUMBER \
    (AACBVH_VERSION_MAJOR * 10000 + AACBVH_VERSION_MINOR * 100 + AACBVH_VERSION_PATCH)
#define AACBVH_VERSION_STRINGIFY_(x) #x
#define AACBVH_VERSION_STRINGIFY(x) AACBVH_VERSION_STRINGIFY_(x)
#define AACBVH_VERSION_STRING                         \
    AACBVH_VERSION_STRINGIFY(AACBVH_VERSION_MAJOR) "." \
    AACBVH_VERSION_STRINGIFY(AACBVH_VERSION_MINOR) "." \
    AACBVH_VERSION_STRINGIFY(AACBVH_VERSION_PATCH)

/** The library's version as major * 10000 + minor * 100 + patch, at run time.
 *  Thread-safe (like every call that takes no handle, except the create and
 *  destroy calls, which follow the handle rules). */
AACBVH_API unsigned aacbvh_version_number(void);
/** The library's version as "major.minor.patch", at run time. Static storage
 *  (never free it). Thread-safe. */
AACBVH_API const char *aacbvh_version_string(void);

/* ===================================================================== */
/* Status codes (values are pinned forever)                              */
/* ===================================================================== */

typedef enum aacbvh_status {
    AACBVH_OK = 0,
    AACBVH_ERROR_INVALID_ARGUMENT = 1,  /**< NULL pointer, value out of range, bad stride */
    AACBVH_ERROR_INVALID_OPERATION = 2, /**< call not allowed in this state (e.g. intersect before build) */
    AACBVH_ERROR_OUT_OF_MEMORY = 3,     /**< memory ran out: any call that allocates may return it (builds, refit, queries and stats use working memory); the call then changed nothing */
    AACBVH_ERROR_INVALID_GEOMETRY = 4,  /**< NaN/infinite coordinates, index out of range */
    AACBVH_ERROR_CANCELLED = 5,         /**< the progress callback asked to stop */
    AACBVH_ERROR_INTERNAL = 6,          /**< a bug in the library (any call may return it); the message says where */
    AACBVH_STATUS_MAX_ENUM = 0x7FFFFFFF
} aacbvh_status;

/** A short English name of a status ("AACBVH_OK", ...; "unknown aacbvh_status" for
 *  values not listed). Static storage (never free it); never NULL. Thread-safe. */
AACBVH_API const char *aacbvh_status_string(aacbvh_status status);

/* ===================================================================== */
/* Handles                                                               */
/* ===================================================================== */

/** Owns the worker threads that builds and batch queries run on. */
typedef struct aacbvh_context aacbvh_context;
/** One BVH: its parameters, a reference to the caller's geometry, and the tree. */
typedef struct aacbvh_bvh aacbvh_bvh;

/**
 * Creates a context with `thread_count` threads in all (the calling thread
 * included); 0 means one per available core.
 * Returns AACBVH_OK, AACBVH_ERROR_INVALID_ARGUMENT (out is NULL, or
 * thread_count > 1024) or AACBVH_ERROR_OUT_OF_MEMORY (also when the system
 * cannot start the threads). On failure *out is NULL and aacbvh_last_error()
 * says why.
 * The caller owns the context and frees it with aacbvh_context_destroy().
 * Thread-safe: contexts may be created from any thread.
 */
AACBVH_API aacbvh_status aacbvh_context_create(uint32_t thread_count, aacbvh_context **out);
/** Number of threads the context runs builds on (>= 1); 0 for NULL. Thread-safe. */
AACBVH_API uint32_t aacbvh_context_thread_count(const aacbvh_context *context);
/**
 * Destroys a context and joins its threads. Accepts NULL. Every BVH created
 * on it must have been destroyed first, and no other call may use it meanwhile.
 * While any context lives, the library keeps up to 16 MiB of memory that
 * builds freed (the 2 MiB pages of their mid-size scratch arrays) for the
 * next builds on any context, so that a build's speed does not depend on
 * the state of the C library's heap; destroying the last context frees it.
 * aacbvh_stats.memory_bytes does not count it.
 */
AACBVH_API void aacbvh_context_destroy(aacbvh_context *context);

/**
 * Creates an empty BVH on `context` (which must outlive it), with default
 * parameters (AAC-HQ, leaves of at most 4 primitives).
 * Returns AACBVH_OK, AACBVH_ERROR_INVALID_ARGUMENT (a NULL argument) or
 * AACBVH_ERROR_OUT_OF_MEMORY. On failure *out is NULL and aacbvh_last_error()
 * says why. The caller owns the BVH
 * and frees it with aacbvh_bvh_destroy(). Thread-safe: several threads may
 * create BVHs on one context at once.
 */
AACBVH_API aacbvh_status aacbvh_bvh_create(aacbvh_context *context, aacbvh_bvh **out);
/** Destroys a BVH and everything it allocated (never the caller's geometry
 *  buffers). Accepts NULL. No other call may use the handle meanwhile. */
AACBVH_API void aacbvh_bvh_destroy(aacbvh_bvh *bvh);
/**
 * The message of the calling thread's last failed call on this handle: never
 * NULL, non-empty after any failure, "" if nothing this thread called on the
 * handle has failed yet (and "invalid handle" for a NULL bvh). Each thread
 * has its own (since 1.1.0), so concurrent queries that fail do not overwrite
 * each other's messages. Owned by the handle: valid until this thread's next
 * call on the handle, or the handle's destruction. Thread-safe.
 */
AACBVH_API const char *aacbvh_bvh_last_error(const aacbvh_bvh *bvh);
/**
 * The message of the calling thread's last failed call that had no BVH
 * handle to keep it (aacbvh_context_create, aacbvh_bvh_create, and any call
 * given a NULL bvh): never NULL, "" before any such failure. Per thread;
 * valid until the thread's next such failure (since 1.1.0). Thread-safe.
 */
AACBVH_API const char *aacbvh_last_error(void);

/* ===================================================================== */
/* Parameters                                                            */
/* ===================================================================== */

/** Builders. Values are pinned forever. */
typedef enum aacbvh_builder {
    AACBVH_BUILDER_AAC_HQ = 0,          /**< default: delta 20, alpha 0.4 and f(n) =
                                             ceil(2.3 n^alpha) (changed after 1.2.0: the paper's
                                             c = 20^0.6 / 2, still the reported AAC_C, costs about
                                             a sixth more build time for the same SAH within 1 %);
                                             the clusters reaching the root split once by SAH
                                             before the greedy merge (changed after 1.1.0); the
                                             top above the sub-trees of at most 64 primitives
                                             built again by a full-sweep SAH over them and kept
                                             where the SAH cost is lower (changed after 1.2.0:
                                             scanned meshes 4-6 % lower SAH) */
    AACBVH_BUILDER_AAC_FAST = 1,        /**< delta 4, c = 4^0.7 / 2, alpha 0.3; ranges of 1,024
                                             primitives and more hand up AAC_HQ's cluster counts,
                                             and the root splits like AAC_HQ's (less overlap at
                                             the top; changed after 1.1.0); the top rebuilt like
                                             AAC_HQ's (changed after 1.2.0) */
    AACBVH_BUILDER_AAC = 2,             /**< the paper's AAC with the delta, c, alpha in force:
                                             f(n) = ceil(c n^alpha) at every size, greedy root,
                                             no top rebuilt */
    AACBVH_BUILDER_SWEEP_SAH = 3,       /**< top-down full-sweep SAH (MacDonald and Booth 1990) */
    AACBVH_BUILDER_BINNED_SAH = 4,      /**< top-down binned SAH, 16 bins (Wald 2007) */
    AACBVH_BUILDER_LOCALLY_ORDERED = 5, /**< exact agglomerative clustering (Walter et al. 2008) */
    AACBVH_BUILDER_PLOC = 6,            /**< parallel locally-ordered clustering (Meister and Bittner 2018) */
    AACBVH_BUILDER_MAX_ENUM = 0x7FFFFFFF
} aacbvh_builder;

/** The builder's short name ("aac-hq", "aac-fast", "aac", "sweep-sah",
 *  "binned-sah", "locally-ordered", "ploc"), or NULL for a value that is no
 *  builder. Builders are numbered from 0 without gaps, so a program can list
 *  them all: for (b = 0; aacbvh_builder_name(b); ++b). Static storage.
 *  Thread-safe. Since 1.1.0. */
AACBVH_API const char *aacbvh_builder_name(aacbvh_builder builder);
/** The builder whose aacbvh_builder_name() is `name` into *out. Returns
 *  AACBVH_OK or AACBVH_ERROR_INVALID_ARGUMENT (NULL argument, unknown name;
 *  aacbvh_last_error() lists the names). Thread-safe. Since 1.1.0. */
AACBVH_API aacbvh_status aacbvh_builder_from_name(const char *name, aacbvh_builder *out);

/**
 * Parameter keys. Values are pinned forever. Each key has one type: integer
 * keys are read and written with the _int calls, float keys with the _float
 * calls; the other call returns AACBVH_ERROR_INVALID_ARGUMENT. Values out of
 * range return AACBVH_ERROR_INVALID_ARGUMENT and change nothing. Parameters
 * take effect at the next build (the costs also at the next get_stats).
 */
typedef enum aacbvh_param {
    /** int, an aacbvh_builder. Choosing AAC_HQ or AAC_FAST also sets delta, c
     *  and alpha to the paper's values (the presets' own cluster counts are
     *  described at aacbvh_builder; AACBVH_BUILDER_AAC builds with the values
     *  in force). Default AACBVH_BUILDER_AAC_HQ. */
    AACBVH_PARAM_BUILDER = 0,
    /** int >= 2 (at most 1 << 20): ranges of fewer primitives stay unsplit in
     *  AAC's downward phase. Setting it switches the builder to AACBVH_BUILDER_AAC. */
    AACBVH_PARAM_AAC_DELTA = 1,
    /** int in [1, 1 << 16]: most primitives per leaf. Default 4. */
    AACBVH_PARAM_MAX_LEAF_SIZE = 2,
    /** float > 0 (finite): c in f(n) = ceil(c * n^alpha). Setting it switches
     *  the builder to AACBVH_BUILDER_AAC. */
    AACBVH_PARAM_AAC_C = 3,
    /** float in (0, 1]: alpha in f(n). c = 1, alpha = 1 is exact agglomerative
     *  clustering. Setting it switches the builder to AACBVH_BUILDER_AAC. */
    AACBVH_PARAM_AAC_ALPHA = 4,
    /** float in (0, 1e30]: SAH cost of visiting an inner node. Default 1.2. */
    AACBVH_PARAM_TRAVERSAL_COST = 5,
    /** float in (0, 1e30]: SAH cost of one primitive test. Default 1.0. */
    AACBVH_PARAM_INTERSECTION_COST = 6,
    /** int in [1, 1024]: PLOC's nearest-neighbour search radius. Default 16. */
    AACBVH_PARAM_PLOC_RADIUS = 7,
    /** int 0 or 1: 1 leaves primitives with NaN or infinite coordinates or
     *  out-of-range indices out of the tree (counted in the stats) instead of
     *  failing the build with AACBVH_ERROR_INVALID_GEOMETRY. Default 0. */
    AACBVH_PARAM_SKIP_INVALID_PRIMITIVES = 8,
    /** int, an aacbvh_layout: the structure ray queries traverse. The binary
     *  nodes of aacbvh_bvh_get_nodes() exist in every layout. Default
     *  AACBVH_LAYOUT_WIDE8 (since 1.2; AACBVH_LAYOUT_BINARY before). */
    AACBVH_PARAM_TRAVERSAL_LAYOUT = 9,
    /** int, an aacbvh_triangle_storage: where ray queries read triangles
     *  from. Default AACBVH_TRIANGLES_COPIED (since 1.2;
     *  AACBVH_TRIANGLES_REFERENCED before). */
    AACBVH_PARAM_TRIANGLE_STORAGE = 10,
    /** int 0 or 1: 1 keeps the large blocks a build frees (its scratch
     *  memory, the tree it replaces) with the handle and reuses them on the
     *  next build, for applications that rebuild every frame: no fresh pages
     *  to fault in, so rebuilds are faster, at the cost of holding up to
     *  aacbvh_stats.build_peak_bytes between builds. Blocks the next build
     *  does not reuse are freed at its end; setting 0 frees them at once, as
     *  does destroying the handle. Trees are identical either way.
     *  aacbvh_bvh_optimize() uses the kept blocks as a build does (since 1.2).
     *  Either way a build reuses the blocks it frees for its own later
     *  arrays (since 1.2). Default 0. */
    AACBVH_PARAM_KEEP_BUILD_MEMORY = 11,
    /** int in [0, AACBVH_MAX_OPTIMIZE_PASSES] (since 1.2): passes of
     *  aacbvh_bvh_optimize() run at the end of every build, counted in its
     *  time (aacbvh_stats.build_seconds) and in aacbvh_stats.built_sah_cost.
     *  Default 0 (none). */
    AACBVH_PARAM_OPTIMIZE_PASSES = 12,
    AACBVH_PARAM_MAX_ENUM = 0x7FFFFFFF
} aacbvh_param;

/** Traversal layouts. Values are pinned forever. */
typedef enum aacbvh_layout {
    /** Queries walk the 32-byte binary nodes themselves: no extra memory. */
    AACBVH_LAYOUT_BINARY = 0,
    /** Queries walk a 4-wide tree collapsed from the binary one, tested four
     *  boxes at a time with SIMD: faster rays, more memory (reported in
     *  aacbvh_stats.memory_bytes). Made by build and kept up to date by refit. */
    AACBVH_LAYOUT_WIDE4 = 1,
    /** The default (since 1.2): an 8-wide tree collapsed from the binary one,
     *  its eight child boxes tested at once with SIMD (SSE2, or AVX2 where
     *  the CPU has it: chosen at run time, the answers are the same bit for
     *  bit). With AACBVH_TRIANGLES_COPIED its leaves hold the triangles
     *  themselves, four side by side, tested together; that copy replaces
     *  the 36-byte-per-triangle one of the other layouts, and the handle
     *  keeps the binary tree's shape (a byte per node) instead of its
     *  32-byte nodes: aacbvh_bvh_get_nodes() makes them again from the
     *  copied triangles, the same as the other layouts report, in time
     *  linear in the tree. A call for all nodes keeps nothing; a call for
     *  part of them keeps them (counted in aacbvh_stats.memory_bytes) until
     *  the next build, refit or optimize, so reading them in pieces costs
     *  one making.
     *  Made by build and kept up to date by refit; counted in
     *  aacbvh_stats.memory_bytes. */
    AACBVH_LAYOUT_WIDE8 = 2,
    AACBVH_LAYOUT_MAX_ENUM = 0x7FFFFFFF
} aacbvh_layout;

/** Where ray queries read triangles from. Values are pinned forever. Both
 *  give bit-identical results. */
typedef enum aacbvh_triangle_storage {
    /** Queries read the caller's buffers: no copy. */
    AACBVH_TRIANGLES_REFERENCED = 0,
    /** The BVH keeps the three vertices of every triangle (36 bytes each) in
     *  leaf order, made by build and refreshed by refit: faster rays, more
     *  memory (counted in aacbvh_stats.memory_bytes). Ignored for box
     *  geometry. */
    AACBVH_TRIANGLES_COPIED = 1,
    AACBVH_TRIANGLE_STORAGE_MAX_ENUM = 0x7FFFFFFF
} aacbvh_triangle_storage;

/** Sets an integer parameter. Returns AACBVH_OK or AACBVH_ERROR_INVALID_ARGUMENT. */
AACBVH_API aacbvh_status aacbvh_bvh_set_param_int(aacbvh_bvh *bvh, aacbvh_param param, int64_t value);
/** Sets a float parameter. Returns AACBVH_OK or AACBVH_ERROR_INVALID_ARGUMENT. */
AACBVH_API aacbvh_status aacbvh_bvh_set_param_float(aacbvh_bvh *bvh, aacbvh_param param, double value);
/** Reads an integer parameter into *out. Returns AACBVH_OK or AACBVH_ERROR_INVALID_ARGUMENT. */
AACBVH_API aacbvh_status aacbvh_bvh_get_param_int(const aacbvh_bvh *bvh, aacbvh_param param, int64_t *out);
/** Reads a float parameter into *out. Returns AACBVH_OK or AACBVH_ERROR_INVALID_ARGUMENT. */
AACBVH_API aacbvh_status aacbvh_bvh_get_param_float(const aacbvh_bvh *bvh, aacbvh_param param, double *out);

/* ===================================================================== */
/* Geometry (referenced, never copied)                                   */
/* ===================================================================== */

/** The most primitives one BVH holds, 2^31 - 1 (since 1.1.0): the builders
 *  number the 2n - 1 nodes of their binary trees with 32-bit ids. */
#define AACBVH_MAX_PRIMITIVES 0x7FFFFFFFu

/**
 * Makes the BVH's primitives `triangle_count` triangles. Vertex k's x, y, z
 * are the three floats at byte offset k * vertex_stride_bytes of `vertices`
 * (stride >= 12 and a multiple of 4). Triangle i uses vertices indices[3i],
 * indices[3i+1], indices[3i+2], or 3i, 3i+1, 3i+2 when indices is NULL.
 *
 * Lifetime: the library keeps the pointers, not copies. Both buffers must stay
 * valid and unchanged in size until the geometry is replaced or the BVH is
 * destroyed; they are read by build, refit, intersect and occluded. Vertex
 * positions may change between calls (then refit or build again).
 *
 * NULL pointers with zero counts make a valid empty scene. The contents are
 * checked by the build (AACBVH_ERROR_INVALID_GEOMETRY names the first bad
 * triangle). Afterwards queries return AACBVH_ERROR_INVALID_OPERATION until
 * the next successful build or refit (refit needs the same primitive count).
 * Returns AACBVH_OK or AACBVH_ERROR_INVALID_ARGUMENT (NULL with a nonzero
 * count, bad stride, counts that overflow or exceed AACBVH_MAX_PRIMITIVES).
 */
AACBVH_API aacbvh_status aacbvh_bvh_set_triangles(aacbvh_bvh *bvh,
                                                  const float *vertices, size_t vertex_count,
                                                  size_t vertex_stride_bytes,
                                                  const uint32_t *indices, size_t triangle_count);
/**
 * Makes the BVH's primitives `box_count` axis-aligned boxes: box i is the six
 * floats min x, y, z, max x, y, z at byte offset i * stride_bytes (stride >= 24
 * and a multiple of 4). Same lifetime and validity rules as
 * aacbvh_bvh_set_triangles(); a box with min > max on an axis is invalid.
 * Returns AACBVH_OK or AACBVH_ERROR_INVALID_ARGUMENT (NULL with a nonzero
 * count, bad stride, counts that overflow or exceed AACBVH_MAX_PRIMITIVES).
 */
AACBVH_API aacbvh_status aacbvh_bvh_set_boxes(aacbvh_bvh *bvh, const float *boxes,
                                              size_t box_count, size_t stride_bytes);

/* ===================================================================== */
/* Build and refit                                                       */
/* ===================================================================== */

/**
 * Progress callback: called on the thread that called aacbvh_bvh_build(), with
 * the fraction done in [0, 1]. Fractions never decrease; a build that succeeds
 * reports 0 first and 1 last. Calls come between the build's phases and
 * during them every few milliseconds, and never more than a fixed amount of
 * work apart in the clustering builders (about 2^20 distance evaluations,
 * whatever the parameters: AAC delta 2^20, alpha 1, PLOC radius 1024), so a
 * cancel is noticed promptly by every builder. Return true to go on, false to cancel: the build then stops
 * promptly, frees what it allocated, returns AACBVH_ERROR_CANCELLED and keeps
 * the previous tree, and the callback is not called again by that build.
 *
 * The callback may use the library (since 1.1.0): build, refit, query and
 * destroy other BVHs, on any context (the building one included), and query
 * this one (which answers with its previous tree). Calls that would change
 * this handle (set_param, set_triangles, set_boxes, build, refit) return
 * AACBVH_ERROR_INVALID_OPERATION. The build's result does not depend on what
 * the callback does, and the callback is never entered again while it runs.
 */
typedef bool (*aacbvh_progress_fn)(void *user_data, double fraction_done);

/** Installs (or, with fn NULL, removes) a progress callback for the handle's
 *  later builds. The library only passes user_data back to fn; both must stay
 *  valid while installed. Returns AACBVH_OK or AACBVH_ERROR_INVALID_ARGUMENT
 *  (bvh NULL). */
AACBVH_API aacbvh_status aacbvh_bvh_set_progress_callback(aacbvh_bvh *bvh, aacbvh_progress_fn fn,
                                                          void *user_data);

/**
 * Builds the tree over the current geometry with the parameters in force.
 * Zero primitives give an empty tree (node count 0) whose rays all miss.
 * Returns AACBVH_OK, AACBVH_ERROR_INVALID_ARGUMENT (bvh NULL),
 * AACBVH_ERROR_INVALID_GEOMETRY, AACBVH_ERROR_OUT_OF_MEMORY or
 * AACBVH_ERROR_CANCELLED. On failure the previous tree, if any, is kept as it
 * was, and everything the failed build allocated is freed. Runs on the
 * context's threads and returns when done. aacbvh_stats.build_peak_bytes
 * reports its peak memory.
 */
AACBVH_API aacbvh_status aacbvh_bvh_build(aacbvh_bvh *bvh);

/**
 * Recomputes every node's bounds bottom-up from the current vertex positions,
 * keeping the topology (time linear in the node count). Needs a built tree
 * over the same number of primitives. Returns AACBVH_OK,
 * AACBVH_ERROR_INVALID_ARGUMENT (bvh NULL), AACBVH_ERROR_INVALID_OPERATION
 * (never built, or the primitive count changed) or
 * AACBVH_ERROR_INVALID_GEOMETRY (a coordinate became NaN or infinite; the tree
 * is then kept as it was). Runs on the context's threads. The topology of the
 * last build is kept, so quality drops as primitives move apart: after a
 * refit, aacbvh_stats.sah_cost / aacbvh_stats.built_sah_cost tells how much,
 * which is what decides when to build again instead (README.md, "Animation").
 */
AACBVH_API aacbvh_status aacbvh_bvh_refit(aacbvh_bvh *bvh);

/** The most passes aacbvh_bvh_optimize() and AACBVH_PARAM_OPTIMIZE_PASSES
 *  take (since 1.2). */
#define AACBVH_MAX_OPTIMIZE_PASSES 64

/**
 * Improves the current tree in place (since 1.2), after a build or after a
 * refit, without changing which primitives it holds. Each pass is one round
 * of reinsertion (Bittner, Hapala, Havran 2013, in parallel rounds after
 * Meister and Bittner 2018: sub-trees move to where they cost least) and one
 * of treelet restructuring (Karras and Aila 2013); primitives may change
 * leaves, the leaves are made again by the same rule as a build's (so
 * AACBVH_PARAM_MAX_LEAF_SIZE holds), and aacbvh_stats.sah_cost never rises.
 * Each pass takes time linear in the primitive count (plus sorting the moves
 * it found); passes stop early once one changes nothing. The result is the
 * same at any thread count. The traversal layout and the triangle copy are
 * made again from the new tree, as a build does; afterwards
 * aacbvh_stats.built_sah_cost is the optimised tree's SAH (the drift after a
 * refit starts again from 1), build_seconds is unchanged.
 * passes 0 only checks that there is a tree. Runs on the context's threads
 * and reports progress and honours cancel through the progress callback as a
 * build does (and, like a build, cannot be called from this handle's own
 * callback). Returns AACBVH_OK, AACBVH_ERROR_INVALID_ARGUMENT (bvh NULL,
 * passes above AACBVH_MAX_OPTIMIZE_PASSES), AACBVH_ERROR_INVALID_OPERATION (no
 * tree yet, the geometry changed since the last build or refit, or called from
 * the handle's progress callback), AACBVH_ERROR_OUT_OF_MEMORY or
 * AACBVH_ERROR_CANCELLED; on failure the tree is kept as it was.
 */
AACBVH_API aacbvh_status aacbvh_bvh_optimize(aacbvh_bvh *bvh, uint32_t passes);

/* ===================================================================== */
/* Queries                                                               */
/* ===================================================================== */

/** Figures of a built tree. Only ever grows at its end. */
typedef struct aacbvh_stats {
    uint32_t struct_size;          /**< set by the caller: sizeof(aacbvh_stats) */
    uint32_t max_depth;            /**< edges from the root to the deepest leaf */
    uint64_t node_count;           /**< inner nodes + leaves (2 * leaves - 1, or 0) */
    uint64_t leaf_count;
    uint64_t primitive_count;      /**< primitives in the tree */
    double sah_cost;               /**< (Ct * sum A(inner) + Ci * sum A(leaf) N(leaf)) / A(root), costs in force now; 0 if A(root) = 0 */
    uint64_t memory_bytes;         /**< every byte the BVH handle holds: tree, traversal layout, triangle copy, kept build memory */
    uint64_t invalid_primitive_count; /**< primitives left out by AACBVH_PARAM_SKIP_INVALID_PRIMITIVES */
    uint64_t build_peak_bytes;     /**< most bytes the last build held at once, the finished tree included */
    double built_sah_cost;         /**< sah_cost of the tree as the last build made it (before any refit), with the costs in force now: sah_cost / built_sah_cost is 1 when nothing moved */
    double build_seconds;          /**< wall time of the last successful build */
    /* Since 1.1.0: */
    uint64_t kept_build_bytes;     /**< of memory_bytes, the blocks kept for the next build (AACBVH_PARAM_KEEP_BUILD_MEMORY); 0 without it */
} aacbvh_stats;

/**
 * Fills *out. The caller sets out->struct_size = sizeof(aacbvh_stats) first;
 * an older, smaller struct gets the fields that fit. Returns AACBVH_OK,
 * AACBVH_ERROR_INVALID_ARGUMENT (NULL, or struct_size too small) or
 * AACBVH_ERROR_INVALID_OPERATION (no valid tree). Constant time, except
 * the first call after a build, which measures the tree once (depth, leaf
 * count and SAH area sums: time linear in the node count, on the context's
 * threads). The figures are kept with the handle, and refit keeps the area
 * sums current, so calling it every frame of a refit loop costs nothing more;
 * sah_cost is computed from the sums with the costs in force at the call.
 */
AACBVH_API aacbvh_status aacbvh_bvh_get_stats(const aacbvh_bvh *bvh, aacbvh_stats *out);

/**
 * A node of the finished binary tree, 32 bytes. Node 0 is the root. An inner
 * node has count == 0 and children first and first + 1; a leaf holds the
 * primitives prim[first .. first + count) of the primitive index array.
 */
typedef struct aacbvh_node {
    float lower[3];
    float upper[3];
    uint32_t first;
    uint32_t count;
} aacbvh_node;

/** Copies nodes [first, first + count) into out. Returns AACBVH_OK,
 *  AACBVH_ERROR_INVALID_ARGUMENT (NULL out with count > 0, range past the end),
 *  AACBVH_ERROR_INVALID_OPERATION (no valid tree) or, where the nodes are
 *  made again (AACBVH_LAYOUT_WIDE8 with copied triangles, since 1.2),
 *  AACBVH_ERROR_OUT_OF_MEMORY. */
AACBVH_API aacbvh_status aacbvh_bvh_get_nodes(const aacbvh_bvh *bvh, size_t first, size_t count,
                                              aacbvh_node *out);
/** Copies entries [first, first + count) of the primitive index array (length
 *  = primitive_count) into out: primitive indices in the caller's order, as
 *  aacbvh_hit.prim_id. Same returns as aacbvh_bvh_get_nodes(). */
AACBVH_API aacbvh_status aacbvh_bvh_get_primitive_indices(const aacbvh_bvh *bvh, size_t first,
                                                          size_t count, uint32_t *out);

/* ===================================================================== */
/* Rays                                                                  */
/* ===================================================================== */

#define AACBVH_INVALID_ID 0xFFFFFFFFu

/**
 * A ray, 32 bytes: points org + t * dir for tmin <= t <= tmax. dir need not be
 * normalised; t is in units of dir; tmax may be INFINITY. A ray with a NaN
 * field, or an infinite origin or direction, or a zero direction, misses.
 */
typedef struct aacbvh_ray {
    float org[3];
    float tmin;
    float dir[3];
    float tmax;
} aacbvh_ray;

/**
 * A hit, 16 bytes. prim_id is the index of the triangle or box hit in the
 * caller's order (triangle i of aacbvh_bvh_set_triangles(), box i of
 * aacbvh_bvh_set_boxes()), also when AACBVH_PARAM_SKIP_INVALID_PRIMITIVES
 * left primitives out; AACBVH_INVALID_ID on a miss (t, u, v are then
 * INFINITY, 0, 0). The hit point is (1 - u - v) * v0 + u * v1 + v * v2. For
 * boxes, t is the distance at which the ray enters the box (clamped to tmin)
 * and u = v = 0. A hit's t is always finite: a box entered before -FLT_MAX
 * (possible with tmin = -INFINITY) reports -FLT_MAX, and one reached only
 * beyond FLT_MAX or left before -FLT_MAX is a miss.
 */
typedef struct aacbvh_hit {
    float t;
    float u;
    float v;
    uint32_t prim_id;
} aacbvh_hit;

/**
 * Closest hit of each of `count` rays. Triangles are two-sided and tested
 * watertight (Woop, Benthin, Wald 2013): a ray through a shared edge or
 * vertex of a closed mesh hits it; triangles of zero area are never hit.
 *
 * Accuracy (since 1.1.0): a triangle hit's t is the distance along the ray to
 * the triangle's plane, computed in double precision from the float inputs
 * and rounded to float once: |t - t_exact| <= 2^-23 |t_exact| + 2^-46 (L +
 * E^2 / h) / (|dir| |cos theta|), where t_exact is the exact distance to the
 * plane, L the largest distance from the ray origin to a vertex of the
 * triangle, E its longest edge, h its smallest height (that term matters only
 * for slivers) and theta the angle between the ray and the triangle's normal.
 * In practice t is within an ulp of t_exact, also for short rays towards
 * large triangles. Exception: a ray that passes within about 1e-5 L of an
 * edge of the triangle may be counted as a hit although it misses it by that
 * much (this is what keeps meshes watertight); if it also grazes the plane,
 * its t is kept where the ray is inside the triangle's bounding box. The hit
 * is the nearest triangle unless another lies within that tolerance of it.
 * Of hits at exactly the same t, the one with the smaller prim_id is
 * reported, in every layout, storage and thread count.
 *
 * Directions: any finite, non-zero direction, of any length from the
 * smallest denormal to FLT_MAX, hits what its normalised twin hits, with t in
 * units of the direction given, wherever that t fits a float (a direction
 * far from unit length is scaled by a power of two inside, exactly). A zero
 * direction misses everything.
 *
 * Returns AACBVH_OK, AACBVH_ERROR_INVALID_ARGUMENT (NULL with count > 0) or
 * AACBVH_ERROR_INVALID_OPERATION (no valid tree). Thread-safe on a built BVH.
 * The caller owns both arrays; they are used only during the call, which runs
 * on the context's threads.
 */
AACBVH_API aacbvh_status aacbvh_bvh_intersect(const aacbvh_bvh *bvh, const aacbvh_ray *rays,
                                              aacbvh_hit *hits, size_t count);
/**
 * Any hit of each of `count` rays: out[i] = 1 if something lies within
 * [tmin, tmax] of ray i, else 0. Same returns and thread safety as
 * aacbvh_bvh_intersect().
 */
AACBVH_API aacbvh_status aacbvh_bvh_occluded(const aacbvh_bvh *bvh, const aacbvh_ray *rays,
                                             uint8_t *out, size_t count);

#ifdef __cplusplus
}
#endif

#endif /* AACBVH_AACBVH_H */
