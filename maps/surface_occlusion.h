// Material surface occlusion from a height map (seed 004, section 4.3-4.4):
// a horizon-based ambient occlusion (cosine-weighted visibility of the
// hemisphere, as GTAO computes it on orthographic depth) and a cavity map
// (how far a point sits below its neighbourhood).
//
// The height map is an orthographic depth map: straight down onto the table,
// square pixels of mm_per_pixel, heights in mm. Samples beyond the image take
// the value of the nearest edge pixel (clamp-to-edge), so the image border
// neither occludes nor opens the sky artificially.
#pragma once

#include <cstddef>
#include <string>

#include "core/progress.h"
#include "core/summary.h"
#include "core/image.h"

namespace scanbench {

struct AmbientOcclusionOptions {
  double mm_per_pixel = 0.1;       // pixel pitch of the height map, mm, > 0
  double radius_mm = 3.0;          // how far occluders are searched (horizontal distance), mm, > 0, at most 1e5 px
  int num_directions = 16;         // azimuths marched per pixel over the full circle, [4, 1024]
  int max_steps = 32;              // samples per azimuth (capped by the radius in pixels), [1, 4096]
  int num_threads = 0;             // worker threads over rows; 0 = hardware concurrency, [0, 256]
  bool around_pixel_normal = false;  // false: hemisphere around the table normal; true: around the pixel's own
                                     // normal from the height gradient (GTAO's form)
  void Check() const;
};

struct CavityOptions {
  double mm_per_pixel = 0.1;       // pixel pitch of the height map, mm, > 0
  double radius_mm = 1.0;          // Gaussian sigma of the neighbourhood mean, mm, > 0, at most 1000 px
  double depth_scale_mm = 0.2;     // depth below the neighbourhood that maps to cavity 0, mm, > 0
  // The mean's Gaussian runs on block means f x f px, f the largest integer
  // with sigma / f >= this, and is scaled back up bicubically (docs/derived-maps.md);
  // 0 = always at full resolution. px, 0 or >= 2.
  double min_coarse_sigma_px = 8.0;
  void Check() const;
};

struct OcclusionSummary : AlgorithmSummary {
  std::string map_name;                // "ambient occlusion" or "cavity"
  double mean = 0, min = 0, max = 0;   // of the output map, [0, 1]
  double seconds = 0;
  int steps_per_direction = 0;         // ambient occlusion only: samples marched per azimuth
  double radius_px = 0;                // search radius (AO) or Gaussian sigma (cavity), pixels
  // "Ambient occlusion: success, mean 0.975, min 0.738, max 1.000, radius 25.9 px, 0.43 s".
  std::string BriefReport() const;
};

// Visibility in [0, 1] (1 = open sky), the cosine-weighted integral of seed
// 004 eq. 43 over the hemisphere around the table normal (0, 0, 1): a point on
// an open plane tilted by a reads (1 + cos a) / 2. Per azimuth the height
// field (bilinear between pixels) is sampled out to radius_mm and the highest
// horizon elevation h kept; that direction's half-slice of the hemisphere
// contributes cos^2(h) exactly, and the map is the mean over num_directions
// azimuths. Occluders beyond radius_mm are ignored. With around_pixel_normal
// the hemisphere is the pixel's own (normal from central differences of the
// height, GTAO's slice integral): an open tilted plane reads 1.
// height_mm: 1 channel, finite. Writes 1 channel into *visibility, no NaN.
// Throws std::invalid_argument on bad options, shapes, non-finite heights or
// a null output, before any work. Writes an empty image with termination
// kCancelled if `progress` returns false.
OcclusionSummary AmbientOcclusionFromHeight(const AmbientOcclusionOptions& options, const ImageF& height_mm,
                                            ImageF* visibility, const ProgressCallback& progress = {});

// Cavity in [0, 1]: 1 where the point is at or above its neighbourhood
// mean, falling linearly to 0 at depth_scale_mm below it. The neighbourhood
// mean is a Gaussian blur (clamp-to-edge border). Throws and cancels like
// AmbientOcclusionFromHeight (`progress` is asked before and after the blur).
OcclusionSummary CavityFromHeight(const CavityOptions& options, const ImageF& height_mm, ImageF* cavity,
                                  const ProgressCallback& progress = {});

// Seed 004 eq. 49: occluded directions see the same surface (interreflection),
// A' = A / (1 - rho + rho * A), per pixel, rho = albedo luminance in [0, 1]
// (Rec. 709 weights on linear RGB for a 3 channel albedo, the value itself for
// 1 channel; clamped to [0, 1], as is A). rho = 0 leaves A unchanged, rho = 1
// gives 1. visibility: 1 channel; albedo: 1 or 3 channels, same size; both
// finite. Throws std::invalid_argument naming the shapes otherwise.
ImageF AdjustOcclusionForAlbedo(const ImageF& visibility, const ImageF& albedo);

}  // namespace scanbench
