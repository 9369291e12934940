/* The examples' random numbers, for C99 and C++: SplitMix64 (Steele, Lea,
 * Flood 2014), a tiny, well-mixed generator whose output is fixed by the seed
 * on every platform, unlike rand() or the std:: distributions, so generated
 * scenes and ray sets are the same everywhere. Header only. */
#ifndef AACBVH_EXAMPLES_RANDOM_H
#define AACBVH_EXAMPLES_RANDOM_H

#include <math.h>
#include <stdint.h>

typedef struct splitmix64 {
    uint64_t state;
} splitmix64;

static inline uint64_t splitmix64_next(splitmix64 *r) {
    uint64_t z = (r->state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1), from the top 53 bits. */
static inline double splitmix64_uniform(splitmix64 *r) {
    return (double)(splitmix64_next(r) >> 11) * (1.0 / 9007199254740992.0);
}

/* Uniform in [0, 1) as a float, from the top 24 bits (never rounds up to 1). */
static inline float splitmix64_uniform_float(splitmix64 *r) {
    return (float)(splitmix64_next(r) >> 40) * (1.0f / 16777216.0f);
}

/* A unit vector uniform over the sphere (Archimedes: z uniform in [-1, 1]). */
static inline void splitmix64_direction(splitmix64 *r, float out[3]) {
    const double z = 2.0 * splitmix64_uniform(r) - 1.0;
    const double phi = 6.283185307179586 * splitmix64_uniform(r);
    const double s = sqrt(1.0 - z * z > 0.0 ? 1.0 - z * z : 0.0);
    out[0] = (float)(s * cos(phi));
    out[1] = (float)(s * sin(phi));
    out[2] = (float)z;
}

#ifdef __cplusplus
/// The same generator with member functions, for the C++ examples.
struct SplitMix64 {
    splitmix64 s;
    explicit SplitMix64(uint64_t seed) : s{seed} {}
    uint64_t next() { return splitmix64_next(&s); }
    double uniform() { return splitmix64_uniform(&s); }
    double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
    float uniform_float() { return splitmix64_uniform_float(&s); }
    void direction(float out[3]) { splitmix64_direction(&s, out); }
};
#endif

#endif /* AACBVH_EXAMPLES_RANDOM_H */
