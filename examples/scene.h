// Triangle scenes for the examples and benchmarks: Wavefront OBJ loading and a
// deterministic generated scene for machines without the OBJ files.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

/// SplitMix64 (Steele, Lea, Flood 2014): a tiny, well-mixed generator whose
/// output is fixed by the seed on every platform, unlike std:: distributions.
/// The generated scenes and the benchmark's rays both draw from it.
struct SplitMix64 {
    uint64_t state;
    uint64_t next() {
        uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
};

/// An indexed triangle mesh, laid out as aacbvh_bvh_set_triangles() takes it.
struct Scene {
    std::string name;               ///< file name without directory and ".obj", or a generated name
    std::vector<float> vertices;    ///< x, y, z per vertex (stride 12 bytes)
    std::vector<uint32_t> indices;  ///< three 0-based vertex indices per triangle

    size_t vertex_count() const { return vertices.size() / 3; }
    size_t triangle_count() const { return indices.size() / 3; }
};

/// Loads the triangles of an OBJ file (polygons split by fan; normals, texture
/// coordinates and materials ignored). Uses tinyobjloader when the build found
/// it (AACBVH_HAVE_TINYOBJLOADER), else a small built-in reader of "v" and "f"
/// lines. Returns false with a message in `err` on failure; `out` is then empty.
bool load_obj(const std::string &path, Scene &out, std::string &err);

/// Knobs of the generated scene; the defaults give 237,056 triangles (a terrain
/// of 2 * 256^2 and 48 spheres of 4 * rings * (rings - 1) each).
struct ProceduralConfig {
    uint32_t terrain_cells = 256;   ///< the terrain is a grid of cells x cells quads
    uint32_t sphere_count = 48;     ///< bumpy spheres scattered over the terrain
    uint32_t sphere_rings = 24;     ///< latitude rings per sphere (2 * rings segments around)
    uint64_t seed = 1;              ///< the same seed always gives the same scene
};

/// Generates a terrain of hills with bumpy spheres of many sizes resting on it:
/// large flat triangles next to small dense clusters, so builders differ.
/// Deterministic: the same config gives the same scene on every run.
Scene make_procedural_scene(const ProceduralConfig &config = ProceduralConfig());

/// The *.obj files directly in `scenes_dir`, sorted by name; empty when the
/// directory is NULL, empty or absent.
std::vector<std::string> default_scene_paths(const char *scenes_dir);
