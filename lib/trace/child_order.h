// The order in which closest-hit traversals visit the children a ray hits,
// the same rule in every layout and kernel (the binary traversal, WIDE4,
// and WIDE8's scalar, SSE2 and AVX2 kernels):
//
// - children are taken by increasing entry distance (clipped to the ray's
//   tmin), so the first hit found tends to be the nearest and prunes the
//   rest;
// - a child whose box holds the ray's origin, for a window that starts at 0
//   or later (its entry distance is tmin itself), comes before every child
//   entered later, and such children go by increasing exit distance: along
//   the ray, the part of a box ahead of the origin ends at its exit, so the
//   box left sooner holds the nearer hits. Rays that start on a surface or
//   inside a room are inside several boxes at every level; ordering them by
//   size instead (the rule before) sent diffuse rays into boxes that reach
//   far ahead and found far hits that later ones replaced
//   (docs/PERFORMANCE.md, row 171);
// - equal keys: the smaller box first (the wide layouts' higher lane,
//   bvh/wide_collapse.h; the binary layout compares areas).
//
// The order decides the work, never the answer: the closest hit and its tie
// rule on equal distances do not depend on it (trace/hit_record.h).
//
// The wide layouts' node tests return the key in place of the entry
// distance for the children they find inside, so the stack entries carry
// it: pruning compares it with the closest hit so far, and an inside key
// (negative, below tmin) is never pruned, as the entry distance tmin it
// stands for would not be (tmin <= tmax). The binary traversal orders its
// two children by the keys and keeps their entries for pruning.
#pragma once

#include <cstdint>
#include <cstring>

namespace aacbvh {

/// The key of a child whose box holds the origin of a ray whose window
/// starts at 0 or later: a negative float, so it orders before every entry
/// distance of a child entered later (those are above tmin >= 0), and one
/// that increases with `exit` (0 to +inf for a hit child; its sign is
/// dropped, so that the -0 exit of a box ending exactly at the origin counts
/// as 0: its key must stay below tmin, the keys being the pruning bounds):
/// its bits are 0xFF800000 minus those of |exit|, from -inf for an exit of 0
/// to -0 for an infinite one. The SIMD kernels compute the same bits with an
/// integer and and subtraction per lane.
inline float inside_order_key(float exit) {
    uint32_t u;
    std::memcpy(&u, &exit, sizeof u);
    u = 0xFF800000u - (u & 0x7FFFFFFFu);
    float key;
    std::memcpy(&key, &u, sizeof key);
    return key;
}

/// The visiting key of a child hit by a ray whose window starts at tmin >= 0:
/// its entry distance, or inside_order_key(exit) when the entry is tmin (the
/// origin lies in the box).
inline float child_order_key(float entry, float exit, float tmin) {
    return entry <= tmin ? inside_order_key(exit) : entry;
}

} // namespace aacbvh
