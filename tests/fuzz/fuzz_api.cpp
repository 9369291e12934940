// libFuzzer harness over the whole public C API (built by scripts/fuzz.sh,
// see tests/fuzz/CMakeLists.txt). Each input drives one BVH through:
// random parameters (out-of-range keys and values included), triangles or
// boxes with NaN / infinite / huge / tiny / denormal coordinates, out-of-range
// indices and odd strides, build, refit after moving vertices, random rays
// through intersect and occluded, and the stats / node / index queries.
// Besides the sanitizers it traps on any broken promise: statuses outside
// what the header lists, node count != 2 * leaves - 1, a primitive missing or
// repeated, a hit outside [tmin, tmax] or on an id out of range, an invalid
// ray that hits, occluded disagreeing with intersect.
#include <aacbvh/aacbvh.h>

#include <fuzzer/FuzzedDataProvider.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace {

#define FUZZ_CHECK(cond)                                                                                           \
    do {                                                                                                           \
        if (!(cond)) __builtin_trap();                                                                            \
    } while (0)

aacbvh_context *context(uint32_t threads) {
    static aacbvh_context *contexts[2] = {nullptr, nullptr};
    aacbvh_context *&c = contexts[threads - 1];
    if (!c && aacbvh_context_create(threads, &c) != AACBVH_OK) std::abort();
    return c;
}

float pick_float(FuzzedDataProvider &in) {
    static const float special[] = {0.0f,     -0.0f,  1.0f,    -1.0f,   NAN,     INFINITY, -INFINITY,
                                    1e30f,    -1e30f, 1e-30f,  -1e-30f, FLT_MAX, -FLT_MAX, FLT_MIN,
                                    1e-40f,   -1e-45f, 3e38f,  0.5f,    2.0f,    1e-7f,    16777216.0f};
    switch (in.ConsumeIntegralInRange<int>(0, 3)) {
    case 0: return special[in.ConsumeIntegralInRange<size_t>(0, sizeof special / sizeof special[0] - 1)];
    case 1: {
        uint32_t bits = in.ConsumeIntegral<uint32_t>();
        float f;
        std::memcpy(&f, &bits, sizeof f);
        return f;
    }
    default: return float(in.ConsumeIntegralInRange<int>(-8, 8)) * 0.25f;
    }
}

bool ray_valid(const aacbvh_ray &r) {
    for (int k = 0; k < 3; ++k)
        if (!std::isfinite(r.org[k]) || !std::isfinite(r.dir[k])) return false;
    if (std::isnan(r.tmin) || std::isnan(r.tmax)) return false;
    return r.dir[0] != 0.0f || r.dir[1] != 0.0f || r.dir[2] != 0.0f;
}

void set_params(FuzzedDataProvider &in, aacbvh_bvh *bvh) {
    const int count = in.ConsumeIntegralInRange<int>(0, 4);
    for (int i = 0; i < count; ++i) {
        // Keys past the last one too (negative ones cannot be made in C++
        // without undefined behaviour; the library reads keys as integers).
        static const int extra_keys[] = {10, 11, 1000, 0x7FFFFFFF};
        const int raw = in.ConsumeIntegralInRange<int>(0, 13);
        const aacbvh_param key = aacbvh_param(raw < 10 ? raw : extra_keys[raw - 10]);
        aacbvh_status s;
        if (in.ConsumeBool()) {
            int64_t value;
            switch (in.ConsumeIntegralInRange<int>(0, 2)) {
            case 0: value = in.ConsumeIntegralInRange<int64_t>(-2, 8); break;
            case 1: value = in.ConsumeIntegralInRange<int64_t>(0, 2000); break;
            default: value = in.ConsumeIntegral<int64_t>(); break;
            }
            s = aacbvh_bvh_set_param_int(bvh, key, value);
        } else {
            s = aacbvh_bvh_set_param_float(bvh, key, double(pick_float(in)));
        }
        FUZZ_CHECK(s == AACBVH_OK || s == AACBVH_ERROR_INVALID_ARGUMENT);
    }
}

/// The scene: the buffers the BVH references (they must outlive it).
struct Scene {
    bool boxes = false;
    std::vector<float> data;  ///< vertices or boxes, `stride` bytes apart
    std::vector<uint32_t> indices;
    bool indexed = false;
    size_t element_count = 0; ///< vertices or boxes
    size_t stride = 12;
    size_t primitive_count = 0;
    bool accepted = false;
};

