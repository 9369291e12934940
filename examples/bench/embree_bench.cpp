#include "embree_bench.h"

#include <atomic>
#include <sys/types.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#ifdef AACBVH_BENCH_HAVE_EMBREE
#include <embree3/rtcore.h>

#include "embree_ray.h"
#endif

namespace bench {

#ifndef AACBVH_BENCH_HAVE_EMBREE

bool embree_compiled() { return false; }
std::string embree_version() { return "not compiled in"; }

bool embree_build_bvh(const std::vector<float> &, const std::vector<uint32_t> &, EmbreeQuality, uint32_t, int,
                      uint32_t, bool, std::vector<double> &, FlatTree *, std::string &err) {
    err = "Embree not compiled in";
    return false;
}

bool embree_scene_bench(const std::vector<float> &, const std::vector<uint32_t> &, uint32_t, int, const RaySets *,
                        std::vector<double> &, double[kRayKindCount], uint64_t[kRayKindCount], double &,
                        std::string &err, const OurPass *, double[kRayKindCount]) {
    err = "Embree not compiled in";
    return false;
}

#else

bool embree_compiled() { return true; }

std::string embree_version() {
    return std::to_string(RTC_VERSION_MAJOR) + "." + std::to_string(RTC_VERSION_MINOR) + "." +
           std::to_string(RTC_VERSION_PATCH);
}

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
    if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
    std::sort(v.begin(), v.end());
    const size_t m = v.size() / 2;
    return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

/// A device with `threads` threads; released by the destructor. Counts the
/// bytes Embree holds through its memory monitor (what its scenes and BVHs
/// allocate), so that the bench can put Embree's memory beside ours.
struct Device {
    RTCDevice device = nullptr;
    std::atomic<int64_t> bytes{0};
    explicit Device(uint32_t threads) {
        const std::string config = "threads=" + std::to_string(threads == 0 ? 1 : threads);
        device = rtcNewDevice(config.c_str());
        if (device) rtcSetDeviceMemoryMonitorFunction(device, monitor, this);
    }
    static bool monitor(void *user, ssize_t delta, bool /*post*/) {
        static_cast<Device *>(user)->bytes.fetch_add(int64_t(delta), std::memory_order_relaxed);
        return true;
    }
    ~Device() {
        if (device) rtcReleaseDevice(device);
    }
    Device(const Device &) = delete;
    Device &operator=(const Device &) = delete;
};

std::string device_error(RTCDevice device, const char *what) {
    const RTCError e = device ? rtcGetDeviceError(device) : RTC_ERROR_UNKNOWN;
    return std::string(what) + " failed (RTCError " + std::to_string(int(e)) + ")";
}

// Nodes made by the rtcBuildBVH callbacks, in memory of Embree's thread-local
// allocator (freed with the RTCBVH). Converted to aacbvh_node afterwards.
struct NodeBase {
    uint32_t is_leaf;
};
struct InnerNode {
    NodeBase base;
    uint32_t child_count;
    NodeBase *children[2];
    RTCBounds bounds[2];
};
struct LeafNode {
    NodeBase base;
    uint32_t count;
    uint32_t prims[RTC_BUILD_MAX_PRIMITIVES_PER_LEAF];
};

void *create_node(RTCThreadLocalAllocator alloc, unsigned int child_count, void *) {
    void *mem = rtcThreadLocalAlloc(alloc, sizeof(InnerNode), 16);
    InnerNode *node = new (mem) InnerNode();
    node->base.is_leaf = 0;
    node->child_count = std::min(child_count, 2u);
    return node;
}

void set_children(void *node_ptr, void **children, unsigned int child_count, void *) {
    InnerNode *node = static_cast<InnerNode *>(node_ptr);
    for (unsigned i = 0; i < child_count && i < 2; ++i) node->children[i] = static_cast<NodeBase *>(children[i]);
}

void set_bounds(void *node_ptr, const RTCBounds **bounds, unsigned int child_count, void *) {
    InnerNode *node = static_cast<InnerNode *>(node_ptr);
    for (unsigned i = 0; i < child_count && i < 2; ++i) node->bounds[i] = *bounds[i];
}

void *create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive *prims, size_t count, void *) {
    void *mem = rtcThreadLocalAlloc(alloc, sizeof(LeafNode), 16);
    LeafNode *leaf = new (mem) LeafNode();
    leaf->base.is_leaf = 1;
    leaf->count = uint32_t(std::min<size_t>(count, RTC_BUILD_MAX_PRIMITIVES_PER_LEAF));
    for (uint32_t i = 0; i < leaf->count; ++i) leaf->prims[i] = prims[i].primID;
    return leaf;
}

void set_node_box(aacbvh_node &out, const RTCBounds &b) {
    out.lower[0] = b.lower_x;
    out.lower[1] = b.lower_y;
    out.lower[2] = b.lower_z;
    out.upper[0] = b.upper_x;
    out.upper[1] = b.upper_y;
    out.upper[2] = b.upper_z;
}

