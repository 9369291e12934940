// The counting tracer of ray_cost.h: a plain scalar stack traversal, written for
// clarity of the counts rather than speed (speed is measured on the library's
// own aacbvh_bvh_intersect / aacbvh_bvh_occluded).
#include "ray_cost.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace bench {

namespace {

double box_area(const float lo[3], const float hi[3]) {
    const double dx = std::max(0.0, double(hi[0]) - lo[0]);
    const double dy = std::max(0.0, double(hi[1]) - lo[1]);
    const double dz = std::max(0.0, double(hi[2]) - lo[2]);
    return 2.0 * (dx * dy + dy * dz + dz * dx);
}

/// Deepest stack the traversal may need (one entry per level); deeper trees are refused.
constexpr size_t kMaxStack = 4096;

}  // namespace

bool fetch_tree(const aacbvh_bvh *bvh, FlatTree &out, std::string &err) {
    aacbvh_stats stats{};
    stats.struct_size = sizeof(stats);
    aacbvh_status s = aacbvh_bvh_get_stats(bvh, &stats);
    if (s != AACBVH_OK) {
        err = std::string("get_stats: ") + aacbvh_bvh_last_error(bvh);
        return false;
    }
    out.nodes.resize(stats.node_count);
    out.prim_indices.resize(stats.primitive_count);
    s = aacbvh_bvh_get_nodes(bvh, 0, out.nodes.size(), out.nodes.data());
    if (s == AACBVH_OK)
        s = aacbvh_bvh_get_primitive_indices(bvh, 0, out.prim_indices.size(), out.prim_indices.data());
    if (s != AACBVH_OK) {
        err = std::string("reading the tree: ") + aacbvh_bvh_last_error(bvh);
        return false;
    }
    return true;
}

bool check_tree(const FlatTree &tree, size_t triangle_count, std::string &err) {
    const size_t n = tree.nodes.size();
    if (n == 0) {
        if (!tree.prim_indices.empty()) {
            err = "no nodes but primitives";
            return false;
        }
        return true;
    }
    std::vector<uint8_t> slot_used(tree.prim_indices.size(), 0);
    std::vector<uint8_t> node_seen(n, 0);
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};  // node, depth
    size_t leaves = 0;
    while (!stack.empty()) {
        const auto [index, depth] = stack.back();
        stack.pop_back();
        if (node_seen[index]++) {
            err = "node " + std::to_string(index) + " reached twice";
            return false;
        }
        if (depth >= kMaxStack - 2) {
            err = "tree deeper than " + std::to_string(kMaxStack - 2);
            return false;
        }
        const aacbvh_node &node = tree.nodes[index];
        if (node.count == 0) {
            if (size_t(node.first) + 1 >= n) {
                err = "inner node " + std::to_string(index) + " has children out of range";
                return false;
            }
            for (uint32_t c = node.first; c <= node.first + 1; ++c) {
                const aacbvh_node &child = tree.nodes[c];
                for (int k = 0; k < 3; ++k) {
                    if (child.lower[k] < node.lower[k] || child.upper[k] > node.upper[k]) {
                        err = "child " + std::to_string(c) + " sticks out of node " + std::to_string(index);
                        return false;
                    }
                }
                stack.push_back({c, depth + 1});
            }
        } else {
            ++leaves;
            if (size_t(node.first) + node.count > slot_used.size()) {
                err = "leaf " + std::to_string(index) + " has slots out of range";
                return false;
            }
            for (uint32_t i = node.first; i < node.first + node.count; ++i) {
                if (slot_used[i]++) {
                    err = "primitive slot " + std::to_string(i) + " in two leaves";
                    return false;
                }
                if (tree.prim_indices[i] >= triangle_count) {
                    err = "primitive index out of range in slot " + std::to_string(i);
                    return false;
                }
            }
        }
    }
    if (std::find(slot_used.begin(), slot_used.end(), uint8_t(0)) != slot_used.end()) {
        err = "a primitive slot is in no leaf";
        return false;
    }
    if (n != 2 * leaves - 1) {
        err = "node count " + std::to_string(n) + " is not 2 * leaves - 1";
        return false;
    }
    return true;
}

double sah_cost(const FlatTree &tree, double ct, double ci) {
    if (tree.nodes.empty()) return 0.0;
    const double root_area = box_area(tree.nodes[0].lower, tree.nodes[0].upper);
    if (root_area <= 0.0) return 0.0;
    double sum = 0.0;
    for (const aacbvh_node &node : tree.nodes) {
        const double a = box_area(node.lower, node.upper);
        sum += node.count == 0 ? ct * a : ci * a * node.count;
    }
    return sum / root_area;
}

