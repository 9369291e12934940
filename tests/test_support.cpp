// Test helpers behind test_support.h: C interface, C++ inside.
#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <setjmp.h>
#include <string>
#include <vector>

// cmocka's header declares its functions without C linkage.
extern "C" {
#include <cmocka.h>
}

#ifdef AACBVH_HAVE_TINYOBJLOADER
#include <tiny_obj_loader.h>
#endif

// ---- RNG -------------------------------------------------------------------

void ts_rng_seed(ts_rng *rng, uint64_t seed) {
    // splitmix64 of the seed, so that nearby seeds give unrelated streams and
    // the state is never 0 (xorshift's fixed point).
    uint64_t z = seed + 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    rng->state = z ? z : 0x2545F4914F6CDD1Dull;
}

uint64_t ts_rng_next(ts_rng *rng) {
    uint64_t x = rng->state;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    rng->state = x;
    return x * 0x2545F4914F6CDD1Dull;
}

uint32_t ts_rng_below(ts_rng *rng, uint32_t bound) {
    return uint32_t((ts_rng_next(rng) >> 32) % bound);
}

float ts_rng_float(ts_rng *rng) {
    return float(ts_rng_next(rng) >> 40) * (1.0f / 16777216.0f);
}

float ts_rng_range(ts_rng *rng, float lo, float hi) {
    float r = lo + (hi - lo) * ts_rng_float(rng);
    return r < hi ? r : lo;
}

// ---- Scenes ----------------------------------------------------------------

namespace {

struct MeshBuilder {
    std::vector<float> v;
    std::vector<uint32_t> idx;

    uint32_t vertex(float x, float y, float z) {
        v.push_back(x);
        v.push_back(y);
        v.push_back(z);
        return uint32_t(v.size() / 3 - 1);
    }
    void tri(uint32_t a, uint32_t b, uint32_t c) {
        idx.push_back(a);
        idx.push_back(b);
        idx.push_back(c);
    }
    void tri(const float a[3], const float b[3], const float c[3]) {
        uint32_t ia = vertex(a[0], a[1], a[2]);
        uint32_t ib = vertex(b[0], b[1], b[2]);
        uint32_t ic = vertex(c[0], c[1], c[2]);
        tri(ia, ib, ic);
    }
    int finish(ts_mesh *out) {
        std::memset(out, 0, sizeof *out);
        out->vertex_count = v.size() / 3;
        out->triangle_count = idx.size() / 3;
        // Always allocate something so that empty meshes still have pointers.
        out->vertices = static_cast<float *>(std::malloc(std::max<size_t>(1, v.size()) * sizeof(float)));
        out->indices = static_cast<uint32_t *>(std::malloc(std::max<size_t>(1, idx.size()) * sizeof(uint32_t)));
        if (!out->vertices || !out->indices) {
            ts_mesh_free(out);
            return 0;
        }
        if (!v.empty()) std::memcpy(out->vertices, v.data(), v.size() * sizeof(float));
        if (!idx.empty()) std::memcpy(out->indices, idx.data(), idx.size() * sizeof(uint32_t));
        return 1;
    }
};

void random_point(ts_rng *rng, float lo, float hi, float p[3]) {
    for (int k = 0; k < 3; ++k) p[k] = ts_rng_range(rng, lo, hi);
}

} // namespace

const char *ts_scene_name(ts_scene_kind kind) {
    switch (kind) {
    case TS_SCENE_RANDOM: return "random";
    case TS_SCENE_GRID: return "grid";
    case TS_SCENE_IDENTICAL: return "identical";
    case TS_SCENE_SAME_CENTROID: return "same-centroid";
    case TS_SCENE_ZERO_AREA: return "zero-area";
    case TS_SCENE_FLAT: return "flat";
    case TS_SCENE_SLIVERS: return "slivers";
    case TS_SCENE_WIDE_RANGE: return "wide-range";
    default: return "unknown";
    }
}

