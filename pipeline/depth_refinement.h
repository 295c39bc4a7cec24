// Draped samples (issue #15): a depth-aware light field. The first solve
// assumes every pixel's surface point lies on the table plane; a sample a few
// centimetres high then gets wrong light directions and falloff. The loop (as
// in Queau et al.'s near-field photometric stereo, "near_ps"):
//   1. integrate the solved normals to a height map (maps' DCT solver, scale
//      from the camera's pixel footprint on the table);
//   2. anchor it: the height at anchor_percentile of the solved pixels is put
//      on the table (z = 0) -- the table around the sample when it is in view,
//      else the lowest folds, which rest on the table;
//   3. move each pixel's surface point along its camera ray to that height;
//   4. re-evaluate the point LEDs there (directions, inverse square, angular
//      falloff) and re-solve, leaving out the lit samples at the edges of
//      cast shadows (below);
// until 99 % of the surface points would move less than tolerance_mm or max_iterations
// re-solves ran. Whether the loop runs at all is decided on block means: the
// first pass's normals averaged over kDepthDecisionBlockPx-square blocks are
// integrated (a 64th of the pixels) and their height range compared with
// min_height_range_mm; a flat sample then never integrates at full size. Only point-LED light fields can be moved (the rig
// description, a calibration set's fitted LEDs); a measured per-pixel field is
// sampled on the table plane only and is left as it is (the summary says so).
//
// Shadow edges: a draped sample's folds cast long shadows. Demosaicing fills
// a pixel's missing colours from raw samples up to 2 px away, so the pixels
// along a shadow's edge mix lit and shadowed light: a sample neither lit nor
// dark that the Lambertian fit takes for lit. On the +-25 mm scene these cost
// more than the light field's remaining error (docs/solver.md, "Draped
// samples"); the re-solves leave out every lit sample within
// shadow_edge_radius_px of a shadowed sample of the same light.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calibration/rig.h"
#include "core/image.h"
#include "core/progress.h"
#include "core/summary.h"
#include "solver/light_field.h"
#include "solver/photometric_solver.h"

