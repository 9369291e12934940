// LSD radix sort of (64-bit key, 32-bit value) pairs; stable, so equal keys
// keep their input order (which makes builds deterministic).
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/memory.h"
#include "core/scheduler.h"

namespace aacbvh {

/// Sorts keys ascending, moving values along. Only the low `key_bits` bits of
/// the keys are looked at; digits on which every key agrees are skipped. Runs
/// on the scheduler's threads; the result does not depend on their number.
void radix_sort_pairs(Array<uint64_t> &keys, Array<uint32_t> &values, unsigned key_bits, Scheduler &scheduler);
/// The same for 32-bit keys with 64-bit values (build/morton.cpp sorts the
/// codes' high half this way, carrying their low half and the index).
void radix_sort_pairs(Array<uint32_t> &keys, Array<uint64_t> &values, unsigned key_bits, Scheduler &scheduler);

} // namespace aacbvh