int ts_make_scene(ts_scene_kind kind, size_t n, uint64_t seed, ts_mesh *out) {
    ts_rng rng;
    ts_rng_seed(&rng, seed);
    MeshBuilder m;
    switch (kind) {
    case TS_SCENE_RANDOM:
        for (size_t i = 0; i < n; ++i) {
            float c[3], a[3], b[3], d[3];
            random_point(&rng, -1.0f, 1.0f, c);
            for (int k = 0; k < 3; ++k) {
                a[k] = c[k] + ts_rng_range(&rng, -0.1f, 0.1f);
                b[k] = c[k] + ts_rng_range(&rng, -0.1f, 0.1f);
                d[k] = c[k] + ts_rng_range(&rng, -0.1f, 0.1f);
            }
            m.tri(a, b, d);
        }
        break;
    case TS_SCENE_GRID: {
        // Exactly n triangles, two per cell, row by row, over shared vertices.
        size_t cells = (n + 1) / 2;
        size_t w = std::max<size_t>(1, size_t(std::ceil(std::sqrt(double(cells)))));
        size_t h = std::max<size_t>(1, (cells + w - 1) / w);
        for (size_t y = 0; y <= h; ++y)
            for (size_t x = 0; x <= w; ++x) {
                float fx = float(x) / float(w), fy = float(y) / float(h);
                m.vertex(fx, fy, 0.05f * std::sin(6.0f * fx) * std::cos(5.0f * fy));
            }
        size_t made = 0;
        for (size_t y = 0; y < h && made < n; ++y)
            for (size_t x = 0; x < w && made < n; ++x) {
                uint32_t v00 = uint32_t(y * (w + 1) + x), v10 = v00 + 1;
                uint32_t v01 = uint32_t(v00 + w + 1), v11 = v01 + 1;
                m.tri(v00, v10, v11);
                if (++made < n) {
                    m.tri(v00, v11, v01);
                    ++made;
                }
            }
        break;
    }
    case TS_SCENE_IDENTICAL: {
        // Every triangle indexes the same three vertices.
        uint32_t a = m.vertex(0.1f, 0.2f, 0.3f);
        uint32_t b = m.vertex(0.7f, 0.25f, 0.35f);
        uint32_t c = m.vertex(0.4f, 0.9f, 0.1f);
        for (size_t i = 0; i < n; ++i) m.tri(a, b, c);
        break;
    }
    case TS_SCENE_SAME_CENTROID:
        // Vertices d1, -d1, d2 with |d2| <= |d1| on each axis: every box is
        // [-|d1|, |d1|], centred exactly on the origin.
        for (size_t i = 0; i < n; ++i) {
            float d1[3], d2[3], e1[3];
            random_point(&rng, -1.0f, 1.0f, d1);
            for (int k = 0; k < 3; ++k) {
                e1[k] = -d1[k];
                d2[k] = d1[k] * ts_rng_range(&rng, -1.0f, 1.0f);
            }
            m.tri(d1, e1, d2);
        }
        break;
    case TS_SCENE_ZERO_AREA:
        for (size_t i = 0; i < n; ++i) {
            float a[3], b[3], c[3];
            random_point(&rng, -1.0f, 1.0f, a);
            std::memcpy(b, a, sizeof b);
            std::memcpy(c, a, sizeof c);
            switch (i % 4) {
            case 0: break; // a point
            case 1:        // a repeated vertex
                for (int k = 0; k < 3; ++k) b[k] = a[k] + ts_rng_range(&rng, -0.1f, 0.1f);
                std::memcpy(c, b, sizeof c);
                break;
            case 2: { // exactly collinear along one axis
                int axis = int(ts_rng_below(&rng, 3));
                b[axis] = a[axis] + 0.05f;
                c[axis] = a[axis] + 0.125f;
                break;
            }
            default: // collinear along a diagonal (dyadic offsets keep it exact)
                for (int k = 0; k < 3; ++k) {
                    b[k] = a[k] + 0.0625f;
                    c[k] = a[k] + 0.125f;
                }
                break;
            }
            m.tri(a, b, c);
        }
        break;
    case TS_SCENE_FLAT:
        for (size_t i = 0; i < n; ++i) {
            float a[3], b[3], c[3];
            float cx = ts_rng_range(&rng, -1.0f, 1.0f), cy = ts_rng_range(&rng, -1.0f, 1.0f);
            a[0] = cx + ts_rng_range(&rng, -0.1f, 0.1f); a[1] = cy + ts_rng_range(&rng, -0.1f, 0.1f);
            b[0] = cx + ts_rng_range(&rng, -0.1f, 0.1f); b[1] = cy + ts_rng_range(&rng, -0.1f, 0.1f);
            c[0] = cx + ts_rng_range(&rng, -0.1f, 0.1f); c[1] = cy + ts_rng_range(&rng, -0.1f, 0.1f);
            a[2] = b[2] = c[2] = 0.0f;
            m.tri(a, b, c);
        }
        break;
    case TS_SCENE_SLIVERS:
        for (size_t i = 0; i < n; ++i) {
            float a[3], b[3], c[3];
            random_point(&rng, -1.0f, 1.0f, a);
            int axis = int(ts_rng_below(&rng, 3));
            std::memcpy(b, a, sizeof b);
            std::memcpy(c, a, sizeof c);
            b[axis] += ts_rng_range(&rng, -2.0f, 2.0f);
            c[axis] += ts_rng_range(&rng, -2.0f, 2.0f);
            c[(axis + 1) % 3] += 1e-4f;
            m.tri(a, b, c);
        }
        break;
    case TS_SCENE_WIDE_RANGE:
        // Each triangle lives at its own scale 10^e, e in [-30, 18]: the
        // scene spans 48 decades, yet its extents' products stay finite in float.
        for (size_t i = 0; i < n; ++i) {
            float scale = std::pow(10.0f, float(int(ts_rng_below(&rng, 49)) - 30));
            float c[3], a[3], b[3], d[3];
            random_point(&rng, -1.0f, 1.0f, c);
            for (int k = 0; k < 3; ++k) {
                a[k] = scale * (c[k] + ts_rng_range(&rng, -0.1f, 0.1f));
                b[k] = scale * (c[k] + ts_rng_range(&rng, -0.1f, 0.1f));
                d[k] = scale * (c[k] + ts_rng_range(&rng, -0.1f, 0.1f));
            }
            m.tri(a, b, d);
        }
        break;
    default:
        std::memset(out, 0, sizeof *out);
        return 0;
    }
    return m.finish(out);
}

