// Low-frequency flattening of a normal map (seed 000, "3D Textile Scanner"):
// photometric stereo gets the fine detail right but carries slow slope errors
// from imperfect light calibration. Working in slope space (dz/dx, dz/dy), the
// valid-weighted Gaussian low-pass of the slopes is subtracted, so the mean
// plane becomes flat and detail shorter than the cut-off is kept unchanged.
// The low-pass is a normalised convolution, blur(w s) / blur(w), so image
// edges and holes are averaged over the valid pixels only. A sigma of 16 px
// or more is blurred on an area-averaged grid sigma / 8 times coarser and
// upsampled bilinearly (against the full-size Gaussian on the tests: mean
// 0.013 deg, at most 0.24 deg at a hole's rim), so the cost does not grow
// with sigma.
#pragma once

#include <cstddef>
#include <string>

#include "core/progress.h"
#include "core/summary.h"
#include "core/image.h"

namespace scanbench {

struct NormalFlatteningOptions {
  double low_pass_sigma_px = 48.0;  // Gaussian sigma of the slope field taken out, px, > 0
  double max_slope = 10.0;          // |dz/dx|, |dz/dy| clamp where n.z is near 0 (about 84 deg), > 0
  // Threads of the per-pixel passes (the shared pool), 0 = hardware concurrency,
  // [0, 256]; the result is the same for any count.
  int num_threads = 0;
  void Check() const;
};

struct NormalFlatteningSummary : AlgorithmSummary {
  size_t valid_pixels = 0;              // pixels that fed the low-pass
  double mean_removed_tilt_deg = 0;     // mean tilt of the removed low-pass normal, valid pixels, deg
  double max_removed_tilt_deg = 0;      // deg
  double seconds = 0;
  // "Normal flattening: success, removed tilt mean 5.972 deg, max 16.250 deg over 1005312 px, 0.06 s".
  std::string BriefReport() const;
};

// normal_in_tangent: 3 channels, unit (x right, y up = towards image row 0,
// z out of the sample). valid: optional, 1 channel, non-zero = use the pixel;
// invalid pixels (and pixels whose normal is non-finite or zero) come out as
// (0, 0, 1). Writes unit normals of the same size into *flat_normal_in_tangent.
// Throws std::invalid_argument on bad options (naming the field), bad shapes
// (naming them) and a null output, before any work. Cancelling through
// `progress` writes the input normals (slopes clamped, re-normalised) and
// returns termination kCancelled.
NormalFlatteningSummary FlattenNormals(const NormalFlatteningOptions& options, const ImageF& normal_in_tangent,
                                       const ImageU8* valid, ImageF* flat_normal_in_tangent,
                                       const ProgressCallback& progress = {});

}  // namespace scanbench