namespace scanbench {

// Side of the blocks (px) whose mean normals decide whether the loop runs.
// The blocks average steep walls' slopes away, so the block range reads low:
// at 400x264 (50 x 33 blocks) 11 % below the full-size one on the +-25 mm
// scene, 4 % on the +-2.5 mm one, both far from the 8 mm threshold
// (tests/pipeline/depth_refinement_test.cc).
inline constexpr int kDepthDecisionBlockPx = 8;

struct DepthRefinementOptions {
  bool enabled = true;               // false = the table plane only (solve --no-depth-refine)
  // The unknown factor of the integrated distances chosen by the images
  // (ResidualScaleChooser) instead of by anchor_percentile alone, which then
  // only centres the search: for a folder whose plane is not a table the
  // object lies on (solve-dataset's default; `solve` keeps its table). Only
  // RefineDepth on frames in memory can; the banded overload ignores it.
  bool anchor_by_residual = false;
  int max_iterations = 4;            // re-solves at most, [1, 20] (solve --depth-iterations)
  double tolerance_mm = 0.5;         // converged when 99 % of the surface points would move less than this, mm, > 0
  double min_height_range_mm = 8.0;  // refine only when the first pass's height range (p99 - p1) exceeds this, mm, >= 0
  double anchor_percentile = 0.5;    // this percentile of the solved pixels' height is put on the table, [0, 50]
  int shadow_edge_radius_px = 2;     // re-solves leave out lit samples this close (square, px) to a shadowed one of the same light, [0, 10], 0 = keep them
  double shadow_edge_level = 0.001;  // a sample whose luminance (the solver's weights, linear) is at or below this is shadowed, [0, 1]
  void Check() const;
  // The options as JSON text: {"enabled": .., "max_iterations": .., ...}
  // (report.json's solver.depth_refinement, and the solve's inputs text).
  std::string ReportJson() const;
};

// One re-solve: how far the surface points moved to get there.
struct DepthIteration {
  double max_move_mm = 0;       // over the solved pixels
  double mean_move_mm = 0;
  double p99_move_mm = 0;       // 99th percentile over the solved pixels
  double height_range_mm = 0;   // p99 - p1 of the anchored height the points moved to
  double seconds = 0;           // integration, new light field and re-solve
  // anchor_by_residual: the chosen factor of the distances over the one
  // anchor_percentile gives (0 = not chosen so).
  double scale_vs_percentile = 0;
};

struct DepthRefinementSummary : AlgorithmSummary {
  bool refined = false;                  // at least one re-solve ran
  // p99 - p1 of the first pass's height integrated from decision_block_px
  // block means (0 when not integrated): what decides whether the loop runs.
  double first_height_range_mm = 0;
  int decision_block_px = 0;             // kDepthDecisionBlockPx, 1 for images too small for blocks, 0 = not integrated
  std::vector<DepthIteration> iterations;
  double final_move_max_mm = -1;         // converged: the largest move not made, mm; -1 otherwise
  double final_move_p99_mm = -1;         // converged: its 99th percentile (< tolerance), mm; -1 otherwise
  size_t shadow_edge_samples = 0;        // lit samples the re-solves left out at shadow edges (all lights)
  // Pixels the last masked re-solve could not solve (too few or
  // ill-conditioned lights left, facing away), solved with their edge
  // samples instead (SolveWithEdgeSamplesWhereMasksFail; RefineDepth on
  // frames in memory only, the banded solve keeps the min_lights rule).
  size_t shadow_edge_kept_pixels = 0;
  std::string stop_reason;               // "converged (...)", "iteration cap", "height range ... below ...", ...
  PhotometricSolverSummary last_resolve; // the last re-solve's summary (the solution's), when refined
  double seconds = 0;
  // "Depth refinement: success, 3 iteration(s), surface moved max 48.29/7.44/3.09 mm, p99 .../... mm,
  // mean .../... mm; first-pass height range ...; stopped: converged (...), 12.3 s".
  std::string BriefReport() const;
  // report.json's "depth_refinement" (`scanbench solve`, `solve-dataset`), JSON
  // text: enabled (from `options`), refined, iterations (max / mean / p99
  // move, height range, seconds each), first_height_range_mm,
  // decision_block_px, shadow_edge_samples, stop_reason, seconds, message.
  std::string ReportJson(const DepthRefinementOptions& options) const;
};

// `input` is the first pass's input (its light_field is not used);
// `solution` holds the first pass's result on entry and the last re-solve's on
// return. `lights` and `camera` are those of the light field the first pass
// used. Writes the final surface points (3 channels, table mm) into
// *surface_points_in_table when given (the table points when nothing ran).
// Throws std::invalid_argument on bad options (naming the field); a cancelled
// progress callback returns kCancelled with the last complete solution.
DepthRefinementSummary RefineDepth(const DepthRefinementOptions& options, const PhotometricSolverOptions& solver,
                                   const PhotometricSolverInput& input, const std::vector<PointLight>& lights,
                                   const CameraGeometry& camera, PhotometricSolution* solution,
                                   ImageF* surface_points_in_table = nullptr, const ProgressCallback& progress = {});

// A re-solve under a moved light field (the full size of the solution):
// what RefineDepth runs at every iteration. The overload above solves its
// `input` with SolvePhotometricStereo; a banded solve (banded_solve.h) passes
// its own, so that no full-size developed frames are needed. A re-solve
// leaves out the lit samples at cast-shadow edges as options.shadow_edge_*
// say (ShadowEdgeSampleMasks) and sets *shadow_edge_samples to how many.
using DepthResolve = std::function<PhotometricSolverSummary(const LightField& moved_field,
                                                            PhotometricSolution* solution,
                                                            const ProgressCallback& progress,
                                                            size_t* shadow_edge_samples)>;
// Chooses the unknown factor f of the integrated distances: each solved
// pixel's point lies at t = f q t_table along its ray (t_table the ray's
// distance to the table plane, q = `q`, 1 channel); `percentile_factor` is
// the f that puts anchor_percentile on the table. Returns f (> 0).
using DepthScaleChooser =
    std::function<double(const PhotometricSolution& solution, const ImageF& q, double percentile_factor)>;

DepthRefinementSummary RefineDepth(const DepthRefinementOptions& options, const DepthResolve& resolve,
                                   const std::vector<PointLight>& lights, const CameraGeometry& camera,
                                   PhotometricSolution* solution, ImageF* surface_points_in_table = nullptr,
                                   const ProgressCallback& progress = {}, const DepthScaleChooser& choose_scale = {});

// anchor_by_residual's chooser (issue #33): near-field lights make the
// absolute distance observable, since moving every point by a common factor
// changes each LED's direction and falloff differently. Among f within
// +-25 % (log) of percentile_factor (a grid of 2 % steps, then a golden-
// section search to 0.05 %) it takes the f whose points give the smallest
// median, over a regular grid of at most 16384 solved pixels, of the
// relative RMS residual of each pixel's Lambertian least-squares fit: the
// solver's luminance of the samples each divided by the light's RGB, those
// at or below min_sample_value, not in input.sample_valid or not in `masks`
// (the shadow edges; may be null) left out, pixels with fewer than 4 samples
// and those the solution gave a specular lobe or a shared sheen left out.
// The median, not the mean: pixels the Lambertian model does not fit
// (highlights, shadow edges) do not move it. With fewer than 64 pixels it
// keeps percentile_factor. The arguments must outlive the chooser. On a
// glossy material the residual's minimum is the light field's and the
// gloss's: on the draped satin folder it sits 1.6 % nearer than the truth
// (docs/solver.md, "Datasets").
DepthScaleChooser ResidualScaleChooser(const PhotometricSolverOptions& solver, const PhotometricSolverInput& input,
                                       const std::vector<ImageU8>* masks, const std::vector<PointLight>& lights,
                                       const CameraGeometry& camera);

// Steps of RefineDepth, exposed for tests.

// Height (mm, table z) of every pixel's surface from the solved normals,
// anchored as the options say; unsolved pixels are filled smoothly.
// With choose_scale, the factor it chooses instead (and its ratio to the
// percentile's in *chosen_vs_percentile when given).
ImageF AnchoredHeightFromSolution(const DepthRefinementOptions& options, const PhotometricSolution& solution,
                                  const CameraGeometry& camera, const DepthScaleChooser& choose_scale = {},
                                  double* chosen_vs_percentile = nullptr);

// p99 - p1 of `height_mm` over the solved pixels of `solution`, mm.
double SolvedHeightRangeMm(const PhotometricSolution& solution, const ImageF& height_mm);

// The first pass at blocks of block_px square: per whole block the mean of
// its solved pixels' normals (normalised), solved when at least half its
// pixels are; the rest (0, 0, 1) and unsolved. Pairs with BlockCamera.
PhotometricSolution BlockMeanSolution(const PhotometricSolution& solution, int block_px,
                                      int num_threads = 0);

// The first pass's decision blocks gathered band by band (the solve streams
// its bands, so no full-size first pass is held when the table plane is
// kept): BlockMeanSolution's blocks of the bands added in order of rows, any
// band heights, bit for bit. block_px 0 = kDepthDecisionBlockPx, or 1 when
// the image has fewer than 16 whole blocks across or down; with 1 the
// normals and status are kept at full size (small images only).
class DepthDecisionBlocks {
 public:
  DepthDecisionBlocks(int width, int height, int block_px = 0);
  // The next rows of the first pass (its normal_in_table and status); the
  // block columns run on num_threads (0 = all).
  void AddRows(const PhotometricSolution& band, int num_threads = 0);
  int block_px() const { return block_px_; }
  // Every row added: the block-mean solution (normal_in_table and status).
  const PhotometricSolution& blocks() const;

