// Where the solve's bands go (solve_controller.cc, issues #14 and #15), so
// that no full-size solution is held unless the depth refinement re-solves:
// to the result files as they are solved, or into a spill file until the
// depth refinement has decided whether the first pass is the result.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "app/controllers/base_controller.h"
#include "app/io/result_maps.h"
#include "core/bounded_worker.h"
#include "pipeline/albedo_color.h"
#include "pipeline/depth_refinement.h"
#include "pipeline/ground_truth_evaluation.h"
#include "solver/photometric_solver.h"

namespace scanbench {

// What the solve does with each band of its result: the albedo's colour
// (ApplyAlbedoColor on its solved pixels), the specular tally, the
// ground-truth evaluation and the maps, streamed into a folder band by band.
// The time of each part goes to its stage of `times`: "color", "evaluate"
// (beside the encoding) and "write_maps" (the rest).
class ResultStream {
 public:
  // `evaluation` empty: a session without ground truth.
  ResultStream(const std::filesystem::path& folder, int width, int height, const AlbedoColor& color,
               const ExrEncoding& exr, std::optional<GroundTruthEvaluation> evaluation, int num_threads,
               StageTimes* times);
  ResultStream(const ResultStream&) = delete;
  ResultStream& operator=(const ResultStream&) = delete;
  ~ResultStream();

  // The next band (rows following the last band's); its albedo is coloured in place.
  void Add(PhotometricSolution& band);
  std::optional<SpecularMapStatistics> specular() const { return specular_.Finish(); }
  bool evaluates() const { return evaluation_.has_value(); }
  // Every band added. Not timed here: the caller's steps.
  GroundTruthComparison FinishEvaluation() { return evaluation_->Finish(num_threads_); }
  std::map<std::string, std::string> Commit() { return maps_->Commit(); }

 private:
  std::filesystem::path folder_;
  int width_, height_;
  AlbedoColor color_;
  ExrEncoding exr_;
  int num_threads_;
  StageTimes* times_;
  SpecularMapTally specular_;
  std::optional<GroundTruthEvaluation> evaluation_;
  std::optional<SolutionMapStream> maps_;
  ImageU8 solved_;  // the band's solved pixels, kept from band to band
};

class FirstPassSpill;

// The route of a solve's bands, from the first pass to the result files:
//  - kStream (the depth refinement cannot re-solve: off, or a calibration
//    set's measured light field): each band to the result files as it is
//    solved;
//  - kSpill: every band into a spill file (FirstPassSpill) with the depth
//    decision's block means; the table plane kept, the bands are replayed to
//    the result files; draped, their normals and status start the re-solves
//    and the last re-solve goes to the result files;
//  - kStreamAndSpill (SolveOptions::stream_first_pass: latency, not the
//    result): each band to the result files on a thread of its own beside
//    the solve, and its normals and status to the spill; draped, those
//    result files are dropped (before any is in place) and the re-solve's
//    written.
// Whatever the route, the result files hold the same bytes.
class SolveRouting {
 public:
  enum class Route { kStream, kSpill, kStreamAndSpill };

  // A width x height solve; spill files in `spill_folder`. `open_results`
  // opens the result files (at most twice: a draped sample's streamed first
  // pass, then its re-solve).
  SolveRouting(Route route, int width, int height, const std::filesystem::path& spill_folder, int num_threads,
               std::function<std::unique_ptr<ResultStream>()> open_results);
  SolveRouting(const SolveRouting&) = delete;
  SolveRouting& operator=(const SolveRouting&) = delete;
  ~SolveRouting();

  // The first pass's bands, in order of rows (SolveBanded's sink, on its thread).
  void AddFirstPassBand(PhotometricSolution& band);
  // After the last band: waits for the band writer (kStreamAndSpill) and
  // rethrows its failure.
  void FinishFirstPass();

  // The depth decision's blocks of the first pass; null with kStream (no
  // decision to take) and once the first pass was taken.
  const DepthDecisionBlocks* decision_blocks() const;
  // Draped: the first pass's normals and status at full size, the start of
  // the re-solves; a streamed first pass's result files are dropped.
  PhotometricSolution TakeFirstPassForResolve();
  // The re-solves' result (after TakeFirstPassForResolve), to new result
  // files, kEvaluationBandRows at a time.
  void StreamResolved(const PhotometricSolution& solution);

  // Every band routed: the result files holding all of them. A spilled first
  // pass that is the result is replayed into them now.
  ResultStream& Results();

 private:
  void Take(PhotometricSolution& band);

  std::function<std::unique_ptr<ResultStream>()> open_results_;
  std::unique_ptr<FirstPassSpill> first_pass_;
  std::unique_ptr<ResultStream> results_;
  // kStreamAndSpill's band writer, until FinishFirstPass; last, so that it stops first.
  std::unique_ptr<BoundedWorker<PhotometricSolution>> writer_;
};

}  // namespace scanbench