int ts_load_scene(const char *file_name, ts_mesh *out) {
    std::memset(out, 0, sizeof *out);
#ifdef AACBVH_HAVE_TINYOBJLOADER
    std::string path = std::string(AACBVH_SCENES_DIR) + "/" + file_name;
    FILE *probe = std::fopen(path.c_str(), "rb");
    if (!probe) return 0;
    std::fclose(probe);
    tinyobj::ObjReaderConfig config;
    config.triangulate = true;
    config.vertex_color = false;
    tinyobj::ObjReader reader;
    if (!reader.ParseFromFile(path, config)) return 0;
    const tinyobj::attrib_t &attrib = reader.GetAttrib();
    MeshBuilder m;
    m.v.assign(attrib.vertices.begin(), attrib.vertices.end());
    size_t vertex_count = m.v.size() / 3;
    for (const tinyobj::shape_t &shape : reader.GetShapes()) {
        const std::vector<tinyobj::index_t> &ix = shape.mesh.indices;
        for (size_t i = 0; i + 2 < ix.size(); i += 3) {
            if (ix[i].vertex_index < 0 || size_t(ix[i].vertex_index) >= vertex_count ||
                ix[i + 1].vertex_index < 0 || size_t(ix[i + 1].vertex_index) >= vertex_count ||
                ix[i + 2].vertex_index < 0 || size_t(ix[i + 2].vertex_index) >= vertex_count)
                continue;
            m.tri(uint32_t(ix[i].vertex_index), uint32_t(ix[i + 1].vertex_index),
                  uint32_t(ix[i + 2].vertex_index));
        }
    }
    if (m.idx.empty()) return 0;
    return m.finish(out);
#else
    (void)file_name;
    return 0;
#endif
}

void ts_mesh_free(ts_mesh *mesh) {
    std::free(mesh->vertices);
    std::free(mesh->indices);
    std::memset(mesh, 0, sizeof *mesh);
}

