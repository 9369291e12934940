// The small combine's SIMD loops (combine_small_avx2.cpp,
// combine_small_avx512.cpp), for cluster_combine.cpp: up to
// kWideSmallCombine clusters (kWideSmallCombine512 with AVX-512) with rows
// recomputed in registers instead of a cached matrix; the same merges as the
// scalar loops.
#pragma once

#include <cmath>
#include <cstdint>

#include "build/binary_tree.h"
#include "build/flatten.h"

namespace aacbvh {

/// Largest combine the AVX2 loop takes.
constexpr uint32_t kWideSmallCombine = 64;
/// Largest combine the AVX-512 loop takes: eight registers a row. Above 64
/// clusters it beat the rows loop only once its writes between merges no
/// longer stalled the next row's loads (docs/PERFORMANCE.md, rows 84, 152
/// and 154).
constexpr uint32_t kWideSmallCombine512 = 128;

/// The box of the SIMD loops' lanes past the live slots: every distance to
/// it is FLT_MAX (infinite extents), which no live slot's nearest takes from
/// a live lane (those come first, the lowest of equals wins, and no
/// distance exceeds FLT_MAX).
constexpr Box kFarBox{{-INFINITY, -INFINITY, -INFINITY}, {INFINITY, INFINITY, INFINITY}};

/// Whether this build of the library has the AVX2 loop (x86-64, GCC or Clang).
bool combine_small_avx2_compiled();

/// combine_clusters() for count <= kWideSmallCombine on a CPU with AVX2.
uint32_t combine_small_avx2(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                            float scale, const FlattenRule &rule, ChoiceTable choices);

/// The pair scan of combine_few() (at most 8 clusters, cluster_combine.cpp)
/// on a CPU with AVX2: the boxes as columns of one register, every pair of
/// clusters a lane of one to four registers, all live pairs' distances
/// computed again at each merge; the same merges.
uint32_t combine_few_avx2(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                          float scale, const FlattenRule &rule, ChoiceTable choices);

/// Whether this build of the library has the AVX-512 loop (x86-64, GCC or Clang).
bool combine_small_avx512_compiled();

/// combine_clusters() for count <= kWideSmallCombine512 on a CPU with AVX-512F.
uint32_t combine_small_avx512(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                              float scale, const FlattenRule &rule, ChoiceTable choices);

} // namespace aacbvh
