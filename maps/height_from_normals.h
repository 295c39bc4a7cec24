// Height map from a normal map (seed 004, section 4.1-4.2): slopes
// dz/dx = -n.x / n.z, dz/dy = -n.y / n.z integrated by least squares. The
// reference method is the multi-resolution relaxation of seed 004 (solve a
// half-resolution slope field first, upsample, then Jacobi/Gauss-Seidel
// sweeps); a DCT Poisson solver (Neumann boundary) is the fast alternative.
#pragma once

#include <cstddef>
#include <string>

#include "maps/map_summary.h"
#include "solver/image.h"

namespace scanbench {

struct HeightFromNormalsOptions {
  enum class Method { kMultiresolutionRelaxation, kDctPoisson };
  Method method = Method::kMultiresolutionRelaxation;
  double mm_per_pixel = 0.1;         // pixel pitch on the sample, mm, > 0; heights come out in mm
  int max_sweeps_per_level = 400;    // relaxation sweeps at each resolution level, >= 1
  double tolerance = 1e-6;           // stop a level once the RMS update is below tolerance * mm_per_pixel, >= 0
  int coarsest_level_size = 8;       // stop halving below this many pixels on the shorter side, >= 2
  double max_slope = 10.0;           // |dz/dx|, |dz/dy| clamp where n.z is near 0, > 0
  void Check() const;
};
const char* HeightMethodName(HeightFromNormalsOptions::Method method);
// "relaxation" or "dct"; throws std::invalid_argument naming the value otherwise.
HeightFromNormalsOptions::Method HeightMethodFromName(const std::string& name);

struct HeightFromNormalsSummary {
  MapTermination termination = MapTermination::kFailure;
  std::string message;
  std::string method;
  int levels = 0;                    // resolution levels solved (1 for DCT)
  int total_sweeps = 0;
  bool converged = false;            // every level reached the tolerance
  double rms_slope_residual = 0;     // RMS of (gradient of height - slope), valid pixels, unitless
  double seconds = 0;
};

// normal_in_tangent: 3 channels (x right, y up = towards image row 0, z out).
// valid: optional; invalid pixels carry no slope constraint and are filled
// smoothly from their neighbours. Returns 1 channel, mm, zero mean over the
// valid pixels, no NaN. Throws std::invalid_argument on bad shapes.
ImageF HeightFromNormals(const ImageF& normal_in_tangent, const ImageU8* valid,
                         const HeightFromNormalsOptions& options, HeightFromNormalsSummary* summary,
                         const MapProgressCallback& progress = {});

}  // namespace scanbench
