// What every traversal (binary, wide, and any kernel to come) does the same
// way: test a leaf's primitives against the ray and keep the closest hit, and
// pop the next pending node that can still hold a closer one. Kept in one
// place so that every layout answers alike.
//
// The tie rule: of hits at exactly the same distance t, the one with the
// smaller prim_id wins. Nodes are skipped only when they cannot hold a hit at
// or before the current t, and a primitive's t does not depend on the window
// it is tested in, so the answer does not depend on the order in which nodes
// or leaves are visited: every layout, thread count and kernel gives the same
// prim_id, also on stacks of coplanar triangles.
#pragma once

#include <cmath>
#include <cstdint>

#include "aacbvh/aacbvh.h"
#include "trace/ray_box.h"

namespace aacbvh {

/// The closest hit of one ray so far (AnyHit false), or whether any hit was
/// found (AnyHit true, which stops at the first).
template <bool AnyHit> struct HitRecord {
    explicit HitRecord(float ray_tmax) : tmax(ray_tmax), reach_(exit_reach(ray_tmax)) {}

    float tmax;                          ///< the ray's tmax, then the closest hit's t
    float u = 0.0f, v = 0.0f;
    uint32_t prim = AACBVH_INVALID_ID;
    bool found = false;

    /// Tests leaf slots [first, first + count) (indices into prim_ids); true
    /// when the query is done (an any-hit query found something).
    template <class Primitives>
    bool test_leaf(const Primitives &prims, const uint32_t *prim_ids, uint32_t first, uint32_t count, float tmin) {
        const uint32_t end = first + count;
        for (uint32_t i = first; i < end; ++i) {
            float t, hu, hv;
            if (!prims.intersect(i, tmin, tmax, t, hu, hv)) continue;
            if (offer(t, hu, hv, prim_ids[i])) return true;
        }
        return false;
    }

    /// Takes a hit within [tmin, tmax] of primitive `id`: true when the
    /// query is done (any hit). Of hits at the same t the smaller id stays.
    bool offer(float t, float hu, float hv, uint32_t id) {
        if (AnyHit) {
            found = true;
            return true;
        }
        if (found && t == tmax && id > prim) return false; // the tie rule
        found = true;
        tmax = t;
        reach_ = exit_reach(t);
        u = hu;
        v = hv;
        prim = id;
        return false;
    }

    /// How far a pending node's entry distance may lie and still hold a hit
    /// at or before tmax: entry distances are rounded (up to 3 ulps late) and a
    /// primitive inside can lie nearer, so tmax is widened exactly as the node
    /// test widens its exit distance. A node is skipped only if the node test
    /// would now reject it too.
    /// Kept beside tmax (set where tmax changes), not computed at each pop.
    float reach() const { return reach_; }

    /// Pops `stack` until an entry (with entry distance .t) within reach();
    /// false when none is left.
    template <class Stack, class Entry> bool pop_next(Stack &stack, Entry &out) const {
        const float limit = reach();
        while (!stack.empty()) {
            const Entry e = stack.pop();
            if (e.t <= limit) {
                out = e;
                return true;
            }
        }
        return false;
    }

private:
    float reach_; ///< exit_reach(tmax)
};

} // namespace aacbvh