 private:
  int width_, height_, block_px_;
  int rows_added_ = 0;
  PhotometricSolution blocks_;
  std::vector<Eigen::Vector3d> sums_;  // per block column: the block row being added
  std::vector<int> solved_;
};

// What decides whether the loop runs: the anchored height range (mm) of the
// block-mean solution integrated through BlockCamera(camera, block_px)
// (block_px 1: the full-size range).
double DecisionHeightRangeMm(const DepthRefinementOptions& options, const DepthDecisionBlocks& blocks,
                             const CameraGeometry& camera);
// The same of a whole first pass; *block_px_used gets DepthDecisionBlocks' block_px.
double DecisionHeightRangeMm(const DepthRefinementOptions& options, const PhotometricSolution& solution,
                             const CameraGeometry& camera, int* block_px_used = nullptr);

// RefineDepth's decision from the first pass's blocks: when the loop would
// not run (disabled, or the height range not above min_height_range_mm) the
// summary RefineDepth returns (its `seconds` the decision's), else nullopt
// (then RefineDepth on the whole first pass runs the loop). The solve takes
// it on the bands it streamed (solve_controller.cc).
std::optional<DepthRefinementSummary> TablePlaneKept(const DepthRefinementOptions& options,
                                                     const DepthDecisionBlocks& blocks, const CameraGeometry& camera);

// Where each pixel's camera ray meets the height z = height_mm(x, y): 3 channels, table mm.
ImageF SurfacePointsAtHeight(const CameraGeometry& camera, const ImageF& height_mm);

// The pixels of a re-solve under ShadowEdgeSampleMasks' `masks` that came
// out unsolved although the masks took samples from them (too few or
// ill-conditioned lights left, facing away): solved again from `input` (the
// same frames and light field, its own sample_valid, not the masks) on
// those pixels only, and taken into *solution where that solve succeeds; a
// solve from the edge samples beats none (as ShadowEdgeSampleMasks keeps
// them where fewer than min_lights lit samples would remain). *summary (of
// *solution) counts the pixels taken under their new status, path and
// specular status. Returns how many were taken.
size_t SolveWithEdgeSamplesWhereMasksFail(const PhotometricSolverOptions& solver, const PhotometricSolverInput& input,
                                          const std::vector<ImageU8>& masks, PhotometricSolution* solution,
                                          PhotometricSolverSummary* summary);

// Per light of `input` (1 channel, as PhotometricSolverInput::sample_valid):
// its sample_valid (all 1 when it has none) with the lit samples within
// options.shadow_edge_radius_px of a shadowed sample (luminance <=
// shadow_edge_level, weights solver.luminance_weights) set to 0. Adds the
// samples it set to 0 to *num_left_out when given.
std::vector<ImageU8> ShadowEdgeSampleMasks(const DepthRefinementOptions& options,
                                           const PhotometricSolverOptions& solver,
                                           const PhotometricSolverInput& input, size_t* num_left_out = nullptr);

}  // namespace scanbench
