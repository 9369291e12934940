// Random triangle soups for the C++ unit tests of lib/ internals.
#pragma once

#include <cstddef>
#include <random>
#include <vector>

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

} // namespace aacbvh_test
