// Internal to the solver library: the pixel kernels, one per method, chosen
// once per solve through the method table's factories
// (solver/photometric_methods.cc). A kernel turns the accumulated samples of
// one span into fits and writes them; the tile loop, the light classification
// and the bookkeeping around it are shared (tiled_solve.h, tile_lights.h).
//
//   AdaptiveKernel         NormalEquationsKernel's solve, then a robust
//                          re-solve where the residual or a clipped sample
//                          calls for it
//   NormalEquationsKernel  closed-form 3x3 solve of the accumulated normal
//                          equations
//   PerPixelKernel         every pixel's samples gathered and handed to one
//                          fit from pixel_solvers.h
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

// The method table's kernel factories (PixelKernelFactory): each builds one
// kernel with its own scratch for spans of up to `capacity` pixels, one per
// thread.
std::unique_ptr<PixelKernel> MakeAdaptiveKernel(const SolveJob& job, int capacity);
std::unique_ptr<PixelKernel> MakeNormalEquationsKernel(const SolveJob& job, int capacity);
std::unique_ptr<PixelKernel> MakeJacobiSvdKernel(const SolveJob& job, int capacity);
std::unique_ptr<PixelKernel> MakeQrKernel(const SolveJob& job, int capacity);
std::unique_ptr<PixelKernel> MakeRobustIrlsKernel(const SolveJob& job, int capacity);
std::unique_ptr<PixelKernel> MakeSparseBayesianKernel(const SolveJob& job, int capacity);
std::unique_ptr<PixelKernel> MakeDiffuseLobeKernel(const SolveJob& job, int capacity);
std::unique_ptr<PixelKernel> MakeLearnedKernel(const SolveJob& job, int capacity);  // learned_kernel.cc

}  // namespace scanbench::tiled
