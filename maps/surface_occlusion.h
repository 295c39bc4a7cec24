// Material surface occlusion from a height map (seed 004, section 4.3-4.4):
// a horizon-based ambient occlusion (cosine-weighted visibility of the
// hemisphere, as GTAO computes it on orthographic depth) and a cavity map
// (how far a point sits below its neighbourhood).
#pragma once

#include <cstddef>
#include <string>

#include "maps/map_summary.h"
#include "solver/image.h"

namespace scanbench {

struct AmbientOcclusionOptions {
  double mm_per_pixel = 0.1;       // pixel pitch of the height map, mm, > 0
  double radius_mm = 3.0;          // how far occluders are searched, mm, > 0
  int num_directions = 16;         // azimuths marched per pixel, >= 4
  int max_steps = 32;              // samples per azimuth (capped by the radius in pixels), >= 1
  void Check() const;
};

struct CavityOptions {
  double mm_per_pixel = 0.1;       // pixel pitch of the height map, mm, > 0
  double radius_mm = 1.0;          // Gaussian sigma of the neighbourhood mean, mm, > 0
  double depth_scale_mm = 0.2;     // depth below the neighbourhood that maps to cavity 0, mm, > 0
  void Check() const;
};

struct OcclusionSummary {
  MapTermination termination = MapTermination::kFailure;
  std::string message;
  double mean = 0, min = 0, max = 0;   // of the output map
  double seconds = 0;
};

// Visibility in [0, 1] (1 = open sky), cosine-weighted over the hemisphere
// around the table normal. height_mm: 1 channel. No NaN.
ImageF AmbientOcclusionFromHeight(const ImageF& height_mm, const AmbientOcclusionOptions& options,
                                  OcclusionSummary* summary, const MapProgressCallback& progress = {});

// Cavity in [0, 1]: 1 where the point is at or above its neighbourhood
// mean, falling linearly to 0 at depth_scale_mm below it.
ImageF CavityFromHeight(const ImageF& height_mm, const CavityOptions& options, OcclusionSummary* summary);

// Seed 004 eq. 49: occluded directions see the same surface (interreflection),
// A' = A / (1 - rho + rho * A), per pixel, rho = albedo luminance in [0, 1].
ImageF AdjustOcclusionForAlbedo(const ImageF& visibility, const ImageF& albedo);

}  // namespace scanbench
