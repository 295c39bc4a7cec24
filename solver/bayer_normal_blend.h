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
  // Optional, not owned: each cell's weight given instead of estimated
  // (1 channel, ceil(width / cell_size) x ceil(height / cell_size), values in
  // [0, 1]; what an earlier blend's summary returned as cell_weights). The
  // depth re-solves blend with the first re-solve's weights: re-estimated on
  // every pass they move the normals, the surface and again the weights, and
  // the loop does not settle (docs/solver.md). Null = estimate.
  const ImageF* cell_weights = nullptr;
  // Worker threads; 0 = all hardware threads, in [0, 256].
  int num_threads = 0;
  void Check() const;
};

struct BayerNormalBlendSummary : AlgorithmSummary {
  size_t pixels_blended = 0;  // took a non-zero share of the Bayer normal
  size_t pixels_kept = 0;     // solved, but left as the demosaiced solve's (a lobe, or no Bayer fit, or w = 0)
  size_t pixels_weighed = 0;  // solved by both, without a lobe: the pixels a weight was estimated for
  double mean_weight = 0;     // mean Bayer share over pixels_weighed
  // The weight of every cell (the estimated ones, or options.cell_weights'),
  // 0 where no pixel was weighed; the shape options.cell_weights takes.
  ImageF cell_weights;
  std::string BriefReport() const;
};

// Blends `bayer`'s normals into `demosaiced` (the same frames, the same size,
// light_field's size). Pixels whose demosaiced fit has a specular lobe
// (specular_status kEstimated: the Bayer-domain solve has no shared lobe) or
// that either solve left unsolved keep the demosaiced normal; everything but
// the normal map is left as it is. `bayer` needs its residual and
// lights_used maps. Throws std::invalid_argument on maps that do not fit.
BayerNormalBlendSummary BlendBayerNormals(const BayerNormalBlendOptions& options, const PhotometricSolution& bayer,
                                          const LightField& light_field, PhotometricSolution* demosaiced,
                                          const ProgressCallback& progress = {});

}  // namespace scanbench
