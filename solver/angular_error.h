// Error figures of a solved normal / albedo map against ground truth.
#pragma once

#include <string>

#include "core/image.h"

namespace scanbench {

struct ErrorStatistics {
  size_t num_pixels = 0;  // pixels compared
  double mean = 0;
  double median = 0;
  double percentile_95 = 0;
  double max = 0;
};

// Angle in degrees between unit normals (3 channels) at pixels where `mask`
// (1 channel, may be empty = all) is non-zero. Non-finite estimates count as 180.
ErrorStatistics AngularErrorDegrees(const ImageF& estimated_normals, const ImageF& true_normals,
                                    const ImageU8& mask);
// Per-pixel angular error map in degrees (1 channel); 0 outside the mask.
ImageF AngularErrorMapDegrees(const ImageF& estimated_normals, const ImageF& true_normals,
                              const ImageU8& mask);
// Absolute error of every channel, pooled, at pixels where `mask` is non-zero.
ErrorStatistics AbsoluteError(const ImageF& estimated, const ImageF& truth, const ImageU8& mask);

ErrorStatistics SummarizeErrors(std::vector<double> errors);

}  // namespace scanbench
