// Internal to scanbench_sim: solver/parallel_rows.h with the simulator's
// cancellation, an exception.
#pragma once

#include "app/sim/simulated_rig.h"
#include "solver/parallel_rows.h"

namespace scanbench::sim_internal {

// scanbench::ParallelRows; a cancel through `progress` throws RenderCancelled.
template <typename Body>
void RenderRows(int rows, int num_threads, const RenderProgressCallback& progress, double begin, double end,
                  const Body& body) {
  if (!scanbench::ParallelRows(rows, num_threads, progress, begin, end, body)) throw RenderCancelled();
}

}  // namespace scanbench::sim_internal
