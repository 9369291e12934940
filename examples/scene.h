/* Triangle scenes for the examples and benchmarks: Wavefront OBJ loading, a
 * deterministic generated scene for machines without the OBJ files, and
 * bounds. One implementation (scene.cpp) behind two faces: the scene_mesh
 * functions for the C99 examples, and Scene, load_obj() and
 * make_procedural_scene() for the C++ ones. */
#ifndef AACBVH_EXAMPLES_SCENE_H
#define AACBVH_EXAMPLES_SCENE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* An indexed triangle mesh in malloc'd arrays, laid out as
 * aacbvh_bvh_set_triangles() takes it (vertex stride 12 bytes). */
typedef struct scene_mesh {
    float *vertices;    /* x, y, z per vertex */
    size_t vertex_count;
    uint32_t *indices;  /* three 0-based vertex indices per triangle */
    size_t triangle_count;
} scene_mesh;

/* Knobs of the generated scene (see make_procedural_scene below). */
typedef struct scene_procedural_config {
    uint32_t terrain_cells; /* the terrain is a grid of cells x cells quads */
    uint32_t sphere_count;  /* bumpy spheres scattered over the terrain */
    uint32_t sphere_rings;  /* latitude rings per sphere (2 * rings segments around) */
    uint64_t seed;          /* the same seed always gives the same scene */
} scene_procedural_config;

/* The default knobs: 237,056 triangles (a terrain of 2 * 256^2 and 48 spheres of 4 * 24 * 23). */
scene_procedural_config scene_procedural_defaults(void);

/* Loads the triangles of an OBJ file into `out` (see load_obj below). Returns
 * 1, or 0 with `out` empty and a message in err[0 .. err_size) (err may be NULL). */
int scene_mesh_load_obj(const char *path, scene_mesh *out, char *err, size_t err_size);

/* Generates the scene of `config` (NULL: the defaults) into `out`. Returns 1,
 * or 0 with `out` empty when memory runs out. */
int scene_mesh_procedural(const scene_procedural_config *config, scene_mesh *out);

/* Frees the arrays of a loaded or generated mesh and empties it (NULL is fine). */
void scene_mesh_free(scene_mesh *mesh);

/* Axis-aligned bounds of `vertex_count` points (x, y, z each); all zero when
 * there are none. */
void scene_bounds(const float *xyz, size_t vertex_count, float lower[3], float upper[3]);

#ifdef __cplusplus
} /* extern "C" */

#include <string>
#include <vector>

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

/// scene_procedural_config with the defaults filled in.
struct ProceduralConfig : scene_procedural_config {
    ProceduralConfig() : scene_procedural_config{256, 48, 24, 1} {}
};

/// Generates a terrain of hills with bumpy spheres of many sizes resting on it:
/// large flat triangles next to small dense clusters, so builders differ.
/// Deterministic: the same config gives the same scene on every run.
Scene make_procedural_scene(const scene_procedural_config &config = ProceduralConfig());

/// The *.obj files directly in `scenes_dir`, sorted by name; empty when the
/// directory is NULL, empty or absent.
std::vector<std::string> default_scene_paths(const char *scenes_dir);

#endif /* __cplusplus */

#endif /* AACBVH_EXAMPLES_SCENE_H */