Overlap overlap_of(const FlatTree &tree) {
    Overlap out;
    if (tree.nodes.empty()) return out;
    const aacbvh_node &root = tree.nodes[0];
    auto volume = [](const float lo[3], const float hi[3]) {
        double v = 1.0;
        for (int k = 0; k < 3; ++k) v *= std::max(0.0, double(hi[k]) - double(lo[k]));
        return v;
    };
    const double root_area = box_area(root.lower, root.upper), root_volume = volume(root.lower, root.upper);
    double area = 0.0, vol = 0.0;
    for (const aacbvh_node &node : tree.nodes) {
        if (node.count != 0 || size_t(node.first) + 1 >= tree.nodes.size()) continue;
        const aacbvh_node &l = tree.nodes[node.first], &r = tree.nodes[node.first + 1];
        float lo[3], hi[3];
        bool empty = false;
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::max(l.lower[k], r.lower[k]);
            hi[k] = std::min(l.upper[k], r.upper[k]);
            empty = empty || !(lo[k] <= hi[k]);
        }
        if (empty) continue;  // disjoint on some axis (touching boxes overlap in a face: area, no volume)
        area += box_area(lo, hi);
        vol += volume(lo, hi);
    }
    out.area = root_area > 0.0 ? area / root_area : std::numeric_limits<double>::quiet_NaN();
    out.volume = root_volume > 0.0 ? vol / root_volume : std::numeric_limits<double>::quiet_NaN();
    return out;
}

CostTracer::CostTracer(const FlatTree &tree, const float *vertices, const uint32_t *indices,
                       size_t triangle_count)
    : tree_(tree), tris_(triangle_count) {
    for (size_t i = 0; i < triangle_count; ++i) {
        const float *a = vertices + 3 * size_t(indices[3 * i]);
        const float *b = vertices + 3 * size_t(indices[3 * i + 1]);
        const float *c = vertices + 3 * size_t(indices[3 * i + 2]);
        Tri &t = tris_[i];
        for (int k = 0; k < 3; ++k) {
            t.v0[k] = a[k];
            t.e1[k] = b[k] - a[k];
            t.e2[k] = c[k] - a[k];
        }
    }
}

