// The skeleton of the shared-model passes (RefineCoherentLobe,
// RefineCoherentSheen): the image in square blocks; in each block the
// candidate pixels grouped by albedo; per group one model fitted to its
// pixels together, kept where it pays, and written to the pixels that take
// it. The passes differ in the model and in their rules, not in this shape.
#pragma once

#include <memory>
#include <vector>

#include "core/progress.h"
#include "core/summary.h"
#include "solver/tiled_solve.h"

namespace scanbench::tiled {

// A Refiner (one per worker, reused between blocks) provides
//   using Counts = ...;  // its figures, one per worker, summed by the pass
//   // The block's candidates; false leaves the block as it is.
//   bool CollectBlock(int x0, int y0, int x1, int y1, Counts* counts);
//   // The candidates in groups of similar albedo; how many groups.
//   int GroupByAlbedo();
//   // The pixels of group g; false when the group is not to be fitted.
//   bool GatherGroup(int group);
//   // The group's shared model; false when the group does not take it.
//   bool FitGroup(Counts* counts);
//   // Each pixel of the group that takes the shared model (the refiner's
//   // rule, per pixel or for the group) written.
//   void WriteGroup(Counts* counts);
template <typename Refiner>
void RefineBlock(Refiner* refiner, int x0, int y0, int x1, int y1, typename Refiner::Counts* counts) {
  if (!refiner->CollectBlock(x0, y0, x1, y1, counts)) return;
  const int groups = refiner->GroupByAlbedo();
  for (int group = 0; group < groups; ++group) {
    if (!refiner->GatherGroup(group)) continue;
    if (refiner->FitGroup(counts)) refiner->WriteGroup(counts);
  }
}

// RefineBlock over every block of width x height (RunBlockPass), each worker
// with its own Refiner from make_refiner() (a std::unique_ptr<Refiner>, made
// when the worker takes its first block). Returns the workers' Counts.
template <typename Refiner, typename MakeRefiner>
std::vector<typename Refiner::Counts> RunBlockRefiners(int width, int height, int block_size, int num_threads,
                                                       const MakeRefiner& make_refiner,
                                                       const ProgressCallback& progress, AlgorithmSummary* summary) {
  const int num_workers = BlockPassWorkers(num_threads, width, height, block_size);
  std::vector<std::unique_ptr<Refiner>> workers(num_workers);
  std::vector<typename Refiner::Counts> counts(num_workers);
  RunBlockPass(
      width, height, block_size, num_workers,
      [&](int x0, int y0, int x1, int y1, int worker) {
        if (!workers[worker]) workers[worker] = make_refiner();
        RefineBlock(workers[worker].get(), x0, y0, x1, y1, &counts[worker]);
      },
      progress, summary);
  return counts;
}

}  // namespace scanbench::tiled