float *ts_triangle_boxes(const float *vertices, size_t stride, const uint32_t *indices, size_t n) {
    float *boxes = static_cast<float *>(std::malloc(std::max<size_t>(1, 6 * n) * sizeof(float)));
    if (!boxes) return nullptr;
    for (size_t i = 0; i < n; ++i) {
        float *b = boxes + 6 * i;
        for (int j = 0; j < 3; ++j) {
            size_t vi = indices ? indices[3 * i + j] : 3 * i + j;
            const float *p = reinterpret_cast<const float *>(reinterpret_cast<const char *>(vertices) + vi * stride);
            for (int k = 0; k < 3; ++k) {
                if (j == 0 || p[k] < b[k]) b[k] = p[k];
                if (j == 0 || p[k] > b[3 + k]) b[3 + k] = p[k];
            }
        }
    }
    return boxes;
}

float *ts_mesh_boxes(const ts_mesh *mesh) {
    return ts_triangle_boxes(mesh->vertices, 3 * sizeof(float), mesh->indices, mesh->triangle_count);
}

float *ts_random_boxes(size_t count, float max_extent, uint64_t seed) {
    ts_rng rng;
    ts_rng_seed(&rng, seed);
    float *boxes = static_cast<float *>(std::malloc(std::max<size_t>(1, 6 * count) * sizeof(float)));
    if (!boxes) return nullptr;
    for (size_t i = 0; i < count; ++i)
        for (int k = 0; k < 3; ++k) {
            float lo = ts_rng_range(&rng, -1.0f, 1.0f);
            boxes[6 * i + k] = lo;
            boxes[6 * i + 3 + k] = lo + max_extent * ts_rng_float(&rng);
        }
    return boxes;
}

// ---- Trees -----------------------------------------------------------------

aacbvh_status ts_tree_fetch(const aacbvh_bvh *bvh, ts_tree *out) {
    std::memset(out, 0, sizeof *out);
    out->stats.struct_size = sizeof(aacbvh_stats);
    aacbvh_status s = aacbvh_bvh_get_stats(bvh, &out->stats);
    if (s != AACBVH_OK) return s;
    out->node_count = size_t(out->stats.node_count);
    out->prim_count = size_t(out->stats.primitive_count);
    out->nodes = static_cast<aacbvh_node *>(std::calloc(std::max<size_t>(1, out->node_count), sizeof(aacbvh_node)));
    out->prims = static_cast<uint32_t *>(std::calloc(std::max<size_t>(1, out->prim_count), sizeof(uint32_t)));
    if (!out->nodes || !out->prims) {
        ts_tree_free(out);
        return AACBVH_ERROR_OUT_OF_MEMORY;
    }
    s = aacbvh_bvh_get_nodes(bvh, 0, out->node_count, out->nodes);
    if (s == AACBVH_OK) s = aacbvh_bvh_get_primitive_indices(bvh, 0, out->prim_count, out->prims);
    if (s != AACBVH_OK) ts_tree_free(out);
    return s;
}

void ts_tree_free(ts_tree *tree) {
    std::free(tree->nodes);
    std::free(tree->prims);
    std::memset(tree, 0, sizeof *tree);
}

int ts_tree_equal(const ts_tree *a, const ts_tree *b) {
    return a->node_count == b->node_count && a->prim_count == b->prim_count &&
           std::memcmp(a->nodes, b->nodes, a->node_count * sizeof(aacbvh_node)) == 0 &&
           std::memcmp(a->prims, b->prims, a->prim_count * sizeof(uint32_t)) == 0;
}

namespace {

double node_area(const aacbvh_node &n) {
    double dx = double(n.upper[0]) - n.lower[0];
    double dy = double(n.upper[1]) - n.lower[1];
    double dz = double(n.upper[2]) - n.lower[2];
    if (dx < 0 || dy < 0 || dz < 0) return 0.0;
    return 2.0 * (dx * dy + dy * dz + dz * dx);
}

bool box_inside(const float *inner_lo, const float *inner_hi, const aacbvh_node &outer) {
    for (int k = 0; k < 3; ++k)
        if (!(inner_lo[k] >= outer.lower[k]) || !(inner_hi[k] <= outer.upper[k])) return false;
    return true;
}

struct Fail {
    char *msg;
    size_t size;
    int operator()(const char *fmt, ...) const {
        if (msg && size) {
            va_list ap;
            va_start(ap, fmt);
            std::vsnprintf(msg, size, fmt, ap);
            va_end(ap);
        }
        return 0;
    }
};

bool close_rel(double a, double b, double rel) {
    if (a == b) return true;
    return std::fabs(a - b) <= rel * std::max(std::fabs(a), std::fabs(b));
}

} // namespace

