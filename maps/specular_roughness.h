// Mip-0 roughness for the export (issue #13): the solver's specular map where
// it estimated a lobe, another estimate (today the normal-variance chain's
// base) elsewhere, feathered across the seam so that no hard edge appears
// where the estimate stops.
//
// The feather lies outside the estimated pixels only, so an estimated pixel
// keeps its own alpha exactly. A pixel at Euclidean distance d (pixels) from
// the nearest estimated pixel mixes, in perceptual roughness r = sqrt(alpha)
// (where equal steps look equal), the mean r of the estimated pixels in its
// (2 w + 1)^2 window with its fallback r, weight smoothstep(1 - d / (w + 1))
// on the former (w = blend_width_px): 1 at the seam, 0 from w + 1 on, with
// continuous slope. The window always holds an estimated pixel when d <= w.
#pragma once

#include <cstddef>
#include <string>

#include "core/image.h"
#include "core/progress.h"
#include "core/summary.h"

namespace scanbench {

struct SpecularRoughnessOptions {
  int blend_width_px = 8;  // feather outside the estimated pixels, pixels, [0, 256]; 0 = a hard edge
  void Check() const;
};

struct SpecularRoughnessSummary : AlgorithmSummary {
  // Over the valid pixels (all pixels without a mask):
  size_t from_specular = 0;  // estimated: the specular map's alpha as is
  size_t blended = 0;        // in the feather: a mix of both
  size_t from_fallback = 0;  // the fallback's alpha as is
  double seconds = 0;
  // "Specular roughness: success, 1200 px from the specular map, 96 blended, 3800 from the fallback, 0.01 s".
  std::string BriefReport() const;
};

// specular_alpha: 1 channel, GGX alpha of the specular map; a pixel is
// estimated where it is finite and > 0 (and inside `valid`). fallback_alpha:
// 1 channel, GGX alpha elsewhere. valid: optional 1-channel mask, 0 = not
// solved: such pixels keep the fallback and are neither sources nor blended.
// Output: 1 channel GGX alpha in [kMinGgxAlpha, 1] (maps/gloss_mips.h) into
// *roughness_alpha (non-finite fallback values become 1, counted in the
// message). Throws std::invalid_argument, naming the image and its shape, for
// maps of other sizes or channel counts, an empty map or a null output, and
// for bad options, before any work. Termination kCancelled (output untouched)
// when `progress`, asked after the distance transform, returns false.
SpecularRoughnessSummary BlendSpecularRoughness(const SpecularRoughnessOptions& options, const ImageF& specular_alpha,
                                                const ImageF& fallback_alpha, const ImageU8* valid,
                                                ImageF* roughness_alpha, const ProgressCallback& progress = {});

}  // namespace scanbench
