// Command-line helpers the benchmark programs share (aacbvh-bench,
// aacbvh-hit-accuracy): lists, numbers, the scenes named on the command line,
// and the CPU model every reported figure is named with.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <aacbvh/aacbvh.h>

#include "scene.h"

namespace bench {

/// The non-empty parts of `s` between `sep` characters.
inline std::vector<std::string> split(const std::string &s, char sep) {
    std::vector<std::string> out;
    size_t start = 0;
    while (start <= s.size()) {
        const size_t end = s.find(sep, start);
        const std::string part = s.substr(start, end == std::string::npos ? std::string::npos : end - start);
        if (!part.empty()) out.push_back(part);
        if (end == std::string::npos) break;
        start = end + 1;
    }
    return out;
}

/// A whole decimal number without sign; false for anything else.
inline bool parse_uint(const char *s, uint64_t &out) {
    char *end = nullptr;
    const unsigned long long v = std::strtoull(s, &end, 10);
    if (!s[0] || *end || s[0] == '-') return false;
    out = v;
    return true;
}

/// A --threads list ("1,2,4"): counts from 1 to 1024; false for anything else.
inline bool parse_thread_list(const char *s, std::vector<uint32_t> &out) {
    out.clear();
    for (const std::string &t : split(s, ',')) {
        uint64_t v = 0;
        if (!parse_uint(t.c_str(), v) || v == 0 || v > 1024) return false;
        out.push_back(uint32_t(v));
    }
    return !out.empty();
}

/// What parse_shared_option() made of argv[i].
enum class Parsed { Taken, Bad, Other };

/// The options aacbvh-batch-threads and aacbvh-build-phases share: --scenes
/// LIST, --threads LIST (parse_thread_list) and --runs N (1 to 1000). Taken:
/// i now points at the option's value; Bad: a missing or wrong value; Other:
/// not one of these.
inline Parsed parse_shared_option(int argc, char **argv, int &i, std::vector<std::string> &scenes,
                                  std::vector<uint32_t> &threads, int &runs) {
    const char *a = argv[i];
    const bool known = !std::strcmp(a, "--scenes") || !std::strcmp(a, "--threads") || !std::strcmp(a, "--runs");
    if (!known) return Parsed::Other;
    if (i + 1 >= argc) return Parsed::Bad;
    const char *value = argv[++i];
    if (!std::strcmp(a, "--scenes")) {
        scenes = split(value, ',');
        return Parsed::Taken;
    }
    if (!std::strcmp(a, "--threads")) return parse_thread_list(value, threads) ? Parsed::Taken : Parsed::Bad;
    uint64_t v = 0;
    if (!parse_uint(value, v) || v == 0 || v > 1000) return Parsed::Bad;
    runs = int(v);
    return Parsed::Taken;
}

/// The thread counts a benchmark uses when none are asked for: 1 and this
/// machine's hardware threads.
inline std::vector<uint32_t> default_thread_counts() {
    std::vector<uint32_t> counts{1};
    const unsigned hw = std::thread::hardware_concurrency();
    if (hw > 1) counts.push_back(hw);
    return counts;
}

/// The CPU's model name from /proc/cpuinfo, or "unknown CPU".
inline std::string cpu_name() {
    std::ifstream f("/proc/cpuinfo");
    std::string line;
    while (std::getline(f, line)) {
        if (line.rfind("model name", 0) == 0) {
            const size_t c = line.find(':');
            if (c != std::string::npos) return line.substr(c + 2);
        }
    }
    return "unknown CPU";
}

/// The first line of a benchmark's report: the program, the CPU (as lscpu
/// names it), its hardware threads and the library's version.
inline void print_machine_line(const char *program) {
    std::printf("%s: %s, %u hardware threads; libaacbvh %s\n", program, cpu_name().c_str(),
                std::thread::hardware_concurrency(), aacbvh_version_string());
}

/// The scenes a --scenes list names, in its order: the entry "shared" stands
/// for every *.obj in `scenes_dir` (sorted; none when there is no such
/// directory); other entries stay as they are (see load_scene_spec()). An
/// empty list means "shared"; when that finds nothing, "procedural".
inline std::vector<std::string> expand_scene_specs(const std::vector<std::string> &listed, const char *scenes_dir) {
    if (listed.empty()) {
        std::vector<std::string> found = default_scene_paths(scenes_dir);
        if (found.empty()) found.push_back("procedural");
        return found;
    }
    std::vector<std::string> out;
    for (const std::string &spec : listed) {
        if (spec != "shared") {
            out.push_back(spec);
            continue;
        }
        const std::vector<std::string> found = default_scene_paths(scenes_dir);
        out.insert(out.end(), found.begin(), found.end());
    }
    return out;
}

/// Loads a --scenes entry: "procedural" (about 240 K triangles),
/// "procedural-small" (about 3 K), a path, or the name of an OBJ file in
/// `scenes_dir` ("" for none; ".obj" may be left out). False with a message
/// in `err` when it cannot be read.
inline bool load_scene_spec(const std::string &spec, const char *scenes_dir, Scene &scene, std::string &err) {
    if (spec == "procedural" || spec == "procedural-small") {
        ProceduralConfig c;
        if (spec == "procedural-small") {
            c.terrain_cells = 32;
            c.sphere_count = 8;
            c.sphere_rings = 6;
        }
        scene = make_procedural_scene(c);
        scene.name = spec;
        return true;
    }
    std::string path = spec;
    if (spec.find('/') == std::string::npos && scenes_dir[0] && !std::ifstream(spec).good()) {
        path = std::string(scenes_dir) + "/" + spec;
        if (path.size() < 4 || path.compare(path.size() - 4, 4, ".obj") != 0) path += ".obj";
    }
    return load_obj(path, scene, err);
}

/// Loads each scene that a --scenes list names, in order, and calls
/// run(scene), which returns false on a failure. A scene that does not load
/// is reported on stderr as "program: spec: error". True when every scene
/// loaded and ran, and there was at least one.
template <class Run>
bool for_each_scene(const std::vector<std::string> &listed, const char *scenes_dir, const char *program, Run &&run) {
    bool ok = true;
    int scenes = 0;
    for (const std::string &spec : expand_scene_specs(listed, scenes_dir)) {
        Scene scene;
        std::string err;
        if (!load_scene_spec(spec, scenes_dir, scene, err)) {
            std::fprintf(stderr, "%s: %s: %s\n", program, spec.c_str(), err.c_str());
            ok = false;
            continue;
        }
        ok = run(scene) && ok;
        ++scenes;
    }
    return ok && scenes > 0;
}

} // namespace bench
