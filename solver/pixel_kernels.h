// Internal to the solver library: one kernel per method, chosen once per
// solve. A kernel turns the accumulated samples of one span into fits and
// writes them; the tile loop, the light classification and the bookkeeping
// around it are shared (tiled_solve.h, tile_lights.h).
//
//   adaptive                 NormalEquationsKernel's solve, then a robust
//                            re-solve where the residual or a clipped sample
//                            calls for it (AdaptiveKernel)
//   normal_equations,        closed-form 3x3 solve of the accumulated normal
//   uniform_pinv             equations (NormalEquationsKernel); they differ
//                            only in how tiles share lights
//   jacobi_svd, qr,          every pixel's samples gathered and fitted on
//   robust_irls,             their own (PerPixelKernel with the method's
//   sparse_bayesian,         fit from pixel_solvers.h)
//   diffuse_lobe
#pragma once

#include <memory>

#include "solver/tiled_solve.h"

namespace scanbench::tiled {

class PixelKernel {
 public:
  virtual ~PixelKernel() = default;
  // Solves the wanted pixels of `span` and writes each through `out`.
  virtual void SolveSpan(const Span& span, PixelWriter* out) = 0;
};

// How far the method lets tiles share lights.
LightSharing LightSharingOf(PhotometricSolverOptions::Method method);

// The kernel of the job's method, with its own scratch for spans of up to
// `capacity` pixels: one per thread.
std::unique_ptr<PixelKernel> MakePixelKernel(const SolveJob& job, int capacity);

}  // namespace scanbench::tiled
