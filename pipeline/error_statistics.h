// Summaries of values that arrive band by band (the solve's ground-truth
// evaluation, issue #14): FloatErrorStatistics holds them as floats. And the
// export's figures against the ground truth: the height's RMS error after a
// best-fit plane, the normals' mean angular error.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "core/image.h"
#include "solver/angular_error.h"

namespace scanbench {

// SummarizeErrors of the values given to Add in turn, held in memory as
// floats (4 bytes a value, no spill file: writing one costs more CPU time on
// this kind of machine than the values' selection, docs/solver.md): the count,
// mean and maximum are SummarizeErrors' bit for bit (the same double sum in
// the same order, the same largest value); the median and 95th percentile are
// the order statistics of the values rounded to float, which are
// SummarizeErrors' rounded to float (rounding keeps the order): within 6e-8
// relative. 46 MB for the 11.4 M angles of a 16 MP solve.
class FloatErrorStatistics {
 public:
  // Room for this many values, so that growing never holds two copies.
  void Reserve(size_t count) { values_.reserve(count); }
  void Add(std::span<const double> values);
  size_t count() const { return values_.size(); }
  // Once (the values are reordered, then freed).
  ErrorStatistics Finish();

 private:
  double sum_ = 0;
  double max_ = 0;
  std::vector<float> values_;
};

// RMS of (estimate - reference) on the mask after removing the best-fit plane
// of that difference: height from normals is defined up to a constant, and a
// tilt is the slope error of a few pixels' worth of calibration. The sums run
// in pixel order (each normal-equation entry, the right-hand side and the
// squares accumulated pixel after pixel). Nothing when fewer than 3 pixels
// are on the mask; throws std::invalid_argument when the three are not 1
// channel of one size.
std::optional<double> RmsAfterBestFitPlane(const ImageF& estimate, const ImageF& reference, const ImageU8& mask);

// The mean of AngleBetweenDegrees over the mask (AngularErrorDegrees' mean,
// bit for bit: the same values summed in pixel order from 0), without its
// list of every value nor its order statistics: AngularErrorsOfRows
// (solver/angular_error.h) a band of rows at a time, then their sum in order.
// Nothing when the mask is empty; throws std::invalid_argument when the
// normals are not 3 channels of the mask's size.
std::optional<double> MeanAngularErrorDegrees(const ImageF& estimate, const ImageF& truth, const ImageU8& mask);

}  // namespace scanbench
