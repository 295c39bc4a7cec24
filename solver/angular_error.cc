#include "solver/angular_error.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "core/parallel_for.h"

namespace scanbench {
namespace {

// `truth_rows` are rows [y_begin, ...) of an image the size of `estimate`.
void CheckRowsFit(const ImageF& estimate, const ImageF& truth_rows, int y_begin, const ImageU8& mask, int channels) {
  if (estimate.width() != truth_rows.width() || estimate.channels() != truth_rows.channels() ||
      estimate.channels() != channels || y_begin < 0 || y_begin + truth_rows.height() > estimate.height()) {
    throw std::invalid_argument("error statistics: estimate " + std::to_string(estimate.width()) + "x" +
                                std::to_string(estimate.height()) + "x" + std::to_string(estimate.channels()) +
                                " and truth " + std::to_string(truth_rows.width()) + "x" +
                                std::to_string(truth_rows.height()) + "x" + std::to_string(truth_rows.channels()) +
                                " from row " + std::to_string(y_begin) + " must have the same shape");
  }
  if (!mask.empty() && !mask.SameSize(estimate)) {
    throw std::invalid_argument("error statistics: mask size differs from the images");
  }
}

// value(x, y, row_truth, out) writes a masked pixel's `per_pixel` values to
// `out`; they are appended in pixel order. The rows are computed in parallel,
// each into its own stretch of one buffer (no list per row growing by
// doubling), then appended row by row.
template <typename Value>
void AppendRowValues(const ImageF& truth_rows, int y_begin, const ImageU8& mask, int num_threads, int per_pixel,
                     std::vector<double>* errors, const Value& value) {
  const int rows = truth_rows.height(), width = truth_rows.width();
  const size_t row_stride = static_cast<size_t>(width) * per_pixel;
  std::vector<double> values(row_stride * rows);
  std::vector<size_t> counts(rows, 0);
  ParallelRows(rows, num_threads, {}, 0, 1, [&](int r) {
    const int y = y_begin + r;
    const float* truth = truth_rows.row(r);
    double* out = values.data() + row_stride * r;
    for (int x = 0; x < width; ++x) {
      if (!mask.empty() && mask(x, y) == 0) continue;
      value(x, y, truth + static_cast<size_t>(x) * truth_rows.channels(), out);
      out += per_pixel;
    }
    counts[r] = static_cast<size_t>(out - (values.data() + row_stride * r));
  });
  for (int r = 0; r < rows; ++r) {
    const double* row = values.data() + row_stride * r;
    errors->insert(errors->end(), row, row + counts[r]);
  }
}

// Whole images: the truth has the estimate's height too.
void CheckSameShape(const ImageF& estimate, const ImageF& truth, const ImageU8& mask, int channels) {
  if (truth.height() != estimate.height()) {
    throw std::invalid_argument("error statistics: estimate " + std::to_string(estimate.width()) + "x" +
                                std::to_string(estimate.height()) + " and truth " + std::to_string(truth.width()) +
                                "x" + std::to_string(truth.height()) + " must have the same shape");
  }
  CheckRowsFit(estimate, truth, 0, mask, channels);
}

}  // namespace

double AngleBetweenDegrees(const float* estimate, const float* truth) {
  double dot = 0, ne = 0, nt = 0;
  for (int c = 0; c < 3; ++c) {
    dot += double(estimate[c]) * truth[c];
    ne += double(estimate[c]) * estimate[c];
    nt += double(truth[c]) * truth[c];
  }
  if (!std::isfinite(dot) || !(ne > 0) || !(nt > 0)) return 180.0;
  const double cosine = std::clamp(dot / std::sqrt(ne * nt), -1.0, 1.0);
  return std::acos(cosine) * 180.0 / M_PI;
}

double AbsoluteErrorValue(float estimate, float truth) {
  const double difference = double(estimate) - truth;
  return std::isfinite(difference) ? std::abs(difference) : 1e30;
}

ErrorStatistics SummarizeErrors(std::vector<double> errors) {
  ErrorStatistics stats;
  stats.num_pixels = errors.size();
  if (errors.empty()) return stats;
  stats.mean = std::accumulate(errors.begin(), errors.end(), 0.0) / errors.size();
  // Each selection searches only the values at or above the one before it
  // (nth_element leaves them after it): the same values, a fraction of the work.
  auto first = errors.begin();
  auto at_fraction = [&](double fraction) {
    const size_t index = std::min(errors.size() - 1, static_cast<size_t>(fraction * (errors.size() - 1) + 0.5));
    std::nth_element(first, errors.begin() + index, errors.end());
    first = errors.begin() + index;
    return errors[index];
  };
  stats.median = at_fraction(0.5);
  stats.percentile_95 = at_fraction(0.95);
  stats.max = *std::max_element(first, errors.end());
  return stats;
}

void AngularErrorsOfRows(const ImageF& estimated, const ImageF& truth_rows, int y_begin, const ImageU8& mask,
                         int num_threads, std::vector<double>* errors, ImageF* error_map_deg) {
  CheckRowsFit(estimated, truth_rows, y_begin, mask, 3);
  if (error_map_deg != nullptr && (error_map_deg->width() != estimated.width() ||
                                   error_map_deg->height() != estimated.height() || error_map_deg->channels() != 1)) {
    throw std::invalid_argument("AngularErrorsOfRows: the error map must be 1 channel of the estimate's size");
  }
  if (error_map_deg != nullptr) {
    std::fill(error_map_deg->row(y_begin), error_map_deg->row(y_begin) + size_t(truth_rows.height()) * estimated.width(),
              0.0f);
  }
  AppendRowValues(truth_rows, y_begin, mask, num_threads, 1, errors, [&](int x, int y, const float* truth, double* out) {
    out[0] = AngleBetweenDegrees(&estimated(x, y), truth);
    if (error_map_deg != nullptr) (*error_map_deg)(x, y) = static_cast<float>(out[0]);
  });
}

void AbsoluteErrorsOfRows(const ImageF& estimated, const ImageF& truth_rows, int y_begin, const ImageU8& mask,
                          int num_threads, std::vector<double>* errors) {
  CheckRowsFit(estimated, truth_rows, y_begin, mask, estimated.channels());
  const int channels = estimated.channels();
  AppendRowValues(truth_rows, y_begin, mask, num_threads, channels, errors,
                  [&](int x, int y, const float* truth, double* out) {
                    for (int c = 0; c < channels; ++c) out[c] = AbsoluteErrorValue(estimated(x, y, c), truth[c]);
                  });
}

ErrorStatistics AngularErrorDegrees(const ImageF& estimated, const ImageF& truth, const ImageU8& mask) {
  CheckSameShape(estimated, truth, mask, 3);
  std::vector<double> errors;
  errors.reserve(estimated.num_pixels());
  AngularErrorsOfRows(estimated, truth, 0, mask, 0, &errors);
  return SummarizeErrors(std::move(errors));
}

ImageF AngularErrorMapDegrees(const ImageF& estimated, const ImageF& truth, const ImageU8& mask) {
  CheckSameShape(estimated, truth, mask, 3);
  ImageF map(estimated.width(), estimated.height(), 1, 0.0f);
  std::vector<double> ignored;
  AngularErrorsOfRows(estimated, truth, 0, mask, 0, &ignored, &map);
  return map;
}

ErrorStatistics AbsoluteError(const ImageF& estimated, const ImageF& truth, const ImageU8& mask) {
  CheckSameShape(estimated, truth, mask, estimated.channels());
  std::vector<double> errors;
  errors.reserve(estimated.size());
  AbsoluteErrorsOfRows(estimated, truth, 0, mask, 0, &errors);
  return SummarizeErrors(std::move(errors));
}

}  // namespace scanbench