/// Converts Embree's tree into the public layout (children adjacent). The root's
/// box is the union of its primitives' boxes.
void convert(const NodeBase *root, const std::vector<RTCBuildPrimitive> &pristine, FlatTree &out) {
    out.nodes.clear();
    out.prim_indices.clear();
    RTCBounds all{};
    all.lower_x = all.lower_y = all.lower_z = std::numeric_limits<float>::infinity();
    all.upper_x = all.upper_y = all.upper_z = -std::numeric_limits<float>::infinity();
    for (const RTCBuildPrimitive &p : pristine) {
        all.lower_x = std::min(all.lower_x, p.lower_x);
        all.lower_y = std::min(all.lower_y, p.lower_y);
        all.lower_z = std::min(all.lower_z, p.lower_z);
        all.upper_x = std::max(all.upper_x, p.upper_x);
        all.upper_y = std::max(all.upper_y, p.upper_y);
        all.upper_z = std::max(all.upper_z, p.upper_z);
    }
    out.nodes.push_back(aacbvh_node{});
    set_node_box(out.nodes[0], all);
    std::vector<std::pair<const NodeBase *, uint32_t>> stack{{root, 0u}};
    while (!stack.empty()) {
        auto [node, index] = stack.back();
        stack.pop_back();
        // A one-child inner node (never made with branching factor 2) is skipped over.
        while (!node->is_leaf && reinterpret_cast<const InnerNode *>(node)->child_count == 1)
            node = reinterpret_cast<const InnerNode *>(node)->children[0];
        if (node->is_leaf) {
            const LeafNode *leaf = reinterpret_cast<const LeafNode *>(node);
            out.nodes[index].first = uint32_t(out.prim_indices.size());
            out.nodes[index].count = leaf->count;
            out.prim_indices.insert(out.prim_indices.end(), leaf->prims, leaf->prims + leaf->count);
            continue;
        }
        const InnerNode *inner = reinterpret_cast<const InnerNode *>(node);
        const uint32_t first = uint32_t(out.nodes.size());
        out.nodes[index].first = first;
        out.nodes[index].count = 0;
        out.nodes.resize(out.nodes.size() + 2);
        for (int c = 0; c < 2; ++c) {
            set_node_box(out.nodes[first + c], inner->bounds[c]);
            stack.push_back({inner->children[c], first + c});
        }
    }
}

}  // namespace

bool embree_build_bvh(const std::vector<float> &vertices, const std::vector<uint32_t> &indices,
                      EmbreeQuality quality, uint32_t threads, int runs, uint32_t max_leaf_size, bool reuse_bvh,
                      std::vector<double> &seconds, FlatTree *tree, std::string &err) {
    Device dev(threads);
    if (!dev.device) {
        err = "rtcNewDevice failed";
        return false;
    }
    const size_t n = indices.size() / 3;
    std::vector<RTCBuildPrimitive> pristine(n);
    for (size_t i = 0; i < n; ++i) {
        const float *v[3];
        for (int k = 0; k < 3; ++k) v[k] = &vertices[3 * size_t(indices[3 * i + k])];
        RTCBuildPrimitive &p = pristine[i];
        p.lower_x = std::min({v[0][0], v[1][0], v[2][0]});
        p.lower_y = std::min({v[0][1], v[1][1], v[2][1]});
        p.lower_z = std::min({v[0][2], v[1][2], v[2][2]});
        p.upper_x = std::max({v[0][0], v[1][0], v[2][0]});
        p.upper_y = std::max({v[0][1], v[1][1], v[2][1]});
        p.upper_z = std::max({v[0][2], v[1][2], v[2][2]});
        p.geomID = 0;
        p.primID = uint32_t(i);
    }
    std::vector<RTCBuildPrimitive> prims(n);
    RTCBVH kept = reuse_bvh ? rtcNewBVH(dev.device) : nullptr;  // holds its memory between builds
    for (int run = 0; run < runs; ++run) {
        prims = pristine;  // the builder reorders its input
        RTCBVH bvh = kept ? kept : rtcNewBVH(dev.device);
        RTCBuildArguments args = rtcDefaultBuildArguments();
        args.byteSize = sizeof(args);
        args.buildQuality = quality == EmbreeQuality::kLow ? RTC_BUILD_QUALITY_LOW : RTC_BUILD_QUALITY_MEDIUM;
        args.buildFlags = RTC_BUILD_FLAG_NONE;
        args.maxBranchingFactor = 2;
        args.maxDepth = 1024;
        args.sahBlockSize = 1;
        args.maxLeafSize = std::min<uint32_t>(max_leaf_size, RTC_BUILD_MAX_PRIMITIVES_PER_LEAF);
        // The Morton builder splits every range down to minLeafSize; with 1 it makes
        // one-triangle leaves. Ranges of up to the leaf limit stay whole, like ours.
        args.minLeafSize = quality == EmbreeQuality::kLow ? args.maxLeafSize : 1;
        args.traversalCost = 1.2f;  // the SAH constants of aacbvh's defaults
        args.intersectionCost = 1.0f;
        args.bvh = bvh;
        args.primitives = prims.data();
        args.primitiveCount = prims.size();
        args.primitiveArrayCapacity = prims.size();
        args.createNode = create_node;
        args.setNodeChildren = set_children;
        args.setNodeBounds = set_bounds;
        args.createLeaf = create_leaf;
        args.splitPrimitive = nullptr;
        args.buildProgress = nullptr;
        args.userPtr = nullptr;

        const auto t0 = Clock::now();
        void *root = rtcBuildBVH(&args);
        const double s = seconds_since(t0);
        if (!root) {
            err = device_error(dev.device, "rtcBuildBVH");
            rtcReleaseBVH(bvh);
            return false;
        }
        seconds.push_back(s);
        if (tree && run == runs - 1) convert(static_cast<const NodeBase *>(root), pristine, *tree);
        if (!kept) rtcReleaseBVH(bvh);
    }
    if (kept) rtcReleaseBVH(kept);
    return true;
}

