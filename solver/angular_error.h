// Error figures of a solved normal / albedo map against ground truth.
#pragma once

#include <string>
#include <vector>

#include "core/image.h"

namespace scanbench {

struct ErrorStatistics {
  size_t num_pixels = 0;  // pixels compared
  double mean = 0;
  double median = 0;
  double percentile_95 = 0;
  double max = 0;
};

// The one definition of the error values every figure below is made of.
// Angle in degrees between two 3-vectors (not necessarily unit); 180 when
// either is zero or the dot product is not finite.
double AngleBetweenDegrees(const float* estimate, const float* truth);
// |estimate - truth| in double; 1e30 when not finite (counts as the worst).
double AbsoluteErrorValue(float estimate, float truth);

// Angle in degrees between unit normals (3 channels) at pixels where `mask`
// (1 channel, may be empty = all) is non-zero. Non-finite estimates count as 180.
ErrorStatistics AngularErrorDegrees(const ImageF& estimated_normals, const ImageF& true_normals,
                                    const ImageU8& mask);
// Per-pixel angular error map in degrees (1 channel); 0 outside the mask.
ImageF AngularErrorMapDegrees(const ImageF& estimated_normals, const ImageF& true_normals,
                              const ImageU8& mask);
// Absolute error of every channel, pooled, at pixels where `mask` is non-zero.
ErrorStatistics AbsoluteError(const ImageF& estimated, const ImageF& truth, const ImageU8& mask);

// The same band by band, for a truth read a band of rows at a time:
// `truth_rows` holds rows [y_begin, y_begin + truth_rows.height()) of the
// truth, `estimated` and `mask` (may be empty = all) are whole images. Rows run
// in parallel (num_threads, 0 = all); the values are appended to *errors in
// pixel order, so SummarizeErrors of the values of all bands in turn equals
// the whole-image statistics above exactly. AngularErrorsOfRows also writes
// those rows of *error_map_deg when given (whole size, 1 channel, 0 outside
// the mask).
void AngularErrorsOfRows(const ImageF& estimated_normals, const ImageF& truth_rows, int y_begin, const ImageU8& mask,
                         int num_threads, std::vector<double>* errors, ImageF* error_map_deg = nullptr);
void AbsoluteErrorsOfRows(const ImageF& estimated, const ImageF& truth_rows, int y_begin, const ImageU8& mask,
                          int num_threads, std::vector<double>* errors);

ErrorStatistics SummarizeErrors(std::vector<double> errors);

}  // namespace scanbench
