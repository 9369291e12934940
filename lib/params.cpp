#include "params.h"

#include <cmath>
#include <string>

#include "builder_table.h"
#include "core/error.h"

namespace aacbvh {

namespace {

[[noreturn]] void reject(const std::string &what) { throw Error(AACBVH_ERROR_INVALID_ARGUMENT, what); }

/// Largest SAH cost constant: with 2^31 primitives the normalised SAH cost
/// stays below 1e41, finite in double (the reported stats).
constexpr double kMaxCost = 1e30;

bool is_int_key(int32_t key) {
    switch (key) {
    case AACBVH_PARAM_BUILDER:
    case AACBVH_PARAM_AAC_DELTA:
    case AACBVH_PARAM_MAX_LEAF_SIZE:
    case AACBVH_PARAM_PLOC_RADIUS:
    case AACBVH_PARAM_SKIP_INVALID_PRIMITIVES:
    case AACBVH_PARAM_TRAVERSAL_LAYOUT:
    case AACBVH_PARAM_TRIANGLE_STORAGE:
    case AACBVH_PARAM_KEEP_BUILD_MEMORY:
    case AACBVH_PARAM_OPTIMIZE_PASSES:
        return true;
    default:
        return false;
    }
}

bool is_float_key(int32_t key) {
    switch (key) {
    case AACBVH_PARAM_AAC_C:
    case AACBVH_PARAM_AAC_ALPHA:
    case AACBVH_PARAM_TRAVERSAL_COST:
    case AACBVH_PARAM_INTERSECTION_COST:
        return true;
    default:
        return false;
    }
}

void check_key_type(int32_t key, bool want_int) {
    if (is_int_key(key) == want_int && (want_int || is_float_key(key))) return;
    if (is_int_key(key) || is_float_key(key))
        reject("parameter " + std::to_string(int(key)) + " is " + (want_int ? "a float" : "an integer") +
               " parameter; use aacbvh_bvh_" + (want_int ? "set/get_param_float" : "set/get_param_int"));
    reject("unknown parameter " + std::to_string(int64_t(key)));
}

} // namespace

Params::Params() : aac(find_builder(AACBVH_BUILDER_AAC_HQ)->preset()) {}

void Params::set_int(int32_t key, int64_t value) {
    check_key_type(key, true);
    switch (key) {
    case AACBVH_PARAM_BUILDER:
    {
        size_t count;
        builder_table(count);
        const BuilderInfo *info = find_builder(value);
        if (!info)
            reject("builder " + std::to_string(value) + " is not an aacbvh_builder value (0 to " +
                   std::to_string(count - 1) + ")");
        builder = info->value;
        if (info->preset) aac = info->preset();
        if (builder == AACBVH_BUILDER_AAC) { // the paper's AAC with the values in force
            aac.use_paper_rules();
        }
        break;
    }
    case AACBVH_PARAM_AAC_DELTA:
        if (value < 2 || value > (1 << 20)) reject("AAC delta must be in [2, 2^20], got " + std::to_string(value));
        aac.delta = uint32_t(value);
        builder = AACBVH_BUILDER_AAC;
        aac.use_paper_rules();
        break;
    case AACBVH_PARAM_MAX_LEAF_SIZE:
        if (value < 1 || value > (1 << 16)) reject("max leaf size must be in [1, 65536], got " + std::to_string(value));
        max_leaf_size = uint32_t(value);
        break;
    case AACBVH_PARAM_PLOC_RADIUS:
        if (value < 1 || value > 1024) reject("PLOC radius must be in [1, 1024], got " + std::to_string(value));
        ploc_radius = uint32_t(value);
        break;
    case AACBVH_PARAM_SKIP_INVALID_PRIMITIVES:
        if (value != 0 && value != 1) reject("skip-invalid must be 0 or 1, got " + std::to_string(value));
        skip_invalid = value == 1;
        break;
    case AACBVH_PARAM_TRAVERSAL_LAYOUT:
        if (value != AACBVH_LAYOUT_BINARY && value != AACBVH_LAYOUT_WIDE4 && value != AACBVH_LAYOUT_WIDE8)
            reject("traversal layout must be AACBVH_LAYOUT_BINARY (0), AACBVH_LAYOUT_WIDE4 (1) or "
                   "AACBVH_LAYOUT_WIDE8 (2), got " +
                   std::to_string(value));
        layout = aacbvh_layout(value);
        break;
    case AACBVH_PARAM_TRIANGLE_STORAGE:
        if (value != AACBVH_TRIANGLES_REFERENCED && value != AACBVH_TRIANGLES_COPIED)
            reject("triangle storage must be AACBVH_TRIANGLES_REFERENCED (0) or AACBVH_TRIANGLES_COPIED (1), got " +
                   std::to_string(value));
        triangle_storage = aacbvh_triangle_storage(value);
        break;
    case AACBVH_PARAM_KEEP_BUILD_MEMORY:
        if (value != 0 && value != 1) reject("keep-build-memory must be 0 or 1, got " + std::to_string(value));
        keep_build_memory = value == 1;
        break;
    case AACBVH_PARAM_OPTIMIZE_PASSES:
        if (value < 0 || value > AACBVH_MAX_OPTIMIZE_PASSES)
            reject("optimize passes must be in [0, " + std::to_string(AACBVH_MAX_OPTIMIZE_PASSES) + "], got " +
                   std::to_string(value));
        optimize_passes = uint32_t(value);
        break;
    default:
        reject("unknown parameter");
    }
}

void Params::set_float(int32_t key, double value) {
    check_key_type(key, false);
    if (!std::isfinite(value)) reject("parameter value must be finite");
    switch (key) {
    case AACBVH_PARAM_AAC_C:
        if (!(value > 0.0)) reject("AAC c must be > 0, got " + std::to_string(value));
        aac.c = value;
        builder = AACBVH_BUILDER_AAC;
        aac.use_paper_rules();
        break;
    case AACBVH_PARAM_AAC_ALPHA:
        if (!(value > 0.0 && value <= 1.0)) reject("AAC alpha must be in (0, 1], got " + std::to_string(value));
        aac.alpha = value;
        builder = AACBVH_BUILDER_AAC;
        aac.use_paper_rules();
        break;
    case AACBVH_PARAM_TRAVERSAL_COST:
        if (!(value > 0.0 && value <= kMaxCost))
            reject("traversal cost must be in (0, 1e30], got " + std::to_string(value));
        traversal_cost = value;
        break;
    case AACBVH_PARAM_INTERSECTION_COST:
        if (!(value > 0.0 && value <= kMaxCost))
            reject("intersection cost must be in (0, 1e30], got " + std::to_string(value));
        intersection_cost = value;
        break;
    default:
        reject("unknown parameter");
    }
}

int64_t Params::get_int(int32_t key) const {
    check_key_type(key, true);
    switch (key) {
    case AACBVH_PARAM_BUILDER: return builder;
    case AACBVH_PARAM_AAC_DELTA: return aac.delta;
    case AACBVH_PARAM_MAX_LEAF_SIZE: return max_leaf_size;
    case AACBVH_PARAM_PLOC_RADIUS: return ploc_radius;
    case AACBVH_PARAM_SKIP_INVALID_PRIMITIVES: return skip_invalid ? 1 : 0;
    case AACBVH_PARAM_TRAVERSAL_LAYOUT: return layout;
    case AACBVH_PARAM_TRIANGLE_STORAGE: return triangle_storage;
    case AACBVH_PARAM_KEEP_BUILD_MEMORY: return keep_build_memory ? 1 : 0;
    case AACBVH_PARAM_OPTIMIZE_PASSES: return optimize_passes;
    default: reject("unknown parameter");
    }
}

double Params::get_float(int32_t key) const {
    check_key_type(key, false);
    switch (key) {
    case AACBVH_PARAM_AAC_C: return aac.c;
    case AACBVH_PARAM_AAC_ALPHA: return aac.alpha;
    case AACBVH_PARAM_TRAVERSAL_COST: return traversal_cost;
    case AACBVH_PARAM_INTERSECTION_COST: return intersection_cost;
    default: reject("unknown parameter");
    }
}

} // namespace aacbvh
