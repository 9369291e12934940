// Refit: new bounds for moved geometry, same topology.
#pragma once

#include "bvh/bvh.h"
#include "core/geometry.h"
#include "core/scheduler.h"

namespace aacbvh {

/// Recomputes every node's box bottom-up from the geometry (same topology):
/// leaves in parallel, then inner nodes in one reverse sweep. Linear time.
void refit_tree(Bvh &bvh, const Geometry &geometry, Scheduler &scheduler);

} // namespace aacbvh
