#include "scene.h"
#include "random.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <cctype>
#include <cstdio>
#include <exception>

#ifdef AACBVH_HAVE_TINYOBJLOADER
#include <tiny_obj_loader.h>
#endif

namespace fs = std::filesystem;

namespace {

std::string scene_name_of(const std::string &path) {
    return fs::path(path).stem().string();
}

#ifdef AACBVH_HAVE_TINYOBJLOADER

bool load_obj_tinyobj(const std::string &path, Scene &out, std::string &err) {
    tinyobj::ObjReaderConfig config;
    config.triangulate = true;
    config.vertex_color = false;
    tinyobj::ObjReader reader;
    if (!reader.ParseFromFile(path, config)) {
        err = reader.Error().empty() ? "cannot read " + path : reader.Error();
        while (!err.empty() && (err.back() == '\n' || err.back() == '\r'))
            err.pop_back();
        return false;
    }
    const std::vector<tinyobj::real_t> &v = reader.GetAttrib().vertices;
    const size_t vertex_count = v.size() / 3;
    if (vertex_count > std::numeric_limits<uint32_t>::max()) {
        err = path + ": too many vertices";
        return false;
    }
    out.vertices.resize(v.size() - v.size() % 3);
    for (size_t i = 0; i < out.vertices.size(); ++i)
        out.vertices[i] = static_cast<float>(v[i]);

    for (const tinyobj::shape_t &shape : reader.GetShapes()) {
        const tinyobj::mesh_t &mesh = shape.mesh;
        size_t offset = 0;
        for (unsigned char corners : mesh.num_face_vertices) {
            // After triangulation every face has three corners; anything else
            // (a degenerate line) is skipped.
            if (corners == 3) {
                for (size_t k = 0; k < 3; ++k) {
                    const int index = mesh.indices[offset + k].vertex_index;
                    if (index < 0 || static_cast<size_t>(index) >= vertex_count) {
                        err = path + ": face in shape '" + shape.name + "' refers to a missing vertex";
                        return false;
                    }
                    out.indices.push_back(static_cast<uint32_t>(index));
                }
            }
            offset += corners;
        }
    }
    return true;
}

#else

// Parses one face corner ("7", "7/1", "7//3", "-2/1/1") into a 0-based index.
bool parse_corner(const char *&p, size_t vertex_count, uint32_t &index) {
    char *end = nullptr;
    errno = 0;
    const long long value = std::strtoll(p, &end, 10);
    if (end == p || errno != 0)
        return false;
    p = end;
    while (*p && !std::isspace(static_cast<unsigned char>(*p)))
        ++p;  // texture and normal indices are ignored
    long long zero_based = value > 0 ? value - 1 : static_cast<long long>(vertex_count) + value;
    if (value == 0 || zero_based < 0 || static_cast<unsigned long long>(zero_based) >= vertex_count)
        return false;
    index = static_cast<uint32_t>(zero_based);
    return true;
}

bool load_obj_builtin(const std::string &path, Scene &out, std::string &err) {
    std::ifstream file(path, std::ios::binary);
    if (!file) {
        err = "cannot open " + path + ": " + std::strerror(errno);
        return false;
    }
    std::string line;
    std::vector<uint32_t> polygon;
    size_t line_number = 0;
    while (std::getline(file, line)) {
        ++line_number;
        const char *p = line.c_str();
        while (*p == ' ' || *p == '\t')
            ++p;
        const bool is_vertex = p[0] == 'v' && (p[1] == ' ' || p[1] == '\t');
        const bool is_face = p[0] == 'f' && (p[1] == ' ' || p[1] == '\t');
        if (is_vertex) {
            char *end = nullptr;
            ++p;
            for (int k = 0; k < 3; ++k) {
                const float value = std::strtof(p, &end);
                if (end == p) {
                    err = path + ":" + std::to_string(line_number) + ": bad vertex";
                    return false;
                }
                out.vertices.push_back(value);
                p = end;
            }
        } else if (is_face) {
            ++p;
            polygon.clear();
            const size_t vertex_count = out.vertices.size() / 3;
            for (;;) {
                while (*p == ' ' || *p == '\t' || *p == '\r')
                    ++p;
                if (*p == '\0' || *p == '#')
                    break;
                uint32_t index = 0;
                if (!parse_corner(p, vertex_count, index)) {
                    err = path + ":" + std::to_string(line_number) + ": bad face index";
                    return false;
                }
                polygon.push_back(index);
            }
            // Fan triangulation, as the scenes' README says their polygons were split.
            for (size_t k = 2; k < polygon.size(); ++k) {
                out.indices.push_back(polygon[0]);
                out.indices.push_back(polygon[k - 1]);
                out.indices.push_back(polygon[k]);
            }
        }
    }
    if (file.bad()) {
        err = "error reading " + path;
        return false;
    }
    return true;
}

#endif

// Value noise: a random value per lattice point, smoothly interpolated.
double lattice_value(int64_t x, int64_t z, uint64_t seed) {
    SplitMix64 r(seed ^ (static_cast<uint64_t>(x) * 0x8CB92BA72F3D8DD7ull) ^
                 (static_cast<uint64_t>(z) * 0xD6E8FEB86659FD93ull));
    return r.uniform();
}

double value_noise(double x, double z, uint64_t seed) {
    const double fx = std::floor(x), fz = std::floor(z);
    const int64_t ix = static_cast<int64_t>(fx), iz = static_cast<int64_t>(fz);
    double tx = x - fx, tz = z - fz;
    tx = tx * tx * (3.0 - 2.0 * tx);
    tz = tz * tz * (3.0 - 2.0 * tz);
    const double a = lattice_value(ix, iz, seed), b = lattice_value(ix + 1, iz, seed);
    const double c = lattice_value(ix, iz + 1, seed), d = lattice_value(ix + 1, iz + 1, seed);
    return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * tz;
}

constexpr double kTerrainHalfSize = 100.0;

double terrain_height(double x, double z, uint64_t seed) {
    double height = 0.0, amplitude = 18.0, frequency = 1.0 / 40.0;
    for (int octave = 0; octave < 5; ++octave) {
        height += amplitude * (value_noise(x * frequency, z * frequency, seed + octave) - 0.5);
        amplitude *= 0.45;
        frequency *= 2.1;
    }
    return height;
}

uint32_t add_vertex(Scene &scene, double x, double y, double z) {
    const uint32_t index = static_cast<uint32_t>(scene.vertex_count());
    scene.vertices.push_back(static_cast<float>(x));
    scene.vertices.push_back(static_cast<float>(y));
    scene.vertices.push_back(static_cast<float>(z));
    return index;
}

void add_triangle(Scene &scene, uint32_t a, uint32_t b, uint32_t c) {
    scene.indices.push_back(a);
    scene.indices.push_back(b);
    scene.indices.push_back(c);
}

void add_terrain(Scene &scene, uint32_t cells, uint64_t seed) {
    const uint32_t base = static_cast<uint32_t>(scene.vertex_count());
    const double step = 2.0 * kTerrainHalfSize / cells;
    for (uint32_t j = 0; j <= cells; ++j)
        for (uint32_t i = 0; i <= cells; ++i) {
            const double x = -kTerrainHalfSize + i * step, z = -kTerrainHalfSize + j * step;
            add_vertex(scene, x, terrain_height(x, z, seed), z);
        }
    const uint32_t row = cells + 1;
    for (uint32_t j = 0; j < cells; ++j)
        for (uint32_t i = 0; i < cells; ++i) {
            const uint32_t v00 = base + j * row + i, v10 = v00 + 1;
            const uint32_t v01 = v00 + row, v11 = v01 + 1;
            add_triangle(scene, v00, v10, v11);
            add_triangle(scene, v00, v11, v01);
        }
}

void add_bumpy_sphere(Scene &scene, double cx, double cy, double cz, double radius,
                      uint32_t rings, int lobes, double phase) {
    const uint32_t segments = 2 * rings;
    const double pi = 3.14159265358979323846;
    auto surface = [&](double theta, double phi) {
        const double bump = 1.0 + 0.18 * std::sin(lobes * theta + phase) * std::sin(lobes * phi);
        const double r = radius * bump;
        return add_vertex(scene, cx + r * std::sin(theta) * std::cos(phi), cy + r * std::cos(theta),
                          cz + r * std::sin(theta) * std::sin(phi));
    };
    const uint32_t top = add_vertex(scene, cx, cy + radius, cz);
    const uint32_t first_ring = static_cast<uint32_t>(scene.vertex_count());
    for (uint32_t ring = 1; ring < rings; ++ring)
        for (uint32_t s = 0; s < segments; ++s)
            surface(pi * ring / rings, 2.0 * pi * s / segments);
    const uint32_t bottom = add_vertex(scene, cx, cy - radius, cz);

    auto at = [&](uint32_t ring, uint32_t s) { return first_ring + (ring - 1) * segments + s % segments; };
    for (uint32_t s = 0; s < segments; ++s) {
        add_triangle(scene, top, at(1, s + 1), at(1, s));
        add_triangle(scene, bottom, at(rings - 1, s), at(rings - 1, s + 1));
    }
    for (uint32_t ring = 1; ring + 1 < rings; ++ring)
        for (uint32_t s = 0; s < segments; ++s) {
            add_triangle(scene, at(ring, s), at(ring, s + 1), at(ring + 1, s + 1));
            add_triangle(scene, at(ring, s), at(ring + 1, s + 1), at(ring + 1, s));
        }
}

} // namespace

