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

/// A random uniform integer in [lo, hi].
int32_t rng_int(ts_rng *rng, int32_t lo, int32_t hi) { return lo + int32_t(ts_rng_below(rng, uint32_t(hi - lo + 1))); }

/// A triangle of the coplanar scenes in lattice units of 1/256: a centre in
/// [-200, 200]^2 and corners up to 100 units (about 0.4) from it, with
/// non-zero area (checked exactly in integers).
void lattice_triangle(ts_rng *rng, int32_t xy[6]) {
    for (;;) {
        const int32_t cx = rng_int(rng, -200, 200), cy = rng_int(rng, -200, 200);
        for (int j = 0; j < 3; ++j) {
            xy[2 * j] = cx + rng_int(rng, -100, 100);
            xy[2 * j + 1] = cy + rng_int(rng, -100, 100);
        }
        const int64_t cross = int64_t(xy[2] - xy[0]) * (xy[5] - xy[1]) - int64_t(xy[3] - xy[1]) * (xy[4] - xy[0]);
        if (cross != 0) return;
    }
}

/// Adds a lattice triangle at height z; returns its first vertex.
uint32_t add_lattice_triangle(MeshBuilder &m, const int32_t xy[6], float z) {
    uint32_t first = 0;
    for (int j = 0; j < 3; ++j) {
        const uint32_t v = m.vertex(float(xy[2 * j]) / 256.0f, float(xy[2 * j + 1]) / 256.0f, z);
        if (j == 0) first = v;
    }
    m.tri(first, first + 1, first + 2);
    return first;
}

