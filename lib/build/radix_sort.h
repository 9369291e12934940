// LSD radix sort of (64-bit key, 32-bit value) pairs; stable, so equal keys
// keep their input order (which makes builds deterministic). And a one-thread
// sort of 64-bit values by their high halves, for runs sorted one per task.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/memory.h"
#include "core/scheduler.h"

namespace aacbvh {

/// Sorts keys ascending, moving values along. The keys must be below
/// 2^key_bits: only the digits that hold those bits are sorted on, and
/// digits on which every key agrees are skipped. Runs
/// on the scheduler's threads; the result does not depend on their number.
void radix_sort_pairs(Array<uint64_t> &keys, Array<uint32_t> &values, unsigned key_bits, Scheduler &scheduler);
/// The same for 32-bit keys with 64-bit values (build/morton.cpp sorts the
/// codes' high half this way, carrying their low half and the index).
void radix_sort_pairs(Array<uint32_t> &keys, Array<uint64_t> &values, unsigned key_bits, Scheduler &scheduler);
/// The same over keys[0, n) and values[0, n), passing between them and the
/// caller's keys_tmp[0, n) and values_tmp[0, n) instead of arrays of its
/// own; true when the result ends in the tmp pair.
bool radix_sort_pairs(uint32_t *keys, uint64_t *values, uint32_t *keys_tmp, uint64_t *values_tmp, size_t n,
                      unsigned key_bits, Scheduler &scheduler);

/// Sorts values[0, count) by their high halves (bits 32-63), stably, on the
/// calling thread: byte-wise LSD passes between values and scratch[0, count),
/// a pass skipped where every value has the same byte; the result ends in
/// values. For build/morton.cpp's long runs of equal high code halves.
void radix_sort_high_halves(uint64_t *values, uint64_t *scratch, size_t count);

} // namespace aacbvh
