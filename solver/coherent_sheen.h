// Spatial coherence for the velvet sheen (issue #13): pixels of one thread
// share a BRDF, so their sheen is fitted once from all of them.
//
// The per-pixel sheen fit (FitDiffuseSheen, adaptive_sheen) adds two unknowns
// to each pixel's ten samples and, decided pixel by pixel, takes noise for
// sheen on Lambertian scenes. RefineCoherentSheen runs after the per-pixel
// passes (and after the shared lobe). It cuts the image into square blocks;
// a block's candidate pixels (solved, in the region, least-squares result:
// no specular lobe, no robust re-solve) first pass a gate (gate_ratio): on
// the candidates of the block's two fullest rows, at their least-squares
// normals, the residual a sheen of one of a few widths can take out must be
// a share of their residual in at least one albedo group, or the block is
// left after that one look (a Lambertian block: the cost of the pass on a
// Lambertian scene). Past the gate, the candidates are split into at most
// two groups of similar albedo chromaticity (warp and weft; RGB input only),
// and for each group with enough candidates that passes the gate on its own
// gate pixels, on an even spread of its pixels, it alternates
//   1. one velvet sheen (white amplitude F0 and width a) for the whole group,
//      each pixel's Lambertian part projected out (its scaled normal is free:
//      the sheen is fitted on what the Lambertian model cannot explain), the
//      width by a search over log a, F0 in closed form, and
//   2. each pixel's scaled normal re-solved under that sheen (least squares
//      on the samples minus the sheen, which depends on the normal: a fixed
//      point, a few 3x3 solves),
// and keeps the sheen for the group only where it pays by BIC on those
// pixels' samples together (two shared parameters against hundreds of
// samples), lowers their residual by at least min_residual_drop, has a
// width inside the search range (not pinned at a bound) and, on RGB input,
// is white (dichromatic: the residual it explains is the same in every
// colour channel, not in the albedo's proportions). Blocks whose
// pixels are mostly glossy (max_lobe_fraction) are left alone. Then
// every candidate of the group is re-solved under the group's sheen. A group
// that does not take it keeps its least-squares results bit for bit.
// Luminance model per sample (intensity divided, as the solver's):
//   b_k = l_k . m + F0 S(n, l_k, v; a),   n = m / |m|,  S: VelvetSheenShape;
// the sheen is white, so each colour channel's albedo is the length of its
// scaled normal solved on the channel's samples minus the same F0 S.
// It also runs in the Bayer domain (SolvePhotometricStereoBayer), one group
// per block (no chromaticity per raw pixel), where the blend of the
// demosaiced and Bayer-domain normals needs the sheen out of the Bayer fit's
// residual (docs/solver.md, "Shared velvet sheen").
#pragma once

#include <cstddef>
#include <string>

#include "core/progress.h"
#include "core/summary.h"
#include "solver/photometric_solver.h"

