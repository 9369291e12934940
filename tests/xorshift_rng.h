// A deterministic xorshift64 generator for the C++ unit tests of lib/
// internals (the C tests over the public API use test_support.h's ts_rng).
// Seed with any non-zero state.
#pragma once

#include <cstdint>

struct XorshiftRng {
    uint64_t s;
    uint64_t next() {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        return s;
    }
    /// Uniform in [0, 1), 24 bits.
    float unit() { return float(double(next() >> 40) / 16777216.0); }
    float range(float lo, float hi) { return lo + (hi - lo) * unit(); }
    uint32_t below(uint32_t n) { return uint32_t(next() % n); }
};
