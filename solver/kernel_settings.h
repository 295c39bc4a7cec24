// Internal to the solver library: what every pixel kernel (pixel_kernels.cc,
// learned_kernel.cc) takes from the solve's options and job.
#pragma once

#include <Eigen/Core>

#include "solver/photometric_methods.h"
#include "solver/pixel_solvers.h"
#include "solver/tiled_solve.h"

namespace scanbench::tiled {

// What every kernel takes from the options.
struct KernelSettings {
  explicit KernelSettings(const SolveJob& job)
      : options(*job.options),
        limits{options.min_lights, options.max_condition_number, options.min_albedo},
        with_albedo(job.with_albedo && !job.bayer),
        with_confidence(job.with_confidence),
        num_lights(job.num_lights),
        field(job.field),
        kernels(&KernelsOf(job)),
        pixel_lobe(MethodRunsPass(options, SolverPass::kPixelLobe)),
        pixel_sheen(MethodRunsPass(options, SolverPass::kPixelSheen)) {
    robust.loss = options.robust_loss;
    robust.width = options.robust_loss_width;
    robust.min_scale = options.robust_min_scale;
    robust.max_iterations = options.robust_max_iterations;
    robust.dark_fraction = options.robust_dark_fraction;
  }

  const PhotometricSolverOptions& options;
  PixelFitLimits limits;
  RobustFitOptions robust;
  bool with_albedo;  // RGB albedo solves
  bool with_confidence;
  int num_lights;
  const LightField* field;  // for the view direction of the lobe fits
  const SpanKernels* kernels;
  bool pixel_lobe;   // adaptive: the robust re-solve is the lobe fit (else IRLS)
  bool pixel_sheen;  // adaptive: the sheen fit where the residual has its pattern

  // Unit direction from pixel (x, y) towards the camera.
  Eigen::Vector3d View(int x, int y) const {
    float view[3];
    field->ViewDirection(x, y, view);
    return Eigen::Vector3d(view[0], view[1], view[2]);
  }
};

}  // namespace scanbench::tiled