namespace scanbench {

struct CoherentSheenOptions {
  // Side of the square blocks whose pixels may share a sheen, pixels, in [4, 256].
  int block_size = 32;
  // Fewest candidate pixels of one albedo group to fit its shared sheen, in [8, 65536].
  int min_pixels = 64;
  // Pixels of a group the sheen is fitted and decided on (an even spread of
  // rows and columns), in [8, 65536]; every candidate of a group that takes
  // the sheen is re-solved.
  int max_fit_pixels = 128;
  // Alternations of the shared-sheen fit and the fit pixels' re-solve, in [1, 10].
  int iterations = 2;
  // Bounds of the velvet width a, 0 < min_width < max_width <= 10.
  double min_width = 0.3;
  double max_width = 2.0;
  // A block's candidates are split into two groups when the centres of their
  // two albedo chromaticity clusters (r, g of rgb / sum) are further apart
  // than this, >= 0 (a large value never splits).
  double albedo_split = 0.03;
  // The pass runs only on solves with at most this many lights, in [3, 1000]:
  // with many lights a Lambertian fit's residual has other structure to
  // explain (DiLiGenT's 96), the pass is for the rig's ten.
  int max_lights = 24;
  // The gate, before any fit: on the candidates of the block's two fullest
  // rows at their least-squares normals, the residual a sheen of one of the
  // gate's widths can take out (their scaled normals projected out) must be
  // at least this fraction of their residual sum of squares in one albedo
  // group, in [0, 1) (0: every block is fitted); then the same on each fit
  // group's own pixels of those rows, and on its fit pixels before their
  // re-solve. A Lambertian block costs one look at 64 pixels (16 MP, 10 LEDs:
  // 3 % of the blocks pass; 0.05: cloth 0.592 deg against 0.590).
  double gate_ratio = 0.025;
  // BIC penalty per shared parameter, in units of ln(samples), >= 0 (1 = BIC).
  double bic_penalty = 1.0;
  // The group's sheen must also lower its fit pixels' residual sum of squares
  // by at least this fraction, in [0, 1): a Lambertian block whose residual
  // has some other smooth structure (fibre footprints, shadow edges, the
  // table-plane light field of a draped sample's first pass) then keeps its
  // least-squares result however many samples it has (cloth 0.594 deg,
  // draped 0.40531; 0.05: 0.590, 0.40564; 0.10: 0.592, 0.40537; docs/solver.md).
  double min_residual_drop = 0.12;
  // A block is left alone where its solved pixels with a specular lobe (the
  // per-pixel GGX fit's or the shared lobe's) are more than this fraction of
  // its candidates, >= 0: a glossy material's lobe tails in the neighbouring
  // pixels are not a velvet sheen (DiLiGenT ball at 10 lights, docs/solver.md).
  double max_lobe_fraction = 0.05;
  // The dichromatic test: the sheen is white, the diffuse coloured, so a
  // group takes the sheen only where one F0 for all colour channels explains
  // at least white_margin times as much of the residual as an F0 in
  // proportion to the group's albedo colour (an error of the diffuse model
  // scales with the albedo). RGB input only. false: no colour test
  // (DiLiGenT ball at 10 lights 1.980 -> 2.015 deg without it; margin 1:
  // 1.997, 1.05: 1.980).
  bool dichromatic = true;
  double white_margin = 1.05;  // > 0
  // Worker threads; 0 = all hardware threads, in [0, 256].
  int num_threads = 0;

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

struct CoherentSheenSummary : AlgorithmSummary {
  bool skipped_lights = false;   // more lights than max_lights: nothing done
  size_t pixels_candidate = 0;   // solved least-squares pixels in blocks worked on
  size_t blocks_gated = 0;       // blocks with enough candidates the gate looked at
  size_t blocks_passed = 0;      // of those, past the gate (gate_ratio)
  size_t groups_tried = 0;       // block albedo groups a shared sheen was fitted to
  size_t groups_taken = 0;       // of those, that took it (BIC and min_residual_drop)
  size_t pixels_refined = 0;     // pixels re-solved under a shared sheen
  double mean_f0 = 0;            // over the groups that took it
  double mean_width = 0;
  double seconds = 0;
  std::string BriefReport() const;
};

// Refines `solution` (a per-pixel solve of `input` with `solver_options`) in
// place; pixels outside the taken groups are not touched. The samples are
// taken as the solver takes them (solver_options' luminance weights, shadow
// level, light intensity floor, sample masks). Throws std::invalid_argument
// on inputs that do not fit the solution; a cancelled run returns kCancelled
// with the blocks done so far refined and the rest as they were.
CoherentSheenSummary RefineCoherentSheen(const CoherentSheenOptions& options,
                                         const PhotometricSolverOptions& solver_options,
                                         const PhotometricSolverInput& input, PhotometricSolution* solution,
                                         const ProgressCallback& progress = {});

namespace tiled {
struct SolveJob;
// The same on the solver's own job (RGB or Bayer layout; in the Bayer layout
// the raw pixel's albedo goes to job.albedo_mosaic when set): what RunSolve
// calls after the per-pixel passes.
CoherentSheenSummary RefineCoherentSheenOfJob(const CoherentSheenOptions& options, const SolveJob& job,
                                              const ProgressCallback& progress = {});
}  // namespace tiled

}  // namespace scanbench