bool load_obj(const std::string &path, Scene &out, std::string &err) {
    out = Scene();
    out.name = scene_name_of(path);
    err.clear();
#ifdef AACBVH_HAVE_TINYOBJLOADER
    const bool ok = load_obj_tinyobj(path, out, err);
#else
    const bool ok = load_obj_builtin(path, out, err);
#endif
    if (!ok) {
        out.vertices.clear();
        out.indices.clear();
    }
    return ok;
}

Scene make_procedural_scene(const scene_procedural_config &config) {
    Scene scene;
    const uint32_t cells = std::max<uint32_t>(config.terrain_cells, 1);
    const uint32_t rings = std::max<uint32_t>(config.sphere_rings, 3);
    scene.name = "procedural-" + std::to_string(cells) + "-" + std::to_string(config.sphere_count) +
                 "x" + std::to_string(rings);
    const size_t sphere_triangles = size_t(4) * rings * (rings - 1);
    scene.indices.reserve(3 * (size_t(2) * cells * cells + config.sphere_count * sphere_triangles));

    add_terrain(scene, cells, config.seed);

    SplitMix64 random(config.seed * 0x2545F4914F6CDD1Dull + 17);
    for (uint32_t k = 0; k < config.sphere_count; ++k) {
        // Log-uniform radii give a few large spheres and many small ones,
        // with a cluster of small ones near the centre.
        const double radius = 0.4 * std::exp(random.uniform(0.0, std::log(30.0)));
        const double spread = (k % 3 == 0) ? 0.15 : 0.9;
        const double x = random.uniform(-spread, spread) * kTerrainHalfSize;
        const double z = random.uniform(-spread, spread) * kTerrainHalfSize;
        const double y = terrain_height(x, z, config.seed) + 0.7 * radius;
        const int lobes = 3 + static_cast<int>(random.next() % 6);
        add_bumpy_sphere(scene, x, y, z, radius, rings, lobes, random.uniform(0.0, 6.283));
    }
    return scene;
}

