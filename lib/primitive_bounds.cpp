// Checks the caller's geometry and computes the per-primitive boxes every
// builder starts from. Invalid primitives (NaN or infinite coordinates, vertex
// indices out of range, boxes with min > max) fail the build with a message
// naming the first one, or are left out when the caller asked for that.
#include <cmath>
#include <string>

#include "build_input.h"
#include "error.h"

namespace aacbvh {

namespace {

bool finite3(const float *p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

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
    input.boxes.clear();
    input.prim_ids.clear();
    input.boxes.reserve(n);
    input.prim_ids.reserve(n);
    input.bounds = Box::empty();
    input.centroid_bounds = Box::empty();
    input.invalid_count = 0;
    for (size_t i = 0; i < n; ++i) {
        if (const char *why = primitive_problem(geometry, i)) {
            if (!skip_invalid) {
                const char *kind = geometry.kind == GeometryKind::Boxes ? "box " : "triangle ";
                throw Error(AACBVH_ERROR_INVALID_GEOMETRY, kind + std::to_string(i) + " " + why);
            }
            ++input.invalid_count;
            continue;
        }
        const Box b = geometry.primitive_box(i);
        input.boxes.push_back(b);
        input.prim_ids.push_back(uint32_t(i));
        input.bounds.extend(b);
        const float c[3] = {b.centroid(0), b.centroid(1), b.centroid(2)};
        input.centroid_bounds.extend(c);
        if ((i & 0xFFFF) == 0xFFFF) ctx.check_cancelled();
    }
}

} // namespace aacbvh
