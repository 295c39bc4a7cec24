// Issue #13: the normals of a demosaiced solve and of a Bayer-domain solve of
// the same raw frames, blended per pixel. Demosaicing takes two of a pixel's
// three colours from its neighbours: where the true normals vary from pixel
// to pixel (cloth fibres) that mixes the neighbours' normals in, where they
// vary smoothly (a Lambertian weave) it averages the sensor noise down. The
// Bayer-domain normal is the pixel's own but noisier (one raw sample per
// light). Per square cell the blend weighs the two by how far they disagree
// beyond the Bayer normal's own noise, the shrinkage that minimises the
// expected squared error of w n_bayer + (1 - w) n_demosaiced:
//   w = clamp(1 - var_bayer / mean |n_bayer - n_demosaiced|^2, 0, 1),
// var_bayer = the Bayer fit's sample variance (its residual, N / (N - 3))
// times the tangential trace of (L^T L)^-1 of the cell's lights: the
// normal's angular variance per unit sample variance. Disagreement at the
// noise level keeps the (less noisy) demosaiced normal; a disagreement well
// above it takes the pixel's own.
//
// The Bayer-domain solve costs about as much as the demosaiced one, and where
// the normals vary smoothly at the pixel scale (a weave at 16 MP) it finds
// nothing to blend. So the cells worth it are chosen first, from the
// demosaiced solve alone (SelectBayerBlendCells), and the Bayer-domain solve
// runs only there (its region, BayerBlendRegion): the demosaic's error on a
// pixel is its normal against the mean of its neighbours', so a gate block
// (one cell row, gate_block_cells cells long) is weighed only where the
// demosaiced normals' second differences exceed gate_ratio times their noise.
#pragma once

#include <string>

#include "core/image.h"
#include "core/progress.h"
#include "core/summary.h"
#include "solver/light_field.h"
#include "solver/photometric_solver.h"

namespace scanbench {

struct BayerNormalBlendOptions {
  // Side of the square cells one weight is estimated on, pixels, in [2, 64];
  // cells start at (0, 0), so a solve cut into bands of a multiple of it rows
  // blends as the whole frame does.
  int cell_size = 4;
  // The gate (SelectBayerBlendCells): cells per gate block along a row, in
  // [1, 4096]; a block is one row of cells (32 x 4 px = 128 px, the solver's
  // tile width: its rows are what the Bayer-domain solve skips).
  int gate_block_cells = 32;
  // A block is weighed where mean |n(x-1) + n(x+1) - 2 n(x)|^2 (rows and
  // columns, the demosaiced normals inside the block) exceeds gate_ratio
  // times t s_d^2 (t as the weight's, s_d^2 the demosaiced fit's sample
  // variance), >= 0; 0 = every block (the blend before the gate).
  double gate_ratio = 3.0;
  // Or where that mean over one of its cells exceeds gate_cell_ratio times
  // the block's t and the cell's s_d^2, >= 0 (a thread crossing a smooth
  // stretch). Unused when gate_ratio is 0.
  double gate_cell_ratio = 6.0;
  // Optional, not owned: each cell's weight given instead of estimated
  // (1 channel, ceil(width / cell_size) x ceil(height / cell_size), values in
  // [0, 1]; what an earlier blend's summary returned as cell_weights). The
  // depth re-solves blend with the first re-solve's weights: re-estimated on
  // every pass they move the normals, the surface and again the weights, and
  // the loop does not settle (docs/solver.md). Null = estimate.
  const ImageF* cell_weights = nullptr;
  // Optional, not owned: the Bayer-domain normals of the pixels with a
  // shared lobe (RefineCoherentLobe's input.lobe_bayer: the light field's
  // size; normal, status, lights_used). A demosaiced lobe pixel solved there
  // takes that normal (no weight: see BlendBayerNormals), whatever
  // cell_weights say; the others keep the demosaiced normal. Null or empty =
  // every lobe pixel keeps it.
  const PhotometricSolution* lobe_bayer = nullptr;
  // Worker threads; 0 = all hardware threads, in [0, 256].
  int num_threads = 0;
  void Check() const;
};

struct BayerNormalBlendSummary : AlgorithmSummary {
  size_t pixels_blended = 0;  // took a non-zero share of the Bayer normal
  size_t pixels_kept = 0;     // solved, but left as the demosaiced solve's (a lobe without lobe_bayer, or no Bayer fit, or w = 0)
  size_t pixels_lobe_replaced = 0;  // lobe pixels that took options.lobe_bayer's normal
  size_t pixels_weighed = 0;  // solved by both, without a lobe: the pixels a weight was estimated for
  double mean_weight = 0;     // mean Bayer share over pixels_weighed
  // The weight of every cell (the estimated ones, or options.cell_weights'),
  // 0 where no pixel was weighed; the shape options.cell_weights takes.
  ImageF cell_weights;
  std::string BriefReport() const;
};

struct BayerBlendCellsSummary : AlgorithmSummary {
  // Per cell of the blend's grid (ceil(width / cell_size) x ceil(height /
  // cell_size), 1 channel): 1 where the Bayer-domain solve is needed.
  ImageU8 cells;
  size_t blocks = 0;         // gate blocks with a pixel to weigh
  size_t blocks_open = 0;    // of them, those whose cells are solved in the Bayer domain
  // Pixels the demosaiced solve solved without a lobe in the cells left out:
  // they keep the demosaiced normal (weight 0) without a Bayer-domain fit.
  size_t pixels_left_out = 0;
  std::string BriefReport() const;
};

// Which cells of the blend can take a non-zero weight, from the demosaiced
// solve alone (normal_in_table, status, lights_used, residual, and
// specular_status if present; light_field's size): with
// options.cell_weights, the cells whose given weight is above 0 (the others
// keep the demosaiced normal whatever a Bayer fit says, so this is exact);
// else every cell of the gate blocks that pass (options.gate_ratio). A block
// is decided from its own pixels only, so bands of whole cell rows decide as
// the whole frame does. Throws std::invalid_argument on maps that do not fit.
BayerBlendCellsSummary SelectBayerBlendCells(const BayerNormalBlendOptions& options,
                                             const PhotometricSolution& demosaiced, const LightField& light_field,
                                             const ProgressCallback& progress = {});

// The pixels of `cells` (SelectBayerBlendCells' grid of cell_size px cells)
// as a region of width x height pixels (1 where a cell is 1), for the
// Bayer-domain solve's BayerSolverInput::region.
ImageU8 BayerBlendRegion(const ImageU8& cells, int cell_size, int width, int height);

// Blends `bayer`'s normals into `demosaiced` (the same frames, the same size,
// light_field's size). Pixels whose demosaiced fit has a specular lobe
// (specular_status kEstimated: the Bayer-domain solve has no lobe) take
// options.lobe_bayer's normal where it has one (the shared lobe re-solved
// from the pixel's own raw samples: its residual is mostly the shared
// shape's misfit, not noise, so no weight is estimated for it), else keep
// the demosaiced normal, as do pixels that either solve left unsolved (e.g. outside the region the Bayer-domain
// solve was given, BayerBlendRegion) keep the demosaiced normal; everything but
// the normal map is left as it is. `bayer` needs its residual and
// lights_used maps. Throws std::invalid_argument on maps that do not fit.
BayerNormalBlendSummary BlendBayerNormals(const BayerNormalBlendOptions& options, const PhotometricSolution& bayer,
                                          const LightField& light_field, PhotometricSolution* demosaiced,
                                          const ProgressCallback& progress = {});

}  // namespace scanbench
