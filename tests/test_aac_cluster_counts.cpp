// AAC's cluster counts f(n) (build/aac/aac_builder.h) on hand-computed values:
// the paper's f(n) = ceil(c n^alpha) clamped to [1, n], a preset's own counts
// that take other c and alpha from `own_from` primitives up, the presets
// (AAC-HQ builds with ceil(2.3 n^0.4) at every size and reports the paper's
// c; AAC-Fast has HQ's counts from 1,024 up; both split the root by SAH),
// and the parameters: AACBVH_BUILDER_AAC, or setting delta, c or alpha,
// always builds the paper's AAC (single f(n), greedy root) with the values in
// force.
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
// This cmocka.h has no extern "C" guard of its own.
extern "C" {
#include <cmocka.h>
}

#include <cmath>
#include <vector>

#include "build/aac/aac_builder.h"
#include "builder_table.h"
#include "params.h"

namespace {

using aacbvh::AacConfig;
using aacbvh::aac_cluster_target;

void test_paper_f(void **) {
    const AacConfig sqrt_n{4, 1.0, 0.5, 0, 0.0, 0.4};
    assert_int_equal(aac_cluster_target(sqrt_n, 100), 10);   // exactly 10: no rounding up past it
    assert_int_equal(aac_cluster_target(sqrt_n, 101), 11);   // 10.05
    assert_int_equal(aac_cluster_target(sqrt_n, 4096), 64);
    assert_int_equal(aac_cluster_target(sqrt_n, 1), 1);
    assert_int_equal(aac_cluster_target(sqrt_n, 0), 1);      // never below 1
    const AacConfig wide{4, 10.0, 1.0, 0, 0.0, 0.4};
    assert_int_equal(aac_cluster_target(wide, 5), 5);        // never above n
    // The paper's presets make f(delta) = delta / 2 exactly.
    AacConfig hq = aacbvh::find_builder(AACBVH_BUILDER_AAC_HQ)->preset();
    hq.own_from = 0; // the paper's f(n), as AACBVH_BUILDER_AAC builds it
    assert_int_equal(aac_cluster_target(hq, 20), 10);
    AacConfig fast = aacbvh::find_builder(AACBVH_BUILDER_AAC_FAST)->preset();
    assert_int_equal(aac_cluster_target(fast, 4), 2);
}

void test_own_counts(void **) {
    const AacConfig cfg{4, 1.0, 0.5, 1024, 2.0, 0.5};
    assert_int_equal(aac_cluster_target(cfg, 100), 10);
    assert_int_equal(aac_cluster_target(cfg, 1023), 32);     // sqrt(1023) = 31.98: below own_from
    assert_int_equal(aac_cluster_target(cfg, 1024), 64);     // 2 * 32
    assert_int_equal(aac_cluster_target(cfg, 4096), 128);
}

void test_presets(void **) {
    const AacConfig hq = aacbvh::find_builder(AACBVH_BUILDER_AAC_HQ)->preset();
    const AacConfig fast = aacbvh::find_builder(AACBVH_BUILDER_AAC_FAST)->preset();
    // HQ: the paper's delta, c and alpha reported, ceil(2.3 n^0.4) built at
    // every size: f(20) = ceil(7.62) = 8, f(1024) = ceil(2.3 * 16) = 37.
    assert_int_equal(hq.delta, 20);
    assert_true(std::fabs(hq.c - std::pow(20.0, 0.6) / 2.0) < 1e-15 && hq.alpha == 0.4);
    assert_int_equal(hq.own_from, 1);
    assert_true(hq.own_c == 2.3 && hq.own_alpha == 0.4);
    assert_int_equal(aac_cluster_target(hq, 1), 1);
    assert_int_equal(aac_cluster_target(hq, 2), 2);          // 3.03, clamped to n
    assert_int_equal(aac_cluster_target(hq, 20), 8);
    assert_int_equal(aac_cluster_target(hq, 1024), 37);
    // Both presets split the root's clusters by SAH once; the paper's AAC never.
    assert_int_equal(hq.root_split_levels, 1);
    assert_int_equal(fast.root_split_levels, 1);
    assert_int_equal(AacConfig{}.root_split_levels, 0);
    // Fast: the paper's delta, c and alpha below 1,024 primitives, HQ's above.
    assert_int_equal(fast.delta, 4);
    assert_true(std::fabs(fast.c - std::pow(4.0, 0.7) / 2.0) < 1e-15 && fast.alpha == 0.3);
    assert_int_equal(fast.own_from, 1024);
    assert_true(fast.own_c == hq.own_c && fast.own_alpha == hq.own_alpha);
    // 1,023 primitives: ceil(1.3195 * 1023^0.3) = 11; 1,024: HQ's ceil(2.3 * 1024^0.4) = 37.
    assert_int_equal(aac_cluster_target(fast, 1023), 11);
    assert_int_equal(aac_cluster_target(fast, 1024), 37);
    assert_int_equal(aac_cluster_target(fast, 1024), aac_cluster_target(hq, 1024));
}

void test_params_drop_the_own_counts(void **) {
    aacbvh::Params p;
    p.set_int(AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST);
    assert_int_equal(p.aac.own_from, 1024);
    p.set_int(AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC);     // the values in force, the paper's f(n)
    assert_int_equal(p.aac.own_from, 0);
    assert_int_equal(p.aac.root_split_levels, 0);
    assert_int_equal(p.aac.delta, 4);
    assert_true(p.aac.alpha == 0.3);

    const int32_t keys[] = {AACBVH_PARAM_AAC_DELTA, AACBVH_PARAM_AAC_C, AACBVH_PARAM_AAC_ALPHA};
    for (int32_t key : keys) {
        p.set_int(AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_FAST);
        assert_int_equal(p.aac.own_from, 1024);
        if (key == AACBVH_PARAM_AAC_DELTA) p.set_int(key, 4);
        else p.set_float(key, key == AACBVH_PARAM_AAC_C ? p.aac.c : 0.3);
        assert_int_equal(p.builder, AACBVH_BUILDER_AAC);
        assert_int_equal(p.aac.own_from, 0);
        assert_int_equal(p.aac.root_split_levels, 0);
    }
    p.set_int(AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC_HQ);
    assert_int_equal(p.aac.own_from, 1);
    assert_int_equal(p.aac.root_split_levels, 1);
    p.set_int(AACBVH_PARAM_BUILDER, AACBVH_BUILDER_AAC);     // the paper's HQ f(n), greedy root
    assert_int_equal(p.aac.own_from, 0);
    assert_int_equal(p.aac.root_split_levels, 0);
    assert_int_equal(aac_cluster_target(p.aac, 20), 10);
}

/// The table a build fills (aac_cluster_targets(): runs found from the
/// inverse of f) against f itself at every n, for the presets, the paper's
/// f(n), extreme and random parameters, own counts from several sizes, and
/// parameters under which f is not monotone (the plain fill).
void check_table(const AacConfig &cfg, uint32_t count) {
    std::vector<uint32_t> table(count + 1, 0xDEADBEEFu);
    aacbvh::aac_cluster_targets(cfg, count, table.data());
    for (uint32_t n = 0; n < count; ++n) {
        if (table[n] != aac_cluster_target(cfg, n))
            fail_msg("c %.17g alpha %.17g own_from %u own_c %.17g own_alpha %.17g: n %u, table %u, f(n) %u", cfg.c,
                     cfg.alpha, cfg.own_from, cfg.own_c, cfg.own_alpha, n, table[n], aac_cluster_target(cfg, n));
    }
    assert_int_equal(table[count], 0xDEADBEEFu); // nothing written past count
}

void test_target_table(void **) {
    const AacConfig hq = aacbvh::find_builder(AACBVH_BUILDER_AAC_HQ)->preset();
    const AacConfig fast = aacbvh::find_builder(AACBVH_BUILDER_AAC_FAST)->preset();
    AacConfig paper_hq = hq, paper_fast = fast;
    paper_hq.own_from = paper_fast.own_from = 0;
    for (const AacConfig &cfg : {hq, fast, paper_hq, paper_fast}) {
        check_table(cfg, 4097);
        check_table(cfg, 70000);
        check_table(cfg, 3); // shorter than the clamped start
    }
    check_table(hq, 0);
    const AacConfig fixed[] = {
        {4, 1.0, 0.5, 0, 0.0, 0.4},     // the square root: exact values at squares
        {4, 10.0, 1.0, 0, 0.0, 0.4},    // f(n) = n everywhere
        {4, 1.0, 1.0, 0, 0.0, 0.4},     // f(n) = n, c n exactly
        {4, 0.01, 0.1, 0, 0.0, 0.4},    // f(n) = 1 nearly everywhere
        {4, 1000.0, 0.05, 0, 0.0, 0.4}, // clamped to n far up
        {4, 1.0, 0.5, 1024, 2.0, 0.5},  // own counts: a jump at 1,024
        {4, 3.0, 0.9, 100, 0.5, 0.2},   // own counts below the paper's: f falls at 100
        {4, 2.0, 1e-9, 0, 0.0, 0.4},    // a tiny alpha: the inverse overflows
        {4, 2.0, -0.5, 0, 0.0, 0.4},    // not monotone (no parameter sets this): the plain fill
        {4, 2.0, 0.4, 10, 1.0, -0.3},
    };
    for (const AacConfig &cfg : fixed) check_table(cfg, 5000);
    uint64_t state = 0x9E3779B97F4A7C15ull;
    auto next = [&state] {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        return double(state >> 11) * 0x1p-53;
    };
    const uint32_t own_froms[] = {0, 1, 2, 17, 1024, 5000};
    for (int k = 0; k < 60; ++k) {
        AacConfig cfg;
        cfg.c = 0.05 + 40.0 * next();
        cfg.alpha = 0.02 + 0.98 * next();
        cfg.own_from = own_froms[k % 6];
        cfg.own_c = 0.05 + 40.0 * next();
        cfg.own_alpha = 0.02 + 0.98 * next();
        check_table(cfg, 4097);
    }
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_paper_f),
        cmocka_unit_test(test_own_counts),
        cmocka_unit_test(test_presets),
        cmocka_unit_test(test_params_drop_the_own_counts),
        cmocka_unit_test(test_target_table),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