/// TS_SCENE_COPLANAR_STACK: see test_support.h.
void coplanar_stack(ts_rng *rng, size_t n, MeshBuilder &m) {
    static const float planes[4] = {0.0f, -1.0f, -3.0f, -7.0f};
    int32_t xy[6];
    float z = 0.0f;
    uint32_t last = 0; // first vertex of the previous new triangle
    for (size_t i = 0; i < n; ++i) {
        const uint32_t kind = i == 0 ? 0 : ts_rng_below(rng, 12);
        if (kind <= 7) { // a new triangle on a random plane
            lattice_triangle(rng, xy);
            z = planes[ts_rng_below(rng, 4)];
            last = add_lattice_triangle(m, xy, z);
        } else if (kind == 8) { // the same vertices again
            m.tri(last, last + 1, last + 2);
        } else if (kind == 9) { // rotated or reversed
            if (ts_rng_below(rng, 2)) m.tri(last + 1, last + 2, last);
            else m.tri(last + 1, last, last + 2);
        } else if (kind == 10) { // copied vertices, same values
            add_lattice_triangle(m, xy, z);
        } else { // the same outline on another plane
            add_lattice_triangle(m, xy, planes[ts_rng_below(rng, 4)]);
        }
    }
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
    case TS_SCENE_COPLANAR: return "coplanar";
    case TS_SCENE_COPLANAR_STACK: return "coplanar-stack";
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
    case TS_SCENE_COPLANAR:
        for (size_t i = 0; i < n; ++i) {
            int32_t xy[6];
            lattice_triangle(&rng, xy);
            add_lattice_triangle(m, xy, 0.0f);
        }
        break;
    case TS_SCENE_COPLANAR_STACK:
        coplanar_stack(&rng, n, m);
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

int ts_tree_equal(const ts_tree *a, const ts_tree *b) { return ts_tree_diff(a, b, nullptr, 0); }

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

int ts_tree_diff(const ts_tree *a, const ts_tree *b, char *msg, size_t msg_size) {
    Fail bad{msg, msg_size};
    if (msg && msg_size) msg[0] = '\0';
    if (a->node_count != b->node_count || a->prim_count != b->prim_count)
        return bad("%zu nodes and %zu primitives vs %zu nodes and %zu primitives", a->node_count, a->prim_count,
                   b->node_count, b->prim_count);
    for (size_t i = 0; i < a->node_count; ++i) {
        const aacbvh_node &x = a->nodes[i], &y = b->nodes[i];
        if (std::memcmp(&x, &y, sizeof x) != 0)
            return bad("node %zu: box (%a %a %a, %a %a %a) first %u count %u vs box (%a %a %a, %a %a %a) first %u "
                       "count %u",
                       i, double(x.lower[0]), double(x.lower[1]), double(x.lower[2]), double(x.upper[0]),
                       double(x.upper[1]), double(x.upper[2]), x.first, x.count, double(y.lower[0]),
                       double(y.lower[1]), double(y.lower[2]), double(y.upper[0]), double(y.upper[1]),
                       double(y.upper[2]), y.first, y.count);
    }
    for (size_t i = 0; i < a->prim_count; ++i)
        if (a->prims[i] != b->prims[i])
            return bad("primitive slot %zu: %u vs %u", i, a->prims[i], b->prims[i]);
    return 1;
}

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

void ts_set_mesh(aacbvh_bvh *bvh, const ts_mesh *mesh) {
    const aacbvh_status s = aacbvh_bvh_set_triangles(bvh, mesh->vertices, mesh->vertex_count, 3 * sizeof(float),
                                                     mesh->indices, mesh->triangle_count);
    if (s != AACBVH_OK) fail_msg("aacbvh_bvh_set_triangles: %s (%s)", aacbvh_status_string(s), aacbvh_bvh_last_error(bvh));
}

void ts_jitter_mesh(ts_mesh *mesh, uint64_t seed) {
    const size_t coords = 3 * mesh->vertex_count;
    float lo[3], hi[3];
    ts_coords_bounds(mesh->vertices, coords, lo, hi);
    ts_jitter_coords(mesh->vertices, coords, 0.05f * (hi[0] - lo[0] + hi[1] - lo[1] + hi[2] - lo[2] + 1e-3f), seed);
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

// ---- Comparing answers -----------------------------------------------------

namespace {

float signed_zero(ts_rng *rng) { return (ts_rng_next(rng) & 1) ? 0.0f : -0.0f; }

// Makes the ray invalid: a NaN or infinite field, or a zero direction.
void make_invalid(ts_rng *rng, aacbvh_ray &r) {
    const int k = int(ts_rng_below(rng, 3));
    switch (ts_rng_below(rng, 8)) {
    case 0: r.org[k] = NAN; break;
    case 1: r.dir[k] = NAN; break;
    case 2: r.tmin = NAN; break;
    case 3: r.tmax = NAN; break;
    case 4: r.org[k] = (ts_rng_next(rng) & 1) ? INFINITY : -INFINITY; break;
    case 5: r.dir[k] = (ts_rng_next(rng) & 1) ? INFINITY : -INFINITY; break;
    default:
        for (int j = 0; j < 3; ++j) r.dir[j] = signed_zero(rng);
        break;
    }
}

// A window [tmin, tmax]; t = 1 is the target.
void pick_window(ts_rng *rng, aacbvh_ray &r) {
    const uint32_t kind = ts_rng_below(rng, 100);
    r.tmin = 0.0f;
    r.tmax = INFINITY;
    if (kind < 55) return;
    if (kind < 70) { // bounded
        r.tmin = ts_rng_range(rng, 0.0f, 0.8f);
        r.tmax = ts_rng_range(rng, r.tmin, 1.5f);
    } else if (kind < 76) {
        r.tmin = -INFINITY;
    } else if (kind < 82) { // partly negative
        r.tmin = ts_rng_range(rng, -1.0f, 0.5f);
        r.tmax = r.tmin + ts_rng_range(rng, 0.0f, 1.5f);
    } else if (kind < 86) { // wholly negative: what lies behind the origin
        r.tmax = ts_rng_range(rng, -1.5f, 0.0f);
        r.tmin = (ts_rng_next(rng) & 1) ? -INFINITY : r.tmax - ts_rng_range(rng, 0.0f, 1.0f);
    } else if (kind < 90) { // one point
        r.tmin = r.tmax = (ts_rng_next(rng) & 1) ? 1.0f : ts_rng_range(rng, -1.0f, 1.5f);
    } else if (kind < 93) { // empty
        r.tmin = ts_rng_range(rng, -1.0f, 1.5f);
        r.tmax = std::nextafter(r.tmin, -INFINITY);
    }
}

std::string describe_answer(const ts_answers *a, size_t i) {
    const aacbvh_hit &h = a->hits[i];
    char buf[160];
    std::snprintf(buf, sizeof buf, "t %a u %a v %a prim %u occluded %u", double(h.t), double(h.u), double(h.v),
                  h.prim_id, unsigned(a->occluded[i]));
    return buf;
}

// Why answer i of `a` is malformed, or "" when it is not.
const char *malformed(const ts_answers *a, size_t i) {
    const aacbvh_hit &h = a->hits[i];
    if (a->occluded[i] > 1) return "occluded is neither 0 nor 1";
    if ((h.prim_id != AACBVH_INVALID_ID) != (a->occluded[i] == 1)) return "occluded disagrees with the closest hit";
    if (h.prim_id == AACBVH_INVALID_ID && !(h.t == INFINITY && h.u == 0.0f && h.v == 0.0f))
        return "a miss is not (t, u, v) = (inf, 0, 0)";
    return "";
}

} // namespace

aacbvh_ray *ts_make_rays(const float *coords, size_t coord_count, size_t count, uint64_t seed) {
    auto *rays = static_cast<aacbvh_ray *>(std::malloc(std::max<size_t>(1, count) * sizeof(aacbvh_ray)));
    if (!rays) return nullptr;
    float lo[3], hi[3];
    ts_coords_bounds(coords, coord_count, lo, hi);
    const uint32_t points = uint32_t(coord_count / 3);
    ts_rng rng;
    ts_rng_seed(&rng, seed);
    for (size_t i = 0; i < count; ++i) {
        aacbvh_ray &r = rays[i];
        float target[3];
        for (int k = 0; k < 3; ++k) {
            const float ext = hi[k] - lo[k] > 0.0f ? hi[k] - lo[k] : 1.0f;
            r.org[k] = ts_rng_range(&rng, lo[k] - 0.5f * ext, hi[k] + 0.5f * ext);
            target[k] = ts_rng_range(&rng, lo[k], hi[k]);
        }
        if (points > 0 && (ts_rng_next(&rng) & 1)) { // a vertex or box corner
            const size_t v = ts_rng_below(&rng, points);
            for (int k = 0; k < 3; ++k) target[k] = coords[3 * v + k];
        }
        if (points > 0 && ts_rng_below(&rng, 8) == 0) { // the origin on one of the scene's planes
            const int k = int(ts_rng_below(&rng, 3));
            r.org[k] = coords[3 * size_t(ts_rng_below(&rng, points)) + k];
        }
        for (int k = 0; k < 3; ++k) r.dir[k] = target[k] - r.org[k];
        const uint32_t kind = ts_rng_below(&rng, 100);
        const int axis = int(ts_rng_below(&rng, 3));
        if (kind < 25) { // along an axis, level with the target on the others
            for (int k = 0; k < 3; ++k)
                if (k != axis) {
                    r.dir[k] = signed_zero(&rng);
                    r.org[k] = target[k];
                }
        } else if (kind < 40) { // in a coordinate plane through the target
            r.dir[axis] = signed_zero(&rng);
            r.org[axis] = target[axis];
        }
        if (r.dir[0] == 0.0f && r.dir[1] == 0.0f && r.dir[2] == 0.0f)
            r.dir[kind < 25 ? axis : (axis + 1) % 3] = (ts_rng_next(&rng) & 1) ? 1.0f : -1.0f;
        pick_window(&rng, r);
        if (ts_rng_below(&rng, 20) == 0) make_invalid(&rng, r);
    }
    return rays;
}

void ts_answers_query(const aacbvh_bvh *bvh, const aacbvh_ray *rays, size_t count, ts_answers *out) {
    static unsigned garbage = 0x5A;
    garbage = (garbage * 37 + 11) & 0xFF;
    out->count = count;
    out->hits = static_cast<aacbvh_hit *>(std::malloc(std::max<size_t>(1, count) * sizeof(aacbvh_hit)));
    out->occluded = static_cast<uint8_t *>(std::malloc(std::max<size_t>(1, count)));
    if (!out->hits || !out->occluded) fail_msg("ts_answers_query: out of memory for %zu rays", count);
    std::memset(out->hits, int(garbage), count * sizeof(aacbvh_hit));
    std::memset(out->occluded, int(garbage ^ 0xFF), count);
    aacbvh_status s = aacbvh_bvh_intersect(bvh, rays, out->hits, count);
    if (s != AACBVH_OK)
        fail_msg("aacbvh_bvh_intersect: %s (%s)", aacbvh_status_string(s), aacbvh_bvh_last_error(bvh));
    s = aacbvh_bvh_occluded(bvh, rays, out->occluded, count);
    if (s != AACBVH_OK)
        fail_msg("aacbvh_bvh_occluded: %s (%s)", aacbvh_status_string(s), aacbvh_bvh_last_error(bvh));
}

void ts_answers_free(ts_answers *answers) {
    std::free(answers->hits);
    std::free(answers->occluded);
    std::memset(answers, 0, sizeof *answers);
}

int ts_answers_equal(const ts_answers *reference, const ts_answers *variant, const aacbvh_ray *rays, char *msg,
                     size_t msg_size) {
    Fail bad{msg, msg_size};
    if (msg && msg_size) msg[0] = '\0';
    if (reference->count != variant->count)
        return bad("%zu answers vs %zu", reference->count, variant->count);
    for (size_t i = 0; i < reference->count; ++i) {
        const char *why_ref = malformed(reference, i), *why_var = malformed(variant, i);
        const bool same = std::memcmp(&reference->hits[i], &variant->hits[i], sizeof(aacbvh_hit)) == 0 &&
                          reference->occluded[i] == variant->occluded[i];
        if (same && !*why_ref && !*why_var) continue;
        std::string ray;
        if (rays) {
            const aacbvh_ray &r = rays[i];
            char buf[256];
            std::snprintf(buf, sizeof buf, " (org %a %a %a, dir %a %a %a, [%a, %a])", double(r.org[0]),
                          double(r.org[1]), double(r.org[2]), double(r.dir[0]), double(r.dir[1]), double(r.dir[2]),
                          double(r.tmin), double(r.tmax));
            ray = buf;
        }
        const char *why = *why_ref ? why_ref : *why_var ? why_var : "the answers differ";
        const char *where = *why_ref ? " in the reference" : *why_var ? " in the variant" : "";
        return bad("ray %zu%s: %s%s; reference %s, variant %s", i, ray.c_str(), why, where,
                   describe_answer(reference, i).c_str(), describe_answer(variant, i).c_str());
    }
    return 1;
}

size_t ts_compare_answers(const aacbvh_bvh *reference, const aacbvh_bvh *variant, const aacbvh_ray *rays,
                          size_t count, const char *what) {
    ts_answers a, b;
    char msg[768];
    ts_answers_query(reference, rays, count, &a);
    ts_answers_query(variant, rays, count, &b);
    if (!ts_answers_equal(&a, &b, rays, msg, sizeof msg)) fail_msg("%s: %s", what, msg);
    size_t hits = 0;
    for (size_t i = 0; i < count; ++i) hits += a.hits[i].prim_id != AACBVH_INVALID_ID;
    ts_answers_free(&a);
    ts_answers_free(&b);
    return hits;
}

void ts_compare_batch_orders(const aacbvh_bvh *bvh, const aacbvh_ray *rays, size_t count, uint64_t seed,
                             const char *what) {
    std::vector<size_t> order(count);
    std::vector<aacbvh_ray> moved(std::max<size_t>(1, count));
    ts_answers first, again, put_back;
    char msg[768];
    ts_rng rng;
    ts_rng_seed(&rng, seed);
    ts_answers_query(bvh, rays, count, &first);
    put_back.count = count;
    put_back.hits = static_cast<aacbvh_hit *>(std::malloc(std::max<size_t>(1, count) * sizeof(aacbvh_hit)));
    put_back.occluded = static_cast<uint8_t *>(std::malloc(std::max<size_t>(1, count)));
    if (!put_back.hits || !put_back.occluded) fail_msg("ts_compare_batch_orders: out of memory");
    for (int pass = 0; pass < 2; ++pass) {
        for (size_t i = 0; i < count; ++i) order[i] = pass == 0 ? count - 1 - i : i;
        if (pass == 1) // Fisher-Yates
            for (size_t i = count; i > 1; --i) std::swap(order[i - 1], order[ts_rng_below(&rng, uint32_t(i))]);
        for (size_t i = 0; i < count; ++i) moved[i] = rays[order[i]];
        ts_answers_query(bvh, moved.data(), count, &again);
        for (size_t i = 0; i < count; ++i) {
            put_back.hits[order[i]] = again.hits[i];
            put_back.occluded[order[i]] = again.occluded[i];
        }
        ts_answers_free(&again);
        if (!ts_answers_equal(&first, &put_back, rays, msg, sizeof msg))
            fail_msg("%s, rays %s: %s", what, pass == 0 ? "reversed" : "shuffled", msg);
    }
    ts_answers_free(&first);
    ts_answers_free(&put_back);
}