bool embree_scene_bench(const std::vector<float> &vertices, const std::vector<uint32_t> &indices,
                        uint32_t threads, int runs, const RaySets *rays, std::vector<double> &seconds,
                        double mrays[kRayKindCount], uint64_t hits[kRayKindCount], double &scene_bytes,
                        std::string &err, const OurPass *ours, double head_to_head[kRayKindCount]) {
    Device dev(threads);
    const int64_t device_bytes = dev.bytes.load();
    if (!dev.device) {
        err = "rtcNewDevice failed";
        return false;
    }
    // Shared vertex buffers must be readable 16 bytes past the last vertex's start.
    std::vector<float> padded(vertices);
    padded.resize(padded.size() + 4, 0.0f);
    const size_t vertex_count = vertices.size() / 3, triangle_count = indices.size() / 3;

    RTCScene scene = nullptr;
    for (int run = 0; run < runs; ++run) {
        if (scene) rtcReleaseScene(scene);
        const auto t0 = Clock::now();
        scene = rtcNewScene(dev.device);
        RTCGeometry geom = rtcNewGeometry(dev.device, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, padded.data(), 0,
                                   3 * sizeof(float), vertex_count);
        rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, indices.data(), 0,
                                   3 * sizeof(uint32_t), triangle_count);
        rtcCommitGeometry(geom);
        rtcAttachGeometry(scene, geom);
        rtcReleaseGeometry(geom);
        rtcCommitScene(scene);
        const double s = seconds_since(t0);
        if (rtcGetDeviceError(dev.device) != RTC_ERROR_NONE) {
            err = "Embree scene build failed";
            rtcReleaseScene(scene);
            return false;
        }
        seconds.push_back(s);
    }
    // What the last committed scene holds (the earlier ones are released).
    scene_bytes = double(dev.bytes.load() - device_bytes);
    if (rays && scene) {
        for (int kind = 0; kind < kRayKindCount; ++kind) {
            const std::vector<aacbvh_ray> &set = rays->rays[kind];
            std::vector<double> times, ratios;
            bool ours_failed = false;
            uint64_t hit_count = 0;
            // Head to head, one round first that is not counted: the first
            // passes fault in the callers' result arrays and find the other
            // side's data in the caches.
            const bool duel = ours && *ours;
            for (int run = duel ? -1 : 0; run < runs; ++run) {
                hit_count = 0;
                RTCIntersectContext context;
                rtcInitIntersectContext(&context);
                const auto t0 = Clock::now();
                for (const aacbvh_ray &r : set) {
                    if (kind == kShadow) {
                        RTCRay ray = embree_ray(r);
                        rtcOccluded1(scene, &context, &ray);
                        hit_count += ray.tfar < 0.0f;  // set to -inf when occluded
                    } else {
                        RTCRayHit rh = embree_ray_hit(r);
                        rtcIntersect1(scene, &context, &rh);
                        hit_count += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
                    }
                }
                const double embree_seconds = seconds_since(t0);
                const double our_seconds = duel ? (*ours)(kind) : 0.0;
                if (run < 0) continue;
                times.push_back(embree_seconds);
                if (duel) {
                    ours_failed |= !(our_seconds > 0.0);
                    ratios.push_back(embree_seconds / our_seconds);
                }
            }
            const double t = median(times);
            mrays[kind] = t > 0.0 ? set.size() / t * 1e-6 : std::numeric_limits<double>::quiet_NaN();
            hits[kind] = hit_count;
            if (head_to_head)
                head_to_head[kind] = duel && !ours_failed ? median(ratios) : std::numeric_limits<double>::quiet_NaN();
        }
    }
    if (scene) rtcReleaseScene(scene);
    return true;
}

#endif

}  // namespace bench
