// A BuildInput over boxes given directly, for the C++ unit tests of lib/
// internals that run a builder or the Morton sort without a geometry: entry i
// bounds boxes[i], and its caller-side primitive index is prim_id(i) (i
// unless the test asks for another, to catch a builder that forgets to map
// indices).
#pragma once

#include <cstdint>
#include <vector>

#include "build/build_input.h"

namespace aacbvh_test {

template <class PrimId>
aacbvh::BuildInput box_input(const std::vector<aacbvh::Box> &boxes, PrimId prim_id) {
    aacbvh::BuildInput in;
    in.boxes.assign(boxes.begin(), boxes.end());
    in.prim_ids.resize(boxes.size());
    for (uint32_t i = 0; i < boxes.size(); ++i) {
        in.prim_ids[i] = prim_id(i);
        in.bounds.extend(boxes[i]);
        const float c[3] = {boxes[i].centroid(0), boxes[i].centroid(1), boxes[i].centroid(2)};
        in.centroid_bounds.extend(c);
    }
    return in;
}

inline aacbvh::BuildInput box_input(const std::vector<aacbvh::Box> &boxes) {
    return box_input(boxes, [](uint32_t i) { return i; });
}

} // namespace aacbvh_test
