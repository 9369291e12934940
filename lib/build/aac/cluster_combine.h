// The greedy step of agglomerative clustering inside one AAC node (Gu et al.
// 2013, "CombineClusters"): repeatedly merge the two clusters whose union box
// has the smallest surface area until `target` clusters remain.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "build/flatten.h"
#include "core/memory.h"
#include "core/box.h"

namespace aacbvh {

/// Scratch memory of the large combines, reused from one call to the next so
/// that the hot path does not allocate. Each belongs to one build and one
/// thread (CombineScratchPool): a build started from a progress callback, or
/// another build that the thread helps with, never touches it. The arrays come
/// from the build allocator, so they count in the build's peak (`meter` is
/// installed while they grow, also on worker threads) and are freed, or kept
/// with AACBVH_PARAM_KEEP_BUILD_MEMORY, with the build's other memory.
struct CombineScratch {
    Array<float> columns;          ///< 6 coordinate columns of the live clusters' boxes
    Array<float> distances;        ///< pairwise matrix, row-major, stride = padded count
    Array<float> nearest_distance;
    Array<uint32_t> nearest;
    Array<uint32_t> rescan;        ///< slots whose nearest neighbour must be found again
    MemoryMeter *meter = nullptr;  ///< the build's meter
    std::thread::id owner;         ///< the one thread that uses it
};

/// One build's combine scratch: one CombineScratch per thread that runs a
/// combine of that build, made on first use and freed with the pool.
class CombineScratchPool {
public:
    /// meter: the build's (MemoryMeter::current() of the building thread).
    explicit CombineScratchPool(MemoryMeter *meter);
    CombineScratchPool(const CombineScratchPool &) = delete;
    CombineScratchPool &operator=(const CombineScratchPool &) = delete;

    /// The calling thread's scratch in this pool.
    CombineScratch &local();

private:
    const uint64_t id_; ///< unique over the process's life, so a thread's cache never mistakes pools
    MemoryMeter *meter_;
    std::mutex mutex_;
    std::vector<std::unique_ptr<CombineScratch>> slots_;
};

/// Merges clusters ids[0, count) of `tree` (leaf or inner node ids whose boxes
/// are set) until `target` remain, creating one inner node per merge with ids
/// taken in order from free_ids[0, count). On return ids[0, result) are the
/// clusters left and free_ids[0, result) the ids not used. Distances are half
/// surface areas scaled by `scale` (keeps huge and tiny scenes in float range).
/// Ties go to the lowest slot, so results are deterministic. Long combines
/// (thousands of clusters) poll `ctx` for a cancel. Each new node's
/// flattening decision is made at once (its sub-tree is complete): choices
/// are indexed by id - leaf count. Combines of more than a handful of
/// clusters use the calling thread's scratch from the build's `scratch_pool`.
///
/// Three greedy loops give the same merges: a register-sized one for at most
/// kSmallCombine clusters (kWideSmallCombine with the AVX2 kernel,
/// kWideSmallCombine512 with AVX-512, build/aac/combine_small.h), one over a
/// cached distance matrix up to kMatrixCombine (never with those kernels),
/// and one that recomputes rows beyond. Each merges slot a, the lowest slot
/// at the smallest nearest distance, with its recorded nearest neighbour.
/// Combines of at most kFewCombine clusters (with every kernel) and those
/// that make one merge take instead the first pair (a, b) in slot order at
/// the smallest distance, by scanning all live pairs: the same pair unless
/// distances tie, where the recorded neighbour can be another
/// (docs/PERFORMANCE.md, row 112). `variant` picks a loop for tests (Small
/// beyond its limit runs the matrix; Small at most kFewCombine the pair
/// scan); builds pass Automatic.
enum class CombineVariant { Automatic, Small, Matrix, Rows };
constexpr uint32_t kSmallCombine = 16;
constexpr uint32_t kFewCombine = 8;
constexpr uint32_t kMatrixCombine = 2048;

uint32_t combine_clusters(BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                          float scale, const FlattenRule &rule, ChoiceTable choices, CombineScratchPool &scratch_pool,
                          BuildContext &ctx, CombineVariant variant = CombineVariant::Automatic);

} // namespace aacbvh
