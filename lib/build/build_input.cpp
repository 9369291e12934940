// Checks the caller's geometry and computes the per-primitive boxes every
// builder starts from. Invalid primitives (NaN or infinite coordinates, vertex
// indices out of range, boxes with min > max) fail the build with a message
// naming the first one, or are left out when the caller asked for that.
#include <cmath>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "build/build_input.h"
#include "core/error.h"

namespace aacbvh {

namespace {

bool finite3(const float *p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

/// What one chunk of primitives contributes; joined left to right.
struct ChunkSummary {
    Box bounds = Box::empty();
    Box centroid_bounds = Box::empty();
    size_t first_invalid = SIZE_MAX;
    size_t invalid = 0;
};

ChunkSummary join(const ChunkSummary &a, const ChunkSummary &b) {
    ChunkSummary r;
    r.bounds = unite(a.bounds, b.bounds);
    r.centroid_bounds = unite(a.centroid_bounds, b.centroid_bounds);
    r.first_invalid = a.first_invalid != SIZE_MAX ? a.first_invalid : b.first_invalid;
    r.invalid = a.invalid + b.invalid;
    return r;
}

constexpr size_t kGrain = 1u << 14;

} // namespace

const char *primitive_problem(const Geometry &g, size_t i) {
    if (g.kind == GeometryKind::Boxes) {
        const float *b = g.box_ptr(i);
        if (!finite3(b) || !finite3(b + 3)) return "has a NaN or infinite coordinate";
        if (b[0] > b[3] || b[1] > b[4] || b[2] > b[5]) return "has min > max";
        return nullptr;
    }
    uint32_t idx[3];
    g.triangle_indices(i, idx);
    for (uint32_t k : idx)
        if (k >= g.vertex_count) return "has a vertex index out of range";
    for (uint32_t k : idx)
        if (!finite3(g.vertex(k))) return "has a NaN or infinite vertex coordinate";
    return nullptr;
}

namespace {

/// One primitive the general way: its problem, or its box and centroid
/// added to the chunk's bounds.
inline void add_primitive(const Geometry &geometry, size_t i, BuildInput &input, ChunkSummary &s) {
    if (primitive_problem(geometry, i)) {
        if (s.first_invalid == SIZE_MAX) s.first_invalid = i;
        ++s.invalid;
        input.prim_ids[i] = UINT32_MAX;
        return;
    }
    const Box box = geometry.primitive_box(i);
    input.boxes[input.box_offset + i] = box;
    input.prim_ids[i] = uint32_t(i);
    s.bounds.extend(box);
    const float c[3] = {box.centroid(0), box.centroid(1), box.centroid(2)};
    s.centroid_bounds.extend(c);
}

ChunkSummary any_chunk(const Geometry &geometry, size_t b, size_t e, BuildInput &input) {
    ChunkSummary s;
    for (size_t i = b; i < e; ++i) add_primitive(geometry, i, input, s);
    return s;
}

#if defined(__SSE2__)
/// A vertex as (x, y, z, 0), read without touching the bytes after it.
/// MOVLPS reads and writes 8 bytes at any float's alignment (a vertex stride
/// of 12 leaves them 4-byte aligned, which a double load would not allow).
inline __m128 load_vertex(const float *p) {
    return _mm_movelh_ps(_mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64 *>(p)), _mm_load_ss(p + 2));
}

inline void store_xyz(float *out, __m128 v) {
    _mm_storel_pi(reinterpret_cast<__m64 *>(out), v);
    _mm_store_ss(out + 2, _mm_movehl_ps(v, v));
}

/// Triangles, the common case, a triangle at a time in SSE registers: the
/// three indices checked against the vertex count at once, the vertices'
/// finiteness by one sum of (v - v) (0 for finite coordinates, NaN for an
/// infinite or NaN one), then the box, its centroid and the chunk's bounds
/// by the same min / max / multiply / add as add_primitive() (MINPS(p, lo) is
/// std::min(lo, p) lane by lane, signed zeros included), so the same bits.
/// A triangle that fails either check goes the general way, which names its
/// problem.
ChunkSummary triangle_chunk(const Geometry &geometry, size_t b, size_t e, BuildInput &input) {
    ChunkSummary s;
    const __m128 half = _mm_set1_ps(0.5f);
    __m128 lo_all = _mm_set1_ps(FLT_MAX), hi_all = _mm_set1_ps(-FLT_MAX);
    __m128 clo_all = lo_all, chi_all = hi_all;
    const uint32_t vertex_count = uint32_t(std::min<size_t>(geometry.vertex_count, UINT32_MAX));
    const bool all_fit = geometry.vertex_count <= UINT32_MAX;
    // A local copy and local pointers: the stores below go through types the
    // compiler must assume may alias the caller's geometry and the arrays.
    const Geometry g = geometry;
    Box *const boxes = input.boxes.data() + input.box_offset;
    uint32_t *const prim_ids = input.prim_ids.data();
    for (size_t i = b; i < e; ++i) {
        uint32_t idx[3];
        g.triangle_indices(i, idx);
        const bool in_range = all_fit ? (idx[0] < vertex_count) & (idx[1] < vertex_count) & (idx[2] < vertex_count)
                                      : true;
        if (!in_range) {
            add_primitive(geometry, i, input, s);
            continue;
        }
        const __m128 v0 = load_vertex(g.vertex(idx[0]));
        const __m128 v1 = load_vertex(g.vertex(idx[1]));
        const __m128 v2 = load_vertex(g.vertex(idx[2]));
        const __m128 finite = _mm_add_ps(_mm_add_ps(_mm_sub_ps(v0, v0), _mm_sub_ps(v1, v1)), _mm_sub_ps(v2, v2));
        if (_mm_movemask_ps(_mm_cmpneq_ps(finite, _mm_setzero_ps())) != 0) {
            add_primitive(geometry, i, input, s);
            continue;
        }
        const __m128 lo = _mm_min_ps(v2, _mm_min_ps(v1, v0));
        const __m128 hi = _mm_max_ps(v2, _mm_max_ps(v1, v0));
        store_xyz(boxes[i].lo, lo);
        store_xyz(boxes[i].hi, hi);
        prim_ids[i] = uint32_t(i);
        lo_all = _mm_min_ps(lo, lo_all);
        hi_all = _mm_max_ps(hi, hi_all);
        const __m128 c = _mm_add_ps(_mm_mul_ps(half, lo), _mm_mul_ps(half, hi));
        clo_all = _mm_min_ps(c, clo_all);
        chi_all = _mm_max_ps(c, chi_all);
    }
    // Only invalid triangles went the general way, and they extend nothing:
    // the chunk's bounds are the registers'.
    Box fast;
    store_xyz(fast.lo, lo_all);
    store_xyz(fast.hi, hi_all);
    Box fast_c;
    store_xyz(fast_c.lo, clo_all);
    store_xyz(fast_c.hi, chi_all);
    s.bounds.extend(fast);
    s.centroid_bounds.extend(fast_c);
    return s;
}
#else
ChunkSummary triangle_chunk(const Geometry &geometry, size_t b, size_t e, BuildInput &input) {
    return any_chunk(geometry, b, e, input);
}
#endif

} // namespace

void compute_build_input(const Geometry &geometry, bool skip_invalid, BuildContext &ctx, BuildInput &input,
                         InputPath path, InputRoom room) {
    const size_t n = geometry.primitive_count;
    input.box_offset = room == InputRoom::Tree ? n : 0;
    input.boxes.resize(input.box_offset + n);
    input.prim_ids.resize(n);

    // One parallel pass: boxes in input order, and per chunk the bounds and
    // the invalid primitives (the split is fixed, so results do not depend on
    // the thread count).
    const ChunkSummary all = ctx.scheduler().parallel_reduce(
        size_t(0), n, kGrain, ChunkSummary{},
        [&](size_t b, size_t e) {
            const bool fast = path == InputPath::Fastest && geometry.kind == GeometryKind::Triangles;
            ChunkSummary s = fast ? triangle_chunk(geometry, b, e, input) : any_chunk(geometry, b, e, input);
            ctx.check_cancelled();
            return s;
        },
        join);

    if (all.invalid > 0 && !skip_invalid) {
        const char *kind = geometry.kind == GeometryKind::Boxes ? "box " : "triangle ";
        throw Error(AACBVH_ERROR_INVALID_GEOMETRY, kind + std::to_string(all.first_invalid) + " " +
                                                       primitive_problem(geometry, all.first_invalid));
    }
    if (all.invalid > 0) { // rare: squeeze the invalid ones out, keeping the order
        size_t out = 0;
        Box *const boxes = input.boxes.data() + input.box_offset;
        for (size_t i = 0; i < n; ++i) {
            if (input.prim_ids[i] == UINT32_MAX) continue;
            boxes[out] = boxes[i];
            input.prim_ids[out] = input.prim_ids[i];
            ++out;
        }
        input.boxes.resize(input.box_offset + out);
        input.prim_ids.resize(out);
    }
    input.bounds = all.bounds;
    input.centroid_bounds = all.centroid_bounds;
    input.invalid_count = all.invalid;
    input.identity_ids = all.invalid == 0; // entry i is primitive i unless some were squeezed out
}

void gather_leaves(const BuildInput &input, const uint32_t *order, Scheduler &scheduler, BinaryTree &out) {
    gather_leaves(input.boxes.data() + input.box_offset, input_prim_ids(input), order, scheduler, out);
}

const uint32_t *input_prim_ids(const BuildInput &input) {
    return input.identity_ids ? nullptr : input.prim_ids.data();
}

void gather_leaves(const Box *boxes, const uint32_t *prim_ids, const uint32_t *order, Scheduler &scheduler,
                   BinaryTree &out) {
    Box *const leaves = out.boxes.data();
    uint32_t *const leaf_prims = out.prim_ids.data();
    // The sorted order scatters the reads: asked for kAhead places early.
    // Without prim_ids (the identity) a leaf's index is the order's entry,
    // read in sequence; where `order` is out.prim_ids that rewrites it as is.
    constexpr size_t kAhead = 16;
    scheduler.parallel_for(0, out.leaf_count(), kGrain, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            if (i + kAhead < e) {
                __builtin_prefetch(&boxes[order[i + kAhead]]);
                if (prim_ids != nullptr) __builtin_prefetch(&prim_ids[order[i + kAhead]]);
            }
            const uint32_t o = order[i];
            leaves[i] = boxes[o];
            leaf_prims[i] = prim_ids != nullptr ? prim_ids[o] : o;
        }
    });
}

} // namespace aacbvh
