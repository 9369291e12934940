// Checks the caller's geometry and computes the per-primitive boxes every
// builder starts from. Invalid primitives (NaN or infinite coordinates, vertex
// indices out of range, boxes with min > max) fail the build with a message
// naming the first one, or are left out when the caller asked for that.
#include <cmath>
#include <string>

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

void compute_build_input(const Geometry &geometry, bool skip_invalid, BuildContext &ctx, BuildInput &input) {
    const size_t n = geometry.primitive_count;
    input.boxes.resize(n);
    input.prim_ids.resize(n);

    // One parallel pass: boxes in input order, and per chunk the bounds and
    // the invalid primitives (the split is fixed, so results do not depend on
    // the thread count).
    const ChunkSummary all = ctx.scheduler().parallel_reduce(
        size_t(0), n, kGrain, ChunkSummary{},
        [&](size_t b, size_t e) {
            ChunkSummary s;
            for (size_t i = b; i < e; ++i) {
                if (primitive_problem(geometry, i)) {
                    if (s.first_invalid == SIZE_MAX) s.first_invalid = i;
                    ++s.invalid;
                    input.prim_ids[i] = UINT32_MAX;
                    continue;
                }
                const Box box = geometry.primitive_box(i);
                input.boxes[i] = box;
                input.prim_ids[i] = uint32_t(i);
                s.bounds.extend(box);
                const float c[3] = {box.centroid(0), box.centroid(1), box.centroid(2)};
                s.centroid_bounds.extend(c);
            }
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
        for (size_t i = 0; i < n; ++i) {
            if (input.prim_ids[i] == UINT32_MAX) continue;
            input.boxes[out] = input.boxes[i];
            input.prim_ids[out] = input.prim_ids[i];
            ++out;
        }
        input.boxes.resize(out);
        input.prim_ids.resize(out);
    }
    input.bounds = all.bounds;
    input.centroid_bounds = all.centroid_bounds;
    input.invalid_count = all.invalid;
}

void gather_leaves(const BuildInput &input, const uint32_t *order, Scheduler &scheduler, BinaryTree &out) {
    scheduler.parallel_for(0, out.leaf_count(), kGrain, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            out.boxes[i] = input.boxes[order[i]];
            out.prim_ids[i] = input.prim_ids[order[i]];
        }
    });
}

} // namespace aacbvh
