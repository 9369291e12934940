// Tests of the --scenes list (cli.h, expand_scene_specs()): "shared" stands for
// the scenes directory's OBJ files, in sorted order and nothing else; other
// entries stay in place; an empty list falls back to the directory, then to
// the generated scene.
#include "bench_test.h"
#include "cli.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace bench;
namespace fs = std::filesystem;

namespace {

/// A fresh directory holding b.obj, a.obj, notes.txt and a directory named
/// d.obj (not a file: not a scene).
std::string make_scene_dir() {
    std::string pattern = (fs::temp_directory_path() / "aacbvh-scenes-XXXXXX").string();
    if (!mkdtemp(pattern.data())) return "";
    for (const char *name : {"b.obj", "a.obj", "notes.txt"}) std::ofstream(pattern + "/" + name) << "# empty\n";
    fs::create_directory(pattern + "/d.obj");
    return pattern;
}

void test_shared_expands_to_sorted_obj_files(const std::string &dir) {
    const std::vector<std::string> got = expand_scene_specs({"procedural-small", "shared", "x.obj"}, dir.c_str());
    const std::vector<std::string> want{"procedural-small", dir + "/a.obj", dir + "/b.obj", "x.obj"};
    CHECK(got == want);
}

void test_empty_list_means_shared(const std::string &dir) {
    const std::vector<std::string> got = expand_scene_specs({}, dir.c_str());
    const std::vector<std::string> want{dir + "/a.obj", dir + "/b.obj"};
    CHECK(got == want);
}

void test_without_directory() {
    // The empty list falls back to the generated scene; a named "shared" finds nothing.
    CHECK(expand_scene_specs({}, "") == std::vector<std::string>{"procedural"});
    CHECK(expand_scene_specs({}, "/nonexistent/aacbvh-scenes") == std::vector<std::string>{"procedural"});
    CHECK(expand_scene_specs({"shared", "procedural"}, "") == std::vector<std::string>{"procedural"});
    CHECK(expand_scene_specs({"shared"}, "").empty());
}

} // namespace

int main() {
    const std::string dir = make_scene_dir();
    CHECK(!dir.empty());
    if (!dir.empty()) {
        test_shared_expands_to_sorted_obj_files(dir);
        test_empty_list_means_shared(dir);
        fs::remove_all(dir);
    }
    test_without_directory();
    return bench_test::finish("test_scene_specs");
}