double ts_tree_sah_cost(const ts_tree *tree, double ct, double ci) {
    if (tree->node_count == 0) return 0.0;
    double root = node_area(tree->nodes[0]);
    if (root == 0.0) return 0.0;
    double sum = 0.0;
    for (size_t i = 0; i < tree->node_count; ++i) {
        const aacbvh_node &n = tree->nodes[i];
        sum += n.count == 0 ? ct * node_area(n) : ci * node_area(n) * double(n.count);
    }
    return sum / root;
}

int ts_check_tree(const aacbvh_bvh *bvh, const float *prim_boxes, size_t prim_total,
                  const unsigned char *present, uint32_t max_leaf_size, char *msg, size_t msg_size) {
    Fail bad{msg, msg_size};
    if (msg && msg_size) msg[0] = '\0';
    ts_tree t;
    aacbvh_status s = ts_tree_fetch(bvh, &t);
    if (s != AACBVH_OK) return bad("fetching the tree failed: %s (%s)", aacbvh_status_string(s),
                                    aacbvh_bvh_last_error(bvh));
    struct Guard {
        ts_tree *t;
        ~Guard() { ts_tree_free(t); }
    } guard{&t};

    size_t expected = 0;
    for (size_t i = 0; i < prim_total; ++i) expected += (!present || present[i]) ? 1 : 0;
    if (t.stats.primitive_count != expected)
        return bad("stats.primitive_count %llu, expected %zu", (unsigned long long)t.stats.primitive_count, expected);
    if (t.stats.invalid_primitive_count != prim_total - expected)
        return bad("stats.invalid_primitive_count %llu, expected %zu",
                    (unsigned long long)t.stats.invalid_primitive_count, prim_total - expected);

    double ct = 0.0, ci = 0.0;
    if (aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_TRAVERSAL_COST, &ct) != AACBVH_OK ||
        aacbvh_bvh_get_param_float(bvh, AACBVH_PARAM_INTERSECTION_COST, &ci) != AACBVH_OK)
        return bad("reading the cost parameters failed");

    if (expected == 0) {
        if (t.node_count != 0 || t.stats.leaf_count != 0 || t.stats.sah_cost != 0.0 || t.stats.max_depth != 0)
            return bad("empty scene: node_count %zu leaf_count %llu sah %g depth %u", t.node_count,
                        (unsigned long long)t.stats.leaf_count, t.stats.sah_cost, t.stats.max_depth);
        return 1;
    }
    if (t.node_count == 0) return bad("no nodes for %zu primitives", expected);

    std::vector<unsigned char> seen_node(t.node_count, 0);
    std::vector<unsigned char> seen_slot(t.prim_count, 0);
    std::vector<uint32_t> prim_hits(prim_total, 0);
    struct Item {
        size_t node;
        uint32_t depth;
    };
    std::vector<Item> stack{{0, 0}};
    seen_node[0] = 1;
    uint64_t leaves = 0, reached = 0, prims_in_leaves = 0;
    uint32_t max_depth = 0;
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        ++reached;
        const aacbvh_node &n = t.nodes[it.node];
        for (int k = 0; k < 3; ++k)
            if (!(n.lower[k] <= n.upper[k]))
                return bad("node %zu has an inverted or NaN box on axis %d", it.node, k);
        if (n.count == 0) {
            if (size_t(n.first) + 1 >= t.node_count || n.first == 0)
                return bad("inner node %zu has children %u, %u out of range (node count %zu)", it.node,
                            n.first, n.first + 1, t.node_count);
            for (uint32_t c = n.first; c <= n.first + 1; ++c) {
                if (seen_node[c]) return bad("node %u is reached twice", c);
                seen_node[c] = 1;
                if (!box_inside(t.nodes[c].lower, t.nodes[c].upper, n))
                    return bad("child %u's box is not inside its parent %zu's box", c, it.node);
                stack.push_back({c, it.depth + 1});
            }
        } else {
            ++leaves;
            max_depth = std::max(max_depth, it.depth);
            if (n.count > max_leaf_size)
                return bad("leaf %zu holds %u primitives, limit %u", it.node, n.count, max_leaf_size);
            if (size_t(n.first) + n.count > t.prim_count)
                return bad("leaf %zu's range [%u, %u) runs past the %zu primitive slots", it.node, n.first,
                            n.first + n.count, t.prim_count);
            for (uint32_t j = n.first; j < n.first + n.count; ++j) {
                if (seen_slot[j]) return bad("primitive slot %u is in two leaves", j);
                seen_slot[j] = 1;
                ++prims_in_leaves;
                uint32_t p = t.prims[j];
                if (p >= prim_total) return bad("slot %u holds primitive %u, scene has %zu", j, p, prim_total);
                if (present && !present[p]) return bad("primitive %u should have been left out", p);
                if (++prim_hits[p] > 1) return bad("primitive %u appears twice", p);
                if (!box_inside(prim_boxes + 6 * size_t(p), prim_boxes + 6 * size_t(p) + 3, n))
                    return bad("leaf %zu's box does not contain primitive %u's box", it.node, p);
            }
        }
    }
    if (reached != t.node_count) return bad("%llu of %zu nodes are reachable", (unsigned long long)reached, t.node_count);
    if (prims_in_leaves != expected)
        return bad("leaves hold %llu primitives, expected %zu", (unsigned long long)prims_in_leaves, expected);
    if (t.node_count != 2 * leaves - 1)
        return bad("node count %zu != 2 * %llu leaves - 1", t.node_count, (unsigned long long)leaves);
    if (t.stats.leaf_count != leaves)
        return bad("stats.leaf_count %llu, recount %llu", (unsigned long long)t.stats.leaf_count,
                    (unsigned long long)leaves);
    if (t.stats.max_depth != max_depth) return bad("stats.max_depth %u, recount %u", t.stats.max_depth, max_depth);
    double sah = ts_tree_sah_cost(&t, ct, ci);
    if (!close_rel(t.stats.sah_cost, sah, 1e-6))
        return bad("stats.sah_cost %.17g, recomputed %.17g (Ct %g, Ci %g)", t.stats.sah_cost, sah, ct, ci);
    return 1;
}

