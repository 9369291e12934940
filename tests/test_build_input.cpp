// The input pass (build/build_input.h): its triangle fast path (SSE, a
// triangle at a time) against the general path (every primitive through
// primitive_problem() and primitive_box()), bit for bit: boxes, primitive
// ids, the bounds and centroid bounds, the invalid count, and the error
// message of the first bad triangle. Inputs: random triangles over several
// chunks, with signed zeros, +-FLT_MAX, denormals, NaN and infinite
// coordinates, indices out of range, vertex strides of 12, 16 and 20 bytes,
// non-indexed triangles, at one and three threads.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <cfloat>
#include <cmath>
#include <algorithm>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "build/build_input.h"
#include "core/error.h"

namespace {

using aacbvh::BuildInput;
using aacbvh::Geometry;
using aacbvh::GeometryKind;
using aacbvh::InputPath;
using aacbvh::InputRoom;

/// A coordinate drawn from the values that make min, max and the centroid
/// hard: signed zeros, the largest and smallest floats, denormals, and
/// ordinary values; `bad` in 1000 are NaN or infinite.
float coordinate(std::mt19937 &rng, unsigned bad) {
    const unsigned pick = rng() % 1000;
    if (pick < bad) {
        const float specials[] = {NAN, INFINITY, -INFINITY};
        return specials[rng() % 3];
    }
    switch (rng() % 10) {
    case 0: return 0.0f;
    case 1: return -0.0f;
    case 2: return (rng() & 1) ? FLT_MAX : -FLT_MAX;
    case 3: return (rng() & 1) ? FLT_MIN * 0.25f : -FLT_MIN * 0.5f; // denormal
    default: return std::uniform_real_distribution<float>(-100.0f, 100.0f)(rng);
    }
}

struct Soup {
    std::vector<float> vertices; // stride floats a vertex, xyz first
    std::vector<uint32_t> indices;
    Geometry geometry;
};

/// `triangles` triangles over `vertex_count` vertices of `stride` bytes;
/// `bad_index` in 1000 triangles have an index at or past the vertex count.
void make_soup(Soup &soup, uint32_t seed, size_t triangles, size_t vertex_count, size_t stride, unsigned bad,
               unsigned bad_index, bool indexed) {
    std::mt19937 rng(seed);
    const size_t floats = stride / 4;
    if (!indexed) vertex_count = 3 * triangles;
    soup.vertices.assign(vertex_count * floats, 7.0f);
    for (size_t v = 0; v < vertex_count; ++v)
        for (size_t a = 0; a < 3; ++a) soup.vertices[v * floats + a] = coordinate(rng, bad);
    soup.indices.clear();
    if (indexed) {
        for (size_t t = 0; t < 3 * triangles; ++t) {
            uint32_t k = uint32_t(rng() % vertex_count);
            if (rng() % 3000 < bad_index) k = (rng() & 1) ? uint32_t(vertex_count) : UINT32_MAX;
            soup.indices.push_back(k);
        }
    }
    Geometry &g = soup.geometry;
    g = Geometry{};
    g.kind = GeometryKind::Triangles;
    g.vertices = soup.vertices.data();
    g.vertex_count = vertex_count;
    g.vertex_stride = stride;
    g.indices = indexed ? soup.indices.data() : nullptr;
    g.primitive_count = triangles;
}

bool same_bits(const void *a, const void *b, size_t bytes) { return std::memcmp(a, b, bytes) == 0; }

/// The input's boxes as a builder reads them (BuildInput::box).
std::vector<aacbvh::Box> boxes_of(const BuildInput &in) {
    std::vector<aacbvh::Box> out(in.size());
    for (size_t i = 0; i < in.size(); ++i) out[i] = in.box(i);
    return out;
}

/// Runs both paths, each without and with room for a tree
/// (InputRoom::Tree: the boxes in the upper half of an array of twice the
/// primitive count); returns the error message (empty when all succeeded)
/// after checking they agree on everything.
std::string compare_paths(const Geometry &g, bool skip_invalid, unsigned threads) {
    aacbvh::Scheduler scheduler(threads);
    const InputPath paths[4] = {InputPath::Fastest, InputPath::General, InputPath::Fastest, InputPath::General};
    const InputRoom rooms[4] = {InputRoom::None, InputRoom::None, InputRoom::Tree, InputRoom::Tree};
    BuildInput in[4];
    std::string error[4];
    for (int k = 0; k < 4; ++k) {
        try {
            aacbvh::BuildContext ctx(scheduler, nullptr, nullptr);
            aacbvh::compute_build_input(g, skip_invalid, ctx, in[k], paths[k], rooms[k]);
        } catch (const aacbvh::Error &e) {
            error[k] = e.what();
        }
    }
    for (int k = 1; k < 4; ++k) assert_true(error[k] == error[0]);
    if (!error[0].empty()) return error[0];
    const BuildInput &fast = in[0];
    const std::vector<aacbvh::Box> fast_boxes = boxes_of(fast);
    assert_int_equal(fast.box_offset, 0);
    for (int k = 1; k < 4; ++k) {
        const BuildInput &other = in[k];
        assert_int_equal(other.size(), fast.size());
        assert_int_equal(other.invalid_count, fast.invalid_count);
        const bool room = rooms[k] == InputRoom::Tree;
        assert_int_equal(other.box_offset, room ? g.primitive_count : 0);
        assert_int_equal(other.boxes.size(), other.box_offset + other.size());
        const std::vector<aacbvh::Box> boxes = boxes_of(other);
        assert_true(same_bits(fast_boxes.data(), boxes.data(), fast.size() * sizeof(aacbvh::Box)));
        assert_true(same_bits(fast.prim_ids.data(), other.prim_ids.data(), fast.size() * sizeof(uint32_t)));
        assert_true(same_bits(&fast.bounds, &other.bounds, sizeof fast.bounds));
        assert_true(same_bits(&fast.centroid_bounds, &other.centroid_bounds, sizeof fast.centroid_bounds));
    }
    return std::string();
}

void test_valid_triangles(void **) {
    Soup soup;
    const size_t strides[] = {12, 16, 20};
    for (uint32_t seed = 1; seed <= 6; ++seed) {
        const size_t stride = strides[seed % 3];
        make_soup(soup, seed, 40000 + seed * 977, 30000, stride, 0, 0, seed % 2 == 1);
        for (unsigned threads : {1u, 3u}) {
            assert_true(compare_paths(soup.geometry, false, threads).empty());
        }
    }
}

void test_invalid_triangles_skipped(void **) {
    Soup soup;
    for (uint32_t seed = 11; seed <= 16; ++seed) {
        make_soup(soup, seed, 50000, 20000, seed % 2 ? 16 : 12, 2, 3, seed != 13);
        for (unsigned threads : {1u, 3u}) {
            assert_true(compare_paths(soup.geometry, true, threads).empty());
        }
    }
    // Mutation check on the comparison: the general path must leave some out.
    make_soup(soup, 11, 50000, 20000, 16, 2, 3, true);
    aacbvh::Scheduler scheduler(1);
    aacbvh::BuildContext ctx(scheduler, nullptr, nullptr);
    BuildInput input;
    aacbvh::compute_build_input(soup.geometry, true, ctx, input, InputPath::Fastest);
    assert_true(input.invalid_count > 0);
    assert_true(input.size() + input.invalid_count == 50000);
}

/// Inputs in a big block with room for the tree (InputRoom::Tree), valid and
/// with invalid triangles left out (the squeeze moves boxes within the upper half).
void test_room_for_the_tree(void **) {
    Soup soup;
    const size_t count = 2 * aacbvh::kHugePageBytes / sizeof(aacbvh::Box) + 1234; // a big block
    for (uint32_t seed = 31; seed <= 34; ++seed) {
        const bool invalid = seed % 2 == 0;
        make_soup(soup, seed, count, 40000, 12, invalid ? 2 : 0, invalid ? 3 : 0, seed != 33);
        for (unsigned threads : {1u, 3u}) assert_true(compare_paths(soup.geometry, invalid, threads).empty());
    }
    aacbvh::Scheduler scheduler(1);
    aacbvh::BuildContext ctx(scheduler, nullptr, nullptr);
    BuildInput input;
    aacbvh::compute_build_input(soup.geometry, true, ctx, input, InputPath::Fastest, InputRoom::Tree);
    assert_int_equal(input.box_offset, count);
}

/// The leaves gathered by a random order: with the input's indices when some
/// triangles were left out, with the order alone when none were
/// (identity_ids), both checked against the input entry by entry, also with
/// the order in the leaves' own index array (as AAC gathers).
void test_gather_leaves(void **) {
    Soup soup;
    for (uint32_t seed = 41; seed <= 44; ++seed) {
        const bool invalid = seed % 2 == 0;
        make_soup(soup, seed, 30000, 15000, 12, invalid ? 2 : 0, invalid ? 3 : 0, true);
        for (unsigned threads : {1u, 3u}) {
            aacbvh::Scheduler scheduler(threads);
            aacbvh::BuildContext ctx(scheduler, nullptr, nullptr);
            BuildInput input;
            aacbvh::compute_build_input(soup.geometry, true, ctx, input, InputPath::Fastest);
            assert_int_equal(input.identity_ids, !invalid);
            assert_int_equal(input.invalid_count > 0, invalid);
            if (invalid) assert_ptr_equal(aacbvh::input_prim_ids(input), input.prim_ids.data());
            else assert_null(aacbvh::input_prim_ids(input));
            const uint32_t n = uint32_t(input.size());
            std::vector<uint32_t> order(n);
            for (uint32_t i = 0; i < n; ++i) order[i] = i;
            std::shuffle(order.begin(), order.end(), std::mt19937(seed));
            for (const bool aliased : {false, true}) {
                aacbvh::BinaryTree tree;
                tree.boxes.resize(2 * size_t(n));
                tree.prim_ids.resize(n);
                if (aliased) std::copy(order.begin(), order.end(), tree.prim_ids.begin());
                aacbvh::gather_leaves(input.boxes.data() + input.box_offset, aacbvh::input_prim_ids(input),
                                      aliased ? tree.prim_ids.data() : order.data(), scheduler, tree);
                for (uint32_t i = 0; i < n; ++i) {
                    assert_int_equal(tree.prim_ids[i], input.prim_ids[order[i]]);
                    assert_memory_equal(&tree.boxes[i], &input.box(order[i]), sizeof(aacbvh::Box));
                }
            }
        }
    }
}

void test_first_invalid_named(void **) {
    Soup soup;
    for (uint32_t seed = 21; seed <= 24; ++seed) {
        make_soup(soup, seed, 40000, 20000, 12, seed == 24 ? 0 : 1, seed == 23 ? 1 : 0, seed != 22);
        if (seed == 24) soup.vertices[3 * soup.indices[3 * 39999 + 2] + 1] = NAN; // the very last triangle
        for (unsigned threads : {1u, 3u}) {
            const std::string message = compare_paths(soup.geometry, false, threads);
            assert_false(message.empty());
            assert_true(message.find("triangle ") == 0);
        }
    }
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_valid_triangles),
        cmocka_unit_test(test_invalid_triangles_skipped),
        cmocka_unit_test(test_room_for_the_tree),
        cmocka_unit_test(test_gather_leaves),
        cmocka_unit_test(test_first_invalid_named),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