void make_scene(FuzzedDataProvider &in, aacbvh_bvh *bvh, Scene &sc) {
    sc.boxes = in.ConsumeBool();
    sc.primitive_count = in.ConsumeIntegralInRange<size_t>(0, 48);
    const size_t floats_each = sc.boxes ? 6 : 3;
    static const size_t strides[] = {12, 16, 24, 28, 32, 0, 4, 13, 22, 26};
    sc.stride = in.ConsumeBool() ? floats_each * 4 : strides[in.ConsumeIntegralInRange<size_t>(0, 9)];
    sc.indexed = !sc.boxes && in.ConsumeBool();
    if (sc.boxes)
        sc.element_count = sc.primitive_count;
    else if (sc.indexed)
        sc.element_count = in.ConsumeIntegralInRange<size_t>(0, 3 * sc.primitive_count + 2);
    else
        sc.element_count = 3 * sc.primitive_count + in.ConsumeIntegralInRange<size_t>(0, 2);
    // Exactly the bytes the stride claims (rounded up to whole floats), so
    // ASan sees any read past them.
    const size_t stride_floats = (sc.stride + 3) / 4;
    sc.data.resize(sc.element_count * std::max<size_t>(stride_floats, floats_each));
    for (float &f : sc.data) f = pick_float(in);
    // Boxes mostly valid (min <= max), so builds get past the check.
    if (sc.boxes && stride_floats >= 6 && in.ConsumeBool())
        for (size_t i = 0; i < sc.element_count; ++i)
            for (int k = 0; k < 3; ++k) {
                float &lo = sc.data[i * stride_floats + k], &hi = sc.data[i * stride_floats + 3 + k];
                if (lo > hi) std::swap(lo, hi);
            }
    if (sc.indexed) {
        sc.indices.resize(3 * sc.primitive_count);
        for (uint32_t &x : sc.indices)
            x = in.ConsumeIntegralInRange<int>(0, 15) == 0
                    ? in.ConsumeIntegral<uint32_t>()
                    : uint32_t(in.ConsumeIntegralInRange<size_t>(0, sc.element_count ? sc.element_count - 1 : 0));
    }
    aacbvh_status s;
    if (sc.boxes)
        s = aacbvh_bvh_set_boxes(bvh, sc.data.empty() ? nullptr : sc.data.data(), sc.primitive_count, sc.stride);
    else
        s = aacbvh_bvh_set_triangles(bvh, sc.data.empty() ? nullptr : sc.data.data(), sc.element_count, sc.stride,
                                     sc.indexed ? sc.indices.data() : nullptr, sc.primitive_count);
    FUZZ_CHECK(s == AACBVH_OK || s == AACBVH_ERROR_INVALID_ARGUMENT);
    // Exactly the documented argument errors.
    const bool stride_ok = sc.stride >= floats_each * 4 && sc.stride % 4 == 0;
    const bool stride_needed = sc.element_count > 0;
    const bool enough_vertices = sc.boxes || sc.indexed || sc.primitive_count <= sc.element_count / 3;
    const bool vertices_needed = !sc.boxes && sc.primitive_count > 0 && sc.element_count == 0;
    const bool expect_ok = (!stride_needed || stride_ok) && enough_vertices && !vertices_needed;
    FUZZ_CHECK((s == AACBVH_OK) == expect_ok);
    sc.accepted = s == AACBVH_OK;
}

/// Tree invariants through the public queries.
void check_tree(aacbvh_bvh *bvh, const Scene &sc) {
    aacbvh_stats st;
    std::memset(&st, 0, sizeof st);
    st.struct_size = sizeof st;
    FUZZ_CHECK(aacbvh_bvh_get_stats(bvh, &st) == AACBVH_OK);
    FUZZ_CHECK(st.primitive_count + st.invalid_primitive_count == sc.primitive_count);
    if (st.primitive_count == 0) {
        FUZZ_CHECK(st.node_count == 0 && st.leaf_count == 0);
        return;
    }
    FUZZ_CHECK(st.node_count == 2 * st.leaf_count - 1);
    int64_t max_leaf = 0;
    FUZZ_CHECK(aacbvh_bvh_get_param_int(bvh, AACBVH_PARAM_MAX_LEAF_SIZE, &max_leaf) == AACBVH_OK);
    std::vector<aacbvh_node> nodes(st.node_count);
    std::vector<uint32_t> prims(st.primitive_count);
    FUZZ_CHECK(aacbvh_bvh_get_nodes(bvh, 0, nodes.size(), nodes.data()) == AACBVH_OK);
    FUZZ_CHECK(aacbvh_bvh_get_primitive_indices(bvh, 0, prims.size(), prims.data()) == AACBVH_OK);
    FUZZ_CHECK(aacbvh_bvh_get_nodes(bvh, nodes.size(), 1, nodes.data()) == AACBVH_ERROR_INVALID_ARGUMENT);
    std::vector<uint8_t> seen_prim(sc.primitive_count, 0), seen_node(nodes.size(), 0);
    std::vector<uint32_t> stack{0};
    uint64_t leaves = 0, covered = 0;
    seen_node[0] = 1;
    while (!stack.empty()) {
        const aacbvh_node &n = nodes[stack.back()];
        stack.pop_back();
        if (n.count > 0) {
            ++leaves;
            FUZZ_CHECK(n.count <= uint64_t(max_leaf));
            FUZZ_CHECK(uint64_t(n.first) + n.count <= prims.size());
            for (uint32_t i = n.first; i < n.first + n.count; ++i) {
                FUZZ_CHECK(prims[i] < sc.primitive_count);
                FUZZ_CHECK(!seen_prim[prims[i]]);
                seen_prim[prims[i]] = 1;
                ++covered;
            }
            continue;
        }
        FUZZ_CHECK(n.first >= 1 && uint64_t(n.first) + 1 < nodes.size());
        for (uint32_t c = n.first; c <= n.first + 1; ++c) {
            FUZZ_CHECK(!seen_node[c]);
            seen_node[c] = 1;
            stack.push_back(c);
        }
    }
    FUZZ_CHECK(leaves == st.leaf_count && covered == st.primitive_count);
}