namespace {

struct RayInv {
    float org[3];
    float inv[3];
};

/// Slab test; returns the entry distance, or NaN on a miss of [tmin, tmax] (so
/// every `t <= tmax` comparison is false, also with an infinite tmax), and
/// the exit distance in `exit`. fmin/fmax drop the NaN of 0 * inf (origin on
/// a slab plane, direction 0 on that axis), which then leaves the interval
/// unconstrained on that axis.
inline float enter_box(const aacbvh_node &node, const RayInv &r, float tmin, float tmax, float &exit) {
    float t_enter = tmin, t_exit = tmax;
    for (int k = 0; k < 3; ++k) {
        const float t0 = (node.lower[k] - r.org[k]) * r.inv[k];
        const float t1 = (node.upper[k] - r.org[k]) * r.inv[k];
        t_enter = std::fmax(t_enter, std::fmin(t0, t1));
        t_exit = std::fmin(t_exit, std::fmax(t0, t1));
    }
    exit = t_exit;
    return t_enter <= t_exit ? t_enter : std::numeric_limits<float>::quiet_NaN();
}

/// The library's closest-hit visiting order (lib/trace/child_order.h),
/// restated: a box the origin lies in (entered at tmin >= 0) comes before
/// those entered later, and such boxes go by exit distance. The key: the
/// entry, or for such a box a negative float that grows with the exit (the
/// bits of -inf less those of the exit, as the library makes it).
inline float visit_key(float entry, float exit, float tmin) {
    if (!(tmin >= 0.0f) || entry > tmin) return entry;
    uint32_t u;
    std::memcpy(&u, &exit, sizeof u);
    u = 0xFF800000u - (u & 0x7FFFFFFFu);
    float key;
    std::memcpy(&key, &u, sizeof key);
    return key;
}

inline void cross(const float a[3], const float b[3], float out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}
inline float dot(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

}  // namespace

template <bool AnyHit>
CountedHit CostTracer::trace(const aacbvh_ray &ray, RayCount &count) const {
    CountedHit hit{std::numeric_limits<float>::infinity(), AACBVH_INVALID_ID};
    if (tree_.nodes.empty()) return hit;
    RayInv r;
    for (int k = 0; k < 3; ++k) {
        r.org[k] = ray.org[k];
        r.inv[k] = 1.0f / ray.dir[k];
    }
    const float tmin = ray.tmin;
    float tmax = ray.tmax;

    struct Entry {
        uint32_t node;
        float t;
    };
    Entry stack[kMaxStack];
    size_t top = 0;

    ++count.steps;  // the root's box
    float x_root;
    const float t_root = enter_box(tree_.nodes[0], r, tmin, tmax, x_root);
    if (!(t_root <= tmax)) return hit;
    stack[top++] = {0, t_root};

    while (top > 0) {
        const Entry e = stack[--top];
        if (e.t > tmax) continue;  // beyond the closest hit so far
        const aacbvh_node &node = tree_.nodes[e.node];
        if (node.count == 0) {
            count.steps += 2;
            const aacbvh_node &c0 = tree_.nodes[node.first], &c1 = tree_.nodes[node.first + 1];
            float x0, x1;
            const float t0 = enter_box(c0, r, tmin, tmax, x0);
            const float t1 = enter_box(c1, r, tmin, tmax, x1);
            const bool hit0 = t0 <= tmax, hit1 = t1 <= tmax;
            if (hit0 && hit1) {
                // The far child goes below the near one, so the near one is
                // popped first. Closest hits: the library's order
                // (visit_key()), of equal keys the smaller box; any hit: the
                // nearer entry, ties to the left.
                const bool first0 =
                    AnyHit ? t0 <= t1
                           : visit_key(t0, x0, tmin) < visit_key(t1, x1, tmin) ||
                                 (visit_key(t0, x0, tmin) == visit_key(t1, x1, tmin) &&
                                  box_area(c0.lower, c0.upper) <= box_area(c1.lower, c1.upper));
                if (first0) {
                    stack[top++] = {node.first + 1, t1};
                    stack[top++] = {node.first, t0};
                } else {
                    stack[top++] = {node.first, t0};
                    stack[top++] = {node.first + 1, t1};
                }
            } else if (hit0) {
                stack[top++] = {node.first, t0};
            } else if (hit1) {
                stack[top++] = {node.first + 1, t1};
            }
            continue;
        }
        for (uint32_t i = node.first; i < node.first + node.count; ++i) {
            ++count.tests;
            const uint32_t prim = tree_.prim_indices[i];
            const Tri &tri = tris_[prim];
            // Moller-Trumbore, two-sided; det == 0 (degenerate or edge-on) misses.
            float p[3], s[3], q[3];
            cross(ray.dir, tri.e2, p);
            const float det = dot(tri.e1, p);
            if (det == 0.0f) continue;
            const float inv_det = 1.0f / det;
            for (int k = 0; k < 3; ++k) s[k] = ray.org[k] - tri.v0[k];
            const float u = dot(s, p) * inv_det;
            if (!(u >= 0.0f && u <= 1.0f)) continue;
            cross(s, tri.e1, q);
            const float v = dot(ray.dir, q) * inv_det;
            if (!(v >= 0.0f && u + v <= 1.0f)) continue;
            const float t = dot(tri.e2, q) * inv_det;
            if (!(t >= tmin && t <= tmax)) continue;
            hit.t = t;
            hit.prim_id = prim;
            if (AnyHit) return hit;
            tmax = t;
        }
    }
    return hit;
}

CountedHit CostTracer::closest(const aacbvh_ray &ray, RayCount &count) const {
    return trace<false>(ray, count);
}

bool CostTracer::any(const aacbvh_ray &ray, RayCount &count) const {
    return trace<true>(ray, count).prim_id != AACBVH_INVALID_ID;
}

CostSummary measure_closest(const CostTracer &tracer, const std::vector<aacbvh_ray> &rays,
                            std::vector<CountedHit> *hits_out) {
    CostSummary out;
    RayCount total;
    if (hits_out) hits_out->resize(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) {
        const CountedHit h = tracer.closest(rays[i], total);
        if (h.prim_id != AACBVH_INVALID_ID) ++out.hits;
        if (hits_out) (*hits_out)[i] = h;
    }
    out.rays = rays.size();
    if (!rays.empty()) {
        out.steps = double(total.steps) / rays.size();
        out.tests = double(total.tests) / rays.size();
    }
    return out;
}

CostSummary measure_any(const CostTracer &tracer, const std::vector<aacbvh_ray> &rays,
                        std::vector<uint8_t> *occluded_out) {
    CostSummary out;
    RayCount total;
    if (occluded_out) occluded_out->resize(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) {
        const bool occ = tracer.any(rays[i], total);
        if (occ) ++out.hits;
        if (occluded_out) (*occluded_out)[i] = occ ? 1 : 0;
    }
    out.rays = rays.size();
    if (!rays.empty()) {
        out.steps = double(total.steps) / rays.size();
        out.tests = double(total.tests) / rays.size();
    }
    return out;
}

}  // namespace bench
