// Unit tests of the SIMD kernels under AAC's greedy combine
// (lib/build/aac/distance_row.h) against plain loops: argmin_row on rows full of ties,
// infinities and FLT_MAX at every length from 1 to 70, distance_row against
// a double-precision union area, and the fused distance_row_argmin against
// the two kernels it replaces.
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
#include <random>
#include <vector>

#include "build/aac/distance_row.h"

namespace {

/// The reference: the first index of the smallest value.
uint32_t first_min(const std::vector<float> &row, uint32_t count) {
    uint32_t arg = 0;
    for (uint32_t j = 1; j < count; ++j)
        if (row[j] < row[arg]) arg = j;
    return arg;
}

void test_argmin_row(void **) {
    std::mt19937 rng(17);
    const float palette[] = {INFINITY, FLT_MAX, 0.0f, 1.0f, 1.0f, 2.5f, 1e-30f, 3.0f};
    for (uint32_t count = 1; count <= 70; ++count) {
        for (int trial = 0; trial < 300; ++trial) {
            std::vector<float> row(count + 8, -1.0f); // entries past count must not be read as candidates
            const int mode = trial % 4;
            for (uint32_t j = 0; j < count; ++j) {
                if (mode == 0) row[j] = palette[rng() % 8];                       // many ties
                if (mode == 1) row[j] = float(rng() % 1000) * 0.5f;               // some ties
                if (mode == 2) row[j] = INFINITY;                                 // all infinite
                if (mode == 3) row[j] = std::ldexp(float(rng() % 97 + 1), int(rng() % 60) - 30);
            }
            if (mode == 2 && count > 1 && trial % 8 == 2) row[rng() % count] = FLT_MAX;
            float best = -7.0f;
            const uint32_t got = aacbvh::argmin_row(row.data(), count, best);
            const uint32_t want = first_min(row, count);
            if (got != want || !(best == row[want]))
                fail_msg("count %u, mode %d: argmin %u (%g), expected %u (%g)", count, mode, got, double(best), want,
                         double(row[want]));
        }
    }
}

void test_distance_row(void **) {
    std::mt19937 rng(23);
    std::uniform_real_distribution<float> u(-100.0f, 100.0f);
    for (uint32_t count = 1; count <= 40; ++count) {
        const uint32_t padded = (count + 7) & ~7u;
        std::vector<float> cols(6 * padded);
        aacbvh::BoxColumns boxes;
        for (int k = 0; k < 3; ++k) {
            boxes.lo[k] = cols.data() + k * padded;
            boxes.hi[k] = cols.data() + (k + 3) * padded;
        }
        for (uint32_t j = 0; j < padded; ++j)
            for (int k = 0; k < 3; ++k) {
                const float a = u(rng), b = u(rng);
                boxes.lo[k][j] = std::fmin(a, b);
                boxes.hi[k][j] = std::fmax(a, b);
            }
        float q[6];
        for (int k = 0; k < 3; ++k) {
            const float a = u(rng), b = u(rng);
            q[k] = std::fmin(a, b);
            q[k + 3] = std::fmax(a, b);
        }
        const float scale = 0.01f;
        std::vector<float> out(padded);
        aacbvh::distance_row(boxes, count, q, scale, out.data());
        for (uint32_t j = 0; j < count; ++j) {
            double e[3];
            for (int k = 0; k < 3; ++k)
                e[k] = (double(std::fmax(boxes.hi[k][j], q[k + 3])) - double(std::fmin(boxes.lo[k][j], q[k]))) * scale;
            const double want = e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
            if (!(std::fabs(out[j] - want) <= 1e-5 * want + 1e-30))
                fail_msg("count %u, box %u: distance %.9g, expected %.9g", count, j, double(out[j]), want);
        }
    }
    // A scene wider than FLT_MAX: distances clamp to FLT_MAX, never inf or NaN.
    float lo[8], hi[8], zero[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (int j = 0; j < 8; ++j) {
        lo[j] = -FLT_MAX;
        hi[j] = FLT_MAX;
    }
    aacbvh::BoxColumns wide{{lo, zero, zero}, {hi, zero, zero}};
    const float q[6] = {0, 0, 0, 1, 1, 1};
    float out[8];
    aacbvh::distance_row(wide, 8, q, 1.0f, out);
    for (float d : out) assert_true(d == FLT_MAX);
}

/// The fused row-and-nearest kernel against the two separate ones, on boxes
/// drawn from a few shapes (so distances tie), with `self` anywhere.
void test_distance_row_argmin(void **) {
    std::mt19937 rng(29);
    for (uint32_t count = 1; count <= 70; ++count) {
        const uint32_t padded = (count + 7) & ~7u;
        for (int trial = 0; trial < 40; ++trial) {
            std::vector<float> cols(6 * padded);
            aacbvh::BoxColumns boxes;
            for (int k = 0; k < 3; ++k) {
                boxes.lo[k] = cols.data() + k * padded;
                boxes.hi[k] = cols.data() + (k + 3) * padded;
            }
            const int shapes = 1 + trial % 5;
            for (uint32_t j = 0; j < padded; ++j) {
                const int shape = int(rng() % unsigned(shapes));
                for (int k = 0; k < 3; ++k) {
                    boxes.lo[k][j] = float(shape * (k + 1));
                    boxes.hi[k][j] = float(shape * (k + 1) + 1 + shape % 2);
                }
            }
            const uint32_t self = rng() % count;
            float q[6];
            for (int k = 0; k < 3; ++k) {
                q[k] = boxes.lo[k][self];
                q[k + 3] = boxes.hi[k][self];
            }
            std::vector<float> fused(padded, -1.0f), plain(padded, -1.0f);
            float fused_best = -1.0f, plain_best = -2.0f;
            const uint32_t got = aacbvh::distance_row_argmin(boxes, count, q, 0.5f, fused.data(), self, fused_best);
            aacbvh::distance_row(boxes, count, q, 0.5f, plain.data());
            plain[self] = INFINITY;
            const uint32_t want = aacbvh::argmin_row(plain.data(), count, plain_best);
            assert_true(want == first_min(plain, count));
            for (uint32_t j = 0; j < count; ++j)
                if (!(fused[j] == plain[j])) fail_msg("count %u: entry %u is %g, expected %g", count, j, double(fused[j]),
                                                      double(plain[j]));
            if (got != want || !(fused_best == plain_best))
                fail_msg("count %u, self %u: nearest %u (%g), expected %u (%g)", count, self, got, double(fused_best),
                         want, double(plain_best));
        }
    }
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_argmin_row),
        cmocka_unit_test(test_distance_row),
        cmocka_unit_test(test_distance_row_argmin),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
