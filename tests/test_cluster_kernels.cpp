// Unit tests of the kernels under AAC's greedy combine
// (build/aac/distance_row.h, build/aac/cluster_combine.h) against plain
// loops: argmin_row on rows full of ties, infinities and FLT_MAX at every
// length from 1 to 70, distance_row against a double-precision union area,
// and the fused distance_row_argmin against the two kernels it replaces. Each
// runs with every kernel this CPU has (scalar, SSE, AVX), forced in turn, and
// the kernels must agree bit for bit. Then the three combine loops (small,
// matrix, rows) must make the same merges, rows past the AVX kernel's float
// index range must still find their minimum, and a build reaches the rows loop.
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
#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

#include "build/aac/cluster_combine.h"
#include "build/aac/distance_row.h"
#include "core/scheduler.h"

namespace {

/// The reference: the first index of the smallest value.
uint32_t first_min(const std::vector<float> &row, uint32_t count) {
    uint32_t arg = 0;
    for (uint32_t j = 1; j < count; ++j)
        if (row[j] < row[arg]) arg = j;
    return arg;
}

void check_argmin_row() {
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

void check_distance_row() {
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
void check_distance_row_argmin() {
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

using aacbvh::DistanceKernel;

constexpr DistanceKernel kAllKernels[] = {DistanceKernel::Scalar, DistanceKernel::Sse, DistanceKernel::Avx,
                                           DistanceKernel::Avx2, DistanceKernel::Avx512};

const char *kernel_name(DistanceKernel k) {
    switch (k) {
    case DistanceKernel::Scalar: return "scalar";
    case DistanceKernel::Sse: return "sse";
    case DistanceKernel::Avx: return "avx";
    case DistanceKernel::Avx2: return "avx2";
    case DistanceKernel::Avx512: return "avx512";
    }
    return "unknown";
}

/// Runs check() once with each kernel this CPU has, then restores the default.
template <class F> void for_each_kernel(F &&check) {
    const DistanceKernel original = aacbvh::distance_kernel();
    int ran = 0;
    for (DistanceKernel k : kAllKernels) {
        if (!aacbvh::set_distance_kernel(k)) continue;
        check();
        ++ran;
    }
    assert_true(aacbvh::set_distance_kernel(original));
    assert_true(ran >= 1);
}

void test_argmin_row(void **) { for_each_kernel(check_argmin_row); }
void test_distance_row(void **) { for_each_kernel(check_distance_row); }
void test_distance_row_argmin(void **) { for_each_kernel(check_distance_row_argmin); }

/// Boxes as columns, padded to a multiple of 8 as the kernels read them.
struct ColumnBoxes {
    explicit ColumnBoxes(uint32_t count) : padded((count + 7) & ~7u), storage(6 * size_t(padded)) {
        for (int k = 0; k < 3; ++k) {
            boxes.lo[k] = storage.data() + k * size_t(padded);
            boxes.hi[k] = storage.data() + (k + 3) * size_t(padded);
        }
    }
    uint32_t padded;
    std::vector<float> storage;
    aacbvh::BoxColumns boxes;
};

/// Every kernel gives the same distances and the same nearest box, bit for
/// bit, on random boxes, tied boxes and boxes wider than FLT_MAX.
void test_kernels_agree(void **) {
    std::mt19937 rng(31);
    std::printf("kernels on this CPU:");
    for (DistanceKernel k : kAllKernels)
        if (aacbvh::kernel_available(k)) std::printf(" %s", kernel_name(k));
    std::printf(" (in use: %s)\n", kernel_name(aacbvh::distance_kernel()));
    const DistanceKernel original = aacbvh::distance_kernel();
    for (uint32_t count : {1u, 3u, 8u, 13u, 64u, 257u}) {
        for (int trial = 0; trial < 30; ++trial) {
            ColumnBoxes c(count);
            for (uint32_t j = 0; j < c.padded; ++j)
                for (int k = 0; k < 3; ++k) {
                    float a = std::ldexp(float(int(rng() % 2001) - 1000), int(rng() % 20) - 10);
                    float b = std::ldexp(float(int(rng() % 2001) - 1000), int(rng() % 20) - 10);
                    if (trial % 3 == 0) a = float(rng() % 3), b = a + 1.0f;    // ties
                    if (trial % 7 == 1 && j % 5 == 0) a = -FLT_MAX, b = FLT_MAX; // overflow
                    c.boxes.lo[k][j] = std::fmin(a, b);
                    c.boxes.hi[k][j] = std::fmax(a, b);
                }
            const uint32_t self = rng() % count;
            float q[6];
            for (int k = 0; k < 3; ++k) {
                q[k] = c.boxes.lo[k][self];
                q[k + 3] = c.boxes.hi[k][self];
            }
            const float scale = trial % 2 ? 1.0f : 1e-3f;
            std::vector<float> first_row, first_fused;
            uint32_t first_nearest = 0;
            float first_best = 0.0f;
            bool have_first = false;
            for (DistanceKernel k : kAllKernels) {
                if (!aacbvh::set_distance_kernel(k)) continue;
                std::vector<float> row(c.padded), fused(c.padded);
                float best = 0.0f;
                aacbvh::distance_row(c.boxes, count, q, scale, row.data());
                const uint32_t nearest = aacbvh::distance_row_argmin(c.boxes, count, q, scale, fused.data(), self, best);
                row.resize(count);
                fused.resize(count);
                if (!have_first) {
                    first_row = row, first_fused = fused, first_nearest = nearest, first_best = best;
                    have_first = true;
                    continue;
                }
                if (std::memcmp(row.data(), first_row.data(), count * sizeof(float)) != 0 ||
                    std::memcmp(fused.data(), first_fused.data(), count * sizeof(float)) != 0 ||
                    nearest != first_nearest || std::memcmp(&best, &first_best, sizeof best) != 0)
                    fail_msg("count %u trial %d: the %s kernel differs from the scalar one", count, trial,
                             kernel_name(k));
            }
        }
    }
    assert_true(aacbvh::set_distance_kernel(original));
}

/// Rows longer than 2^24: the fused AVX kernel counts indices in float
/// lanes, exact only below 2^24, so such rows must take the other path and
/// still find a minimum placed past 2^24.
void test_rows_beyond_float_indices(void **) {
    const uint32_t count = (uint32_t(1) << 24) + 13;
    ColumnBoxes c(count);
    for (uint32_t j = 0; j < c.padded; ++j)
        for (int k = 0; k < 3; ++k) {
            c.boxes.lo[k][j] = 0.0f;
            c.boxes.hi[k][j] = 2.0f;
        }
    const uint32_t nearest = (uint32_t(1) << 24) + 5;
    for (int k = 0; k < 3; ++k) c.boxes.hi[k][nearest] = 1.0f; // the only box inside the query
    const float q[6] = {0, 0, 0, 1, 1, 1};
    std::vector<float> out(c.padded);
    for_each_kernel([&] {
        float best = 0.0f;
        const uint32_t got = aacbvh::distance_row_argmin(c.boxes, count, q, 1.0f, out.data(), 0, best);
        if (got != nearest || best != 3.0f)
            fail_msg("%s: nearest %u (%g), expected %u (3)", kernel_name(aacbvh::distance_kernel()), got,
                     double(best), nearest);
    });
}

/// One combine's input: `count` leaf clusters with boxes drawn so that
/// distances tie often, and its output.
struct CombineCase {
    aacbvh::BinaryTree tree;
    std::vector<uint32_t> ids, free_ids;
    aacbvh::SubtreeChoices choices;
    uint32_t left = 0;

    CombineCase(uint32_t count, uint32_t seed) {
        std::mt19937 rng(seed);
        tree.resize(count);
        for (uint32_t i = 0; i < count; ++i) {
            aacbvh::Box b;
            const bool tie = seed % 2 == 0;
            for (int k = 0; k < 3; ++k) {
                const float x = tie ? float(rng() % (seed % 4 == 0 ? 3 : 6)) : float(rng() % 100000) * 1e-3f;
                b.lo[k] = x;
                b.hi[k] = x + (tie ? 1.0f : float(rng() % 1000) * 1e-3f);
                if (seed % 5 == 0 && i % 3 == 0) { // some distances overflow to FLT_MAX (and tie there)
                    b.lo[k] -= 1e30f;
                    b.hi[k] += 1e30f;
                }
            }
            tree.boxes[i] = b;
            tree.prim_ids[i] = i;
            ids.push_back(i);
            free_ids.push_back(count + i);
        }
        choices.resize(count);
    }

    void run(uint32_t target, aacbvh::CombineVariant variant, aacbvh::BuildContext &ctx) {
        aacbvh::CombineScratchPool pool(nullptr);
        const aacbvh::FlattenRule rule{4, 1.2, 1.0};
        left = aacbvh::combine_clusters(tree, ids.data(), free_ids.data(), uint32_t(ids.size()), target, 1e-2f, rule,
                                        choices.table(), pool, ctx, variant);
    }

    bool same(const CombineCase &o) const {
        const uint32_t n = tree.leaf_count();
        if (left != o.left || ids != o.ids || free_ids != o.free_ids) return false;
        for (uint32_t i = 0; i + left < n; ++i) {
            const uint32_t id = n + i; // merge i made inner node n + i (free ids are used in order)
            if (tree.left(id) != o.tree.left(id) || tree.right(id) != o.tree.right(id)) return false;
            if (std::memcmp(&tree.boxes[id], &o.tree.boxes[id], sizeof(aacbvh::Box)) != 0) return false;
            if (choices.cost(i) != o.choices.cost(i) || choices.leaves(i) != o.choices.leaves(i)) return false;
        }
        return true;
    }
};

/// The reference for combines of at most kFewCombine clusters: merge the
/// first pair (a, b), a < b, in slot order at the smallest distance, put the
/// union in slot a and the last live cluster in slot b, until `target` remain;
/// the plain rule, written here independently of the library's loop.
void canonical_combine(CombineCase &c, uint32_t target) {
    const aacbvh::FlattenRule rule{4, 1.2, 1.0};
    const uint32_t n = c.tree.leaf_count();
    auto choice = [&](uint32_t id) { return id < n ? rule.leaf(c.tree.boxes[id]) : c.choices.get(id - n); };
    uint32_t live = uint32_t(c.ids.size()), used = 0;
    while (live > target) {
        uint32_t a = 0, b = 1;
        float best = INFINITY;
        for (uint32_t i = 0; i < live; ++i)
            for (uint32_t j = i + 1; j < live; ++j) {
                const float d = aacbvh::scaled_union_half_area(c.tree.boxes[c.ids[i]], c.tree.boxes[c.ids[j]], 1e-2f);
                if (d < best) {
                    best = d;
                    a = i;
                    b = j;
                }
            }
        const uint32_t node = c.free_ids[used++];
        c.tree.boxes[node] = aacbvh::unite(c.tree.boxes[c.ids[a]], c.tree.boxes[c.ids[b]]);
        c.tree.set_children(node, c.ids[a], c.ids[b]);
        c.choices.set(node - n, rule.inner(c.tree.boxes[node], choice(c.ids[a]), choice(c.ids[b])));
        c.ids[b] = c.ids[live - 1];
        c.ids[a] = node;
        --live;
    }
    for (uint32_t i = 0; i < live; ++i) c.free_ids[i] = c.free_ids[used + i];
    c.left = live;
}

/// The small, matrix and rows loops make the same merges in the same order,
/// with every kernel; and a combine of more than 2048 clusters (rows) equals
/// the matrix loop forced on it. Small counts get more seeds, half of them on
/// a grid where distances tie at every step: a greedy loop that breaks ties
/// differently (PERFORMANCE.md row 78) fails within them. Up to kFewCombine
/// clusters the small variant is the pair scan (row 112): it must follow
/// canonical_combine() on every seed, and the greedy loops where no distance
/// ties (odd seeds).
void test_combine_variants_agree(void **) {
    using aacbvh::CombineVariant;
    aacbvh::Scheduler scheduler(1);
    aacbvh::BuildContext ctx(scheduler, nullptr, nullptr);
    for_each_kernel([&] {
        for (uint32_t count : {2u, 3u, 4u, 5u, 6u, 7u, 8u, 9u, 16u, 17u, 24u, 32u, 33u, 40u, 48u, 49u, 64u, 65u, 80u, 81u,
                               97u, 112u, 113u, 127u, 128u, 129u, 300u}) {
            for (uint32_t seed = 1; seed <= (count <= 16 ? 32u : 6u); ++seed) {
                for (uint32_t target : {1u, 2u, count / 3 + 1, count - 1}) {
                    CombineCase reference(count, seed);
                    reference.run(target, CombineVariant::Rows, ctx);
                    const bool few = count <= aacbvh::kFewCombine;
                    for (CombineVariant v : {CombineVariant::Matrix, CombineVariant::Small}) {
                        if (few && v == CombineVariant::Small && seed % 2 == 0) continue; // ties: checked below
                        CombineCase other(count, seed);
                        other.run(target, v, ctx);
                        if (!other.same(reference))
                            fail_msg("%s kernel, %u clusters down to %u (seed %u): variant %d merges differently",
                                     kernel_name(aacbvh::distance_kernel()), count, target, seed, int(v));
                    }
                    if (!few) continue;
                    CombineCase small(count, seed), canonical(count, seed);
                    small.run(target, CombineVariant::Small, ctx);
                    canonical_combine(canonical, target);
                    if (!small.same(canonical))
                        fail_msg("%s kernel, %u clusters down to %u (seed %u): the pair scan is not the first pair "
                                 "at the smallest distance",
                                 kernel_name(aacbvh::distance_kernel()), count, target, seed);
                }
            }
        }
    });
    const uint32_t big = aacbvh::kMatrixCombine + 100;
    CombineCase rows(big, 2), matrix(big, 2);
    rows.run(1, CombineVariant::Automatic, ctx); // beyond the matrix limit: rows
    matrix.run(1, CombineVariant::Matrix, ctx);
    assert_true(rows.left == 1);
    assert_true(rows.same(matrix));
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_argmin_row),
        cmocka_unit_test(test_distance_row),
        cmocka_unit_test(test_distance_row_argmin),
        cmocka_unit_test(test_kernels_agree),
        cmocka_unit_test(test_rows_beyond_float_indices),
        cmocka_unit_test(test_combine_variants_agree),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