void ts_coords_bounds(const float *coords, size_t coord_count, float lo[3], float hi[3]) {
    for (int k = 0; k < 3; ++k) {
        lo[k] = coord_count ? INFINITY : -1.0f;
        hi[k] = coord_count ? -INFINITY : 1.0f;
    }
    for (size_t i = 0; i + 2 < coord_count; i += 3)
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], coords[i + k]);
            hi[k] = std::max(hi[k], coords[i + k]);
        }
}

void ts_jitter_coords(float *coords, size_t coord_count, float scale, uint64_t seed) {
    ts_rng rng;
    ts_rng_seed(&rng, seed);
    for (size_t i = 0; i < coord_count; ++i) coords[i] += scale * ts_rng_range(&rng, -1.0f, 1.0f);
}

uint64_t ts_memory_bytes(const aacbvh_bvh *bvh) {
    aacbvh_stats st;
    std::memset(&st, 0, sizeof st);
    st.struct_size = sizeof st;
    const aacbvh_status s = aacbvh_bvh_get_stats(bvh, &st);
    if (s != AACBVH_OK) fail_msg("aacbvh_bvh_get_stats: %s", aacbvh_status_string(s));
    return st.memory_bytes;
}

void ts_create(uint32_t threads, aacbvh_context **ctx, aacbvh_bvh **bvh) {
    aacbvh_status s = aacbvh_context_create(threads, ctx);
    if (s != AACBVH_OK) fail_msg("aacbvh_context_create: %s", aacbvh_status_string(s));
    s = aacbvh_bvh_create(*ctx, bvh);
    if (s != AACBVH_OK) fail_msg("aacbvh_bvh_create: %s", aacbvh_status_string(s));
}
