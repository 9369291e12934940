// Axis-aligned bounding box in single precision, the unit every builder works on.
#pragma once

#include <algorithm>
#include <cfloat>
#include <cmath>

namespace aacbvh {

struct Box {
    float lo[3];
    float hi[3];

    /// An empty box: extending it by anything gives that thing.
    static Box empty() { return Box{{FLT_MAX, FLT_MAX, FLT_MAX}, {-FLT_MAX, -FLT_MAX, -FLT_MAX}}; }

    void extend(const Box &b) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], b.lo[k]);
            hi[k] = std::max(hi[k], b.hi[k]);
        }
    }
    void extend(const float p[3]) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], p[k]);
            hi[k] = std::max(hi[k], p[k]);
        }
    }
    bool is_empty() const { return lo[0] > hi[0] || lo[1] > hi[1] || lo[2] > hi[2]; }
    float extent(int k) const { return hi[k] - lo[k]; }
    /// Halves first so that boxes near FLT_MAX do not overflow.
    float centroid(int k) const { return 0.5f * lo[k] + 0.5f * hi[k]; }

    /// Half the surface area (the SAH only needs ratios); 0 for an empty box.
    float half_area() const { return is_empty() ? 0.0f : half_area_of_filled(); }
    /// half_area() of a box known not to be empty (a tree's: a primitive's,
    /// or a union of them), without the test.
    float half_area_of_filled() const {
        const float dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
        return dx * dy + dy * dz + dz * dx;
    }
    /// Full surface area in double precision, for reported SAH costs.
    double area() const {
        if (is_empty()) return 0.0;
        const double dx = double(hi[0]) - lo[0], dy = double(hi[1]) - lo[1], dz = double(hi[2]) - lo[2];
        return 2.0 * (dx * dy + dy * dz + dz * dx);
    }
    bool contains(const Box &b) const {
        for (int k = 0; k < 3; ++k)
            if (b.lo[k] < lo[k] || b.hi[k] > hi[k]) return false;
        return true;
    }
};

/// a.extend(b)'s box written into `out` a component at a time (out may be a
/// or b). Where the union goes straight into an array that is read a float at
/// a time, this spares the copy of a union made in the stack, which wider
/// loads read back than its stores (docs/PERFORMANCE.md, row 241).
inline void write_union(Box &out, const Box &a, const Box &b) {
    for (int k = 0; k < 3; ++k) {
        out.lo[k] = std::min(a.lo[k], b.lo[k]);
        out.hi[k] = std::max(a.hi[k], b.hi[k]);
    }
}

inline Box unite(const Box &a, const Box &b) {
    Box r;
    write_union(r, a, b);
    return r;
}

/// A power of two that brings the largest extent of `bounds` (a scene's) to
/// [0.5, 1); 1 for an empty, flat-point or infinite one. Areas of extents
/// scaled by it stay in single precision's range for any scene (coordinates
/// near 1e30 have areas near 1e60, near 1e-30 areas near 1e-60), and,
/// multiplying exactly, a scene scaled by a power of two has the same scaled
/// areas bit for bit. At most 2^126, the largest finite power of two that
/// keeps headroom: a denormal extent (below 2^-126) is brought above 2^-24,
/// not to [0.5, 1), where 2^-exponent itself would be infinite.
inline float extent_scale_of(const Box &bounds) {
    const float largest = std::max({bounds.extent(0), bounds.extent(1), bounds.extent(2)});
    if (!(largest > 0.0f) || !std::isfinite(largest)) return 1.0f;
    int exponent = 0;
    std::frexp(largest, &exponent);
    return std::ldexp(1.0f, std::min(-exponent, 126));
}

/// Half surface area of a filled box (see Box::half_area_of_filled()) whose
/// extents are first multiplied by `scale` (extent_scale_of()).
inline float scaled_half_area(const Box &b, float scale) {
    const float dx = (b.hi[0] - b.lo[0]) * scale, dy = (b.hi[1] - b.lo[1]) * scale, dz = (b.hi[2] - b.lo[2]) * scale;
    return dx * dy + dy * dz + dz * dx;
}

/// Half surface area of the union of two boxes: AAC's cluster distance d(A, B).
inline float union_half_area(const Box &a, const Box &b) {
    const float dx = std::max(a.hi[0], b.hi[0]) - std::min(a.lo[0], b.lo[0]);
    const float dy = std::max(a.hi[1], b.hi[1]) - std::min(a.lo[1], b.lo[1]);
    const float dz = std::max(a.hi[2], b.hi[2]) - std::min(a.lo[2], b.lo[2]);
    return dx * dy + dy * dz + dz * dx;
}

/// 1 / largest extent of a scene's bounds: clustering distances computed on
/// extents times this are of about unit size, so neither 1e30 nor 1e-30
/// coordinates leave the float range. 1 for an empty, flat-point or infinite
/// scene; at most FLT_MAX (an extent of a few denormals would give +inf, and
/// inf * 0 distances that are NaN).
inline float distance_scale(const Box &bounds) {
    const double extent = std::max({double(bounds.hi[0]) - bounds.lo[0], double(bounds.hi[1]) - bounds.lo[1],
                                    double(bounds.hi[2]) - bounds.lo[2]});
    if (!(extent > 0.0) || !std::isfinite(extent)) return 1.0f;
    return float(std::min(1.0 / extent, double(FLT_MAX)));
}

/// AAC's cluster distance d(A, B) as every clustering builder computes it:
/// union_half_area on extents scaled by `scale` (distance_scale()). The one
/// overflow rule: a distance that leaves the float range (a scene wider than
/// FLT_MAX overflows its extents; inf * 0 is NaN) is FLT_MAX, so distances
/// are totally ordered and always below the +inf that marks "no candidate".
/// The SIMD rows of build/aac/distance_row.h follow it bit for bit.
inline float scaled_union_half_area(const Box &a, const Box &b, float scale) {
    const float dx = (std::max(a.hi[0], b.hi[0]) - std::min(a.lo[0], b.lo[0])) * scale;
    const float dy = (std::max(a.hi[1], b.hi[1]) - std::min(a.lo[1], b.lo[1])) * scale;
    const float dz = (std::max(a.hi[2], b.hi[2]) - std::min(a.lo[2], b.lo[2])) * scale;
    const float d = dx * dy + dy * dz + dz * dx;
    return d <= FLT_MAX ? d : FLT_MAX; // NaN compares false: FLT_MAX too
}

} // namespace aacbvh
