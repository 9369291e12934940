// Random triangle soups for the C++ unit tests of lib/ internals, and
// handles built over them.
#pragma once

#include <cstddef>
#include <random>
#include <vector>

#include "bvh_object.h"

namespace aacbvh_test {

/// Random triangles (9 floats each, no indices): most small, every 16th
/// long, in [-1, 1]^3.
inline std::vector<float> random_soup(size_t triangles, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), small(-0.02f, 0.02f);
    std::vector<float> v(9 * triangles);
    for (size_t t = 0; t < triangles; ++t) {
        const bool big = t % 16 == 0;
        for (int a = 0; a < 3; ++a) {
            const float c = u(rng);
            for (int i = 0; i < 3; ++i) v[9 * t + 3 * i + a] = big ? u(rng) : c + small(rng);
        }
    }
    return v;
}

/// Hands a soup (9 floats a triangle, no indices) to a handle.
inline void set_soup(aacbvh::BvhObject &object, const std::vector<float> &soup) {
    object.set_triangles(soup.data(), soup.size() / 3, 3 * sizeof(float), nullptr, soup.size() / 9);
}

/// Builds a handle over a soup with the given builder and leaf size.
inline void build_soup(aacbvh::BvhObject &object, const std::vector<float> &soup, aacbvh_builder builder,
                       int max_leaf) {
    set_soup(object, soup);
    object.set_param_int(AACBVH_PARAM_BUILDER, builder);
    object.set_param_int(AACBVH_PARAM_MAX_LEAF_SIZE, max_leaf);
    object.build();
}

} // namespace aacbvh_test
