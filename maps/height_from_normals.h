// Height map from a normal map (seed 004, section 4.1-4.2): slopes
// dz/dx = -n.x / n.z, dz/dy = -n.y / n.z integrated by least squares over the
// 4-neighbour edges (trapezoidal edge targets, so quadratics are exact; the
// free boundary is the Neumann condition).
//   relaxation: the multi-resolution relaxation of seed 004. The edge targets
//     are restricted to half resolution down to coarsest_level_size (a coarse
//     edge is the difference of two block means), the coarsest level relaxes
//     from zero, each finer level starts from the bilinear upsampling of the
//     one below; red-black Gauss-Seidel sweeps at every level. Plain sweeps
//     (over_relaxation 1) leave wavelengths much longer than the level's
//     pixel unconverged (0.2% height error on the tests); the default
//     over-relaxation of 1.9 reaches the DCT's least-squares answer within
//     ~0.01% of the relief in the same 400 sweeps.
//   dct: the same least-squares problem solved exactly by a DCT Poisson
//     solver (cv::dct; odd sizes through cv::dft of the mirrored image). With
//     a mask, the holes' slopes are first filled by pull-push, then
//     dct_hole_iterations re-solves give every edge touching a hole the
//     difference of the current solution, so the holes stop constraining the
//     valid pixels. Each round roughly halves the holes' pull: a 40 px hole
//     needs ~10 rounds, scattered pixel-sized holes hardly any (measured:
//     0.2 mm -> 0.0013 mm in 10 rounds for the first, 0.00129 -> 0.00121 mm
//     for the second); each round costs about one more DCT solve.
#pragma once

#include <cstddef>
#include <string>

#include "core/progress.h"
#include "core/summary.h"
#include "core/image.h"

namespace scanbench {

struct HeightFromNormalsOptions {
  enum class Method { kMultiresolutionRelaxation, kDctPoisson };
  Method method = Method::kMultiresolutionRelaxation;
  double mm_per_pixel = 0.1;         // pixel pitch on the sample, mm, > 0; heights come out in mm
  int max_sweeps_per_level = 400;    // relaxation: Gauss-Seidel sweeps at each resolution level, >= 1
  double over_relaxation = 1.9;      // relaxation: SOR factor, 1 = plain Gauss-Seidel, (0, 2)
  double tolerance = 1e-5;           // stop a level (dct: hole re-solves) at RMS update < tolerance * pixel pitch, >= 0
  int coarsest_level_size = 8;       // relaxation: stop halving before the longer side drops below this, px, >= 2
  double max_slope = 10.0;           // |dz/dx|, |dz/dy| clamp where n.z is near 0, > 0
  int dct_hole_iterations = 10;      // dct with holes: at most this many re-solves that free them, >= 0
  void Check() const;
};
const char* HeightMethodName(HeightFromNormalsOptions::Method method);
// "relaxation" or "dct"; throws std::invalid_argument naming the value otherwise.
HeightFromNormalsOptions::Method HeightMethodFromName(const std::string& name);

struct HeightFromNormalsSummary : AlgorithmSummary {
  std::string method;                // HeightMethodName
  int levels = 0;                    // resolution levels solved (1 for DCT)
  int total_sweeps = 0;              // relaxation: Gauss-Seidel sweeps over all levels
  bool converged = false;            // every level reached the tolerance (dct: no holes, or their re-solves did)
  double rms_slope_residual = 0;     // RMS of (gradient of height - slope), valid pixels, unitless
  double seconds = 0;
  // "Height from normals (dct): success, 1 level(s), 0 sweep(s), converged, RMS slope residual 0.005, 0.09 s".
  std::string BriefReport() const;
};

// normal_in_tangent: 3 channels (x right, y up = towards image row 0, z out).
// valid: optional, 1 channel, non-zero = use the pixel; invalid pixels (and
// pixels whose normal is non-finite or zero) carry no slope constraint and
// are filled smoothly (relaxation: a harmonic membrane, edges into holes
// weighted 1e-3; dct: the pull-push slope fill, re-integrated). Writes 1
// channel into *height_mm: mm, zero mean over the valid pixels, no NaN.
// Throws std::invalid_argument on bad options (naming the field), bad shapes
// and a null output. Cancelling through `progress` writes the current
// estimate brought to full size (termination kCancelled); no valid pixel at
// all writes zeros with termination kFailure.
HeightFromNormalsSummary HeightFromNormals(const HeightFromNormalsOptions& options, const ImageF& normal_in_tangent,
                                           const ImageU8* valid, ImageF* height_mm,
                                           const ProgressCallback& progress = {});

}  // namespace scanbench
