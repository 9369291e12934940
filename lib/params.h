// A BVH handle's parameters with their defaults and valid ranges.
#pragma once

#include <cstdint>

#include "aacbvh/aacbvh.h"
#include "build/aac/aac_builder.h"

namespace aacbvh {

struct Params {
    Params();

    aacbvh_builder builder = AACBVH_BUILDER_AAC_HQ;
    AacConfig aac; ///< the builder's preset (builder_table.h) or the caller's values
    uint32_t max_leaf_size = 4;
    double traversal_cost = 1.2;
    double intersection_cost = 1.0;
    uint32_t ploc_radius = 16;
    bool skip_invalid = false;
    aacbvh_layout layout = AACBVH_LAYOUT_WIDE8;
    aacbvh_triangle_storage triangle_storage = AACBVH_TRIANGLES_COPIED;
    bool keep_build_memory = false;
    uint32_t optimize_passes = 0; ///< AACBVH_PARAM_OPTIMIZE_PASSES

    /// Throw Error(AACBVH_ERROR_INVALID_ARGUMENT) for unknown keys, a key of the
    /// other type, or values out of range; then nothing changes.
    /// Keys are plain integers: a C caller may pass any value, and loading an
    /// out-of-range value as the C++ enum type would be undefined behaviour.
    void set_int(int32_t key, int64_t value);
    void set_float(int32_t key, double value);
    int64_t get_int(int32_t key) const;
    double get_float(int32_t key) const;
};

} // namespace aacbvh