std::vector<std::string> default_scene_paths(const char *scenes_dir) {
    std::vector<std::string> paths;
    if (scenes_dir == nullptr || *scenes_dir == '\0')
        return paths;
    std::error_code ec;
    fs::directory_iterator it(scenes_dir, ec), end;
    for (; !ec && it != end; it.increment(ec)) {
        const fs::path &p = it->path();
        std::error_code type_ec;
        if (p.extension() == ".obj" && fs::is_regular_file(p, type_ec))
            paths.push_back(p.string());
    }
    std::sort(paths.begin(), paths.end());
    return paths;
}

// ---- the C face (scene.h): copies into malloc'd arrays; no exception leaves ----

namespace {

void set_error(char *err, size_t err_size, const std::string &message) {
    if (err != nullptr && err_size > 0)
        std::snprintf(err, err_size, "%s", message.c_str());
}

/// Moves a Scene's arrays into `out` (malloc'd, for scene_mesh_free).
bool to_mesh(const Scene &scene, scene_mesh *out) {
    *out = scene_mesh{nullptr, 0, nullptr, 0};
    // malloc(0) may return NULL: ask for at least one element.
    float *v = static_cast<float *>(std::malloc(std::max<size_t>(scene.vertices.size(), 1) * sizeof(float)));
    uint32_t *t = static_cast<uint32_t *>(std::malloc(std::max<size_t>(scene.indices.size(), 1) * sizeof(uint32_t)));
    if (v == nullptr || t == nullptr) {
        std::free(v);
        std::free(t);
        return false;
    }
    std::copy(scene.vertices.begin(), scene.vertices.end(), v);
    std::copy(scene.indices.begin(), scene.indices.end(), t);
    *out = scene_mesh{v, scene.vertex_count(), t, scene.triangle_count()};
    return true;
}

} // namespace

extern "C" scene_procedural_config scene_procedural_defaults(void) { return ProceduralConfig(); }

extern "C" int scene_mesh_load_obj(const char *path, scene_mesh *out, char *err, size_t err_size) {
    *out = scene_mesh{nullptr, 0, nullptr, 0};
    try {
        Scene scene;
        std::string message;
        if (!load_obj(path, scene, message)) {
            set_error(err, err_size, message);
            return 0;
        }
        if (!to_mesh(scene, out)) {
            set_error(err, err_size, std::string(path) + ": out of memory");
            return 0;
        }
        return 1;
    } catch (const std::exception &e) {  // bad_alloc, or a loader's own
        set_error(err, err_size, std::string(path) + ": " + e.what());
        return 0;
    }
}

extern "C" int scene_mesh_procedural(const scene_procedural_config *config, scene_mesh *out) {
    *out = scene_mesh{nullptr, 0, nullptr, 0};
    try {
        return to_mesh(make_procedural_scene(config ? *config : ProceduralConfig()), out) ? 1 : 0;
    } catch (const std::exception &) {
        return 0;
    }
}

extern "C" void scene_mesh_free(scene_mesh *mesh) {
    if (mesh == nullptr)
        return;
    std::free(mesh->vertices);
    std::free(mesh->indices);
    *mesh = scene_mesh{nullptr, 0, nullptr, 0};
}

extern "C" void scene_bounds(const float *xyz, size_t vertex_count, float lower[3], float upper[3]) {
    for (int k = 0; k < 3; ++k) {
        lower[k] = vertex_count ? std::numeric_limits<float>::infinity() : 0.0f;
        upper[k] = vertex_count ? -std::numeric_limits<float>::infinity() : 0.0f;
    }
    for (size_t i = 0; i < vertex_count; ++i)
        for (int k = 0; k < 3; ++k) {
            lower[k] = std::min(lower[k], xyz[3 * i + k]);
            upper[k] = std::max(upper[k], xyz[3 * i + k]);
        }
}