void shoot_rays(FuzzedDataProvider &in, aacbvh_bvh *bvh, const Scene &sc) {
    const size_t count = in.ConsumeIntegralInRange<size_t>(0, 16);
    std::vector<aacbvh_ray> rays(count);
    for (aacbvh_ray &r : rays) {
        for (int k = 0; k < 3; ++k) r.org[k] = pick_float(in);
        for (int k = 0; k < 3; ++k) r.dir[k] = pick_float(in);
        r.tmin = in.ConsumeBool() ? 0.0f : pick_float(in);
        r.tmax = in.ConsumeBool() ? INFINITY : pick_float(in);
    }
    std::vector<aacbvh_hit> hits(count);
    std::vector<uint8_t> occ(count);
    const aacbvh_status a = aacbvh_bvh_intersect(bvh, rays.data(), hits.data(), count);
    const aacbvh_status b = aacbvh_bvh_occluded(bvh, rays.data(), occ.data(), count);
    FUZZ_CHECK(a == b);
    if (a != AACBVH_OK) {
        FUZZ_CHECK(a == AACBVH_ERROR_INVALID_OPERATION);
        return;
    }
    for (size_t i = 0; i < count; ++i) {
        const aacbvh_hit &h = hits[i];
        if (h.prim_id == AACBVH_INVALID_ID) {
            FUZZ_CHECK(h.t == INFINITY && h.u == 0.0f && h.v == 0.0f);
            FUZZ_CHECK(occ[i] == 0);
            continue;
        }
        FUZZ_CHECK(ray_valid(rays[i]));
        FUZZ_CHECK(h.prim_id < sc.primitive_count);
        FUZZ_CHECK(h.t >= rays[i].tmin && h.t <= rays[i].tmax && std::isfinite(h.t));
        FUZZ_CHECK(occ[i] == 1);
    }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    FuzzedDataProvider in(data, size);
    aacbvh_bvh *bvh = nullptr;
    FUZZ_CHECK(aacbvh_bvh_create(context(in.ConsumeBool() ? 2 : 1), &bvh) == AACBVH_OK);
    set_params(in, bvh);
    Scene sc;
    make_scene(in, bvh, sc);
    set_params(in, bvh);
    shoot_rays(in, bvh, sc); // before any build: INVALID_OPERATION

    const aacbvh_status built = aacbvh_bvh_build(bvh);
    FUZZ_CHECK(built == AACBVH_OK || built == AACBVH_ERROR_INVALID_GEOMETRY);
    FUZZ_CHECK(built == AACBVH_OK || std::strlen(aacbvh_bvh_last_error(bvh)) > 0);
    if (built == AACBVH_OK && sc.accepted) check_tree(bvh, sc);
    shoot_rays(in, bvh, sc);

    // Move some coordinates in place and refit.
    if (!sc.data.empty() && in.ConsumeBool()) {
        const int moves = in.ConsumeIntegralInRange<int>(1, 8);
        for (int i = 0; i < moves; ++i) sc.data[in.ConsumeIntegralInRange<size_t>(0, sc.data.size() - 1)] = pick_float(in);
        const aacbvh_status s = aacbvh_bvh_refit(bvh);
        FUZZ_CHECK(s == AACBVH_OK || s == AACBVH_ERROR_INVALID_GEOMETRY || s == AACBVH_ERROR_INVALID_OPERATION);
        if (s == AACBVH_OK && built == AACBVH_OK && sc.accepted) check_tree(bvh, sc);
        shoot_rays(in, bvh, sc);
    }
    if (in.ConsumeBool()) {
        set_params(in, bvh);
        const aacbvh_status s = aacbvh_bvh_build(bvh);
        FUZZ_CHECK(s == AACBVH_OK || s == AACBVH_ERROR_INVALID_GEOMETRY);
        if (s == AACBVH_OK && sc.accepted) check_tree(bvh, sc);
        shoot_rays(in, bvh, sc);
    }
    aacbvh_bvh_destroy(bvh);
    return 0;
}
