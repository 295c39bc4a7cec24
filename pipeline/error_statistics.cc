#include "pipeline/error_statistics.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

namespace scanbench {

void FloatErrorStatistics::Add(std::span<const double> values) {
  if (values.empty()) return;
  if (values_.empty()) max_ = values[0];
  for (const double value : values) {
    sum_ += value;
    if (max_ < value) max_ = value;
  }
  // The rounding in a loop of its own (vectorised), into room made at once.
  const size_t first = values_.size();
  values_.resize(first + values.size());
  float* out = values_.data() + first;
  for (size_t i = 0; i < values.size(); ++i) out[i] = static_cast<float>(values[i]);
}

namespace {

// Non-NaN floats to unsigned integers in the same order.
uint32_t FloatOrderKey(float value) {
  const uint32_t bits = std::bit_cast<uint32_t>(value);
  return (bits >> 31) ? ~bits : bits | (uint32_t{1} << 31);
}

}  // namespace

ErrorStatistics FloatErrorStatistics::Finish() {
  ErrorStatistics stats;
  const size_t count = values_.size();
  stats.num_pixels = count;
  if (count == 0) return stats;
  stats.mean = sum_ / count;
  stats.max = max_;
  // SummarizeErrors' ranks, selected by a histogram of the order keys' top 16
  // bits (one pass), then std::nth_element among the values of the rank's
  // bucket only (a second pass gathers them): a few times faster than
  // nth_element over every value.
  const auto rank_of = [&](double fraction) {
    return std::min(count - 1, static_cast<size_t>(fraction * (count - 1) + 0.5));
  };
  constexpr int kShift = 16;
  std::vector<uint32_t> histogram(size_t{1} << (32 - kShift), 0);
  for (const float value : values_) ++histogram[FloatOrderKey(value) >> kShift];
  const auto value_of_rank = [&](size_t rank) {
    size_t bucket = 0, before = 0;
    while (rank >= before + histogram[bucket]) before += histogram[bucket++];
    std::vector<float> selected;
    selected.reserve(histogram[bucket]);
    for (const float value : values_) {
      if ((FloatOrderKey(value) >> kShift) == bucket) selected.push_back(value);
    }
    std::nth_element(selected.begin(), selected.begin() + (rank - before), selected.end());
    return static_cast<double>(selected[rank - before]);
  };
  stats.median = value_of_rank(rank_of(0.5));
  stats.percentile_95 = value_of_rank(rank_of(0.95));
  values_ = {};
  return stats;
}

std::optional<double> RmsAfterBestFitPlane(const ImageF& estimate, const ImageF& reference, const ImageU8& mask) {
  if (estimate.channels() != 1 || reference.channels() != 1 || mask.channels() != 1 ||
      !estimate.SameSize(reference) || !mask.SameSize(estimate)) {
    throw std::invalid_argument("RmsAfterBestFitPlane: estimate " + ShapeText(estimate) + ", reference " +
                                ShapeText(reference) + " and mask " + ShapeText(mask) +
                                " must be 1 channel of one size");
  }
  const int width = estimate.width(), height = estimate.height();
  const double cx = width / 2.0, cy = height / 2.0;
  // Per pixel of the plane's design row (1, x - cx, y - cy): m(i, j) += r_i r_j, rhs(i) += r_i d.
  double m01 = 0, m02 = 0, m11 = 0, m12 = 0, m22 = 0, rhs0 = 0, rhs1 = 0, rhs2 = 0;
  double m00 = 0;
  size_t count = 0;
  for (int y = 0; y < height; ++y) {
    const uint8_t* on = mask.row(y);
    const float* e = estimate.row(y);
    const float* r = reference.row(y);
    const double r2 = y - cy;
    for (int x = 0; x < width; ++x) {
      if (!on[x]) continue;
      const double r1 = x - cx;
      const double difference = double(e[x]) - r[x];
      m00 += 1.0;
      m01 += r1;  // 1.0 * r1, exactly
      m02 += r2;
      m11 += r1 * r1;
      m12 += r1 * r2;
      m22 += r2 * r2;
      rhs0 += difference;
      rhs1 += r1 * difference;
      rhs2 += r2 * difference;
      ++count;
    }
  }
  if (count < 3) return std::nullopt;
  Eigen::Matrix3d normal_matrix;
  normal_matrix << m00, m01, m02, m01, m11, m12, m02, m12, m22;
  const Eigen::Vector3d plane = normal_matrix.ldlt().solve(Eigen::Vector3d(rhs0, rhs1, rhs2));
  double sum_squares = 0;
  for (int y = 0; y < height; ++y) {
    const uint8_t* on = mask.row(y);
    const float* e = estimate.row(y);
    const float* r = reference.row(y);
    for (int x = 0; x < width; ++x) {
      if (!on[x]) continue;
      const double residual = double(e[x]) - r[x] - plane.dot(Eigen::Vector3d(1.0, x - cx, y - cy));
      sum_squares += residual * residual;
    }
  }
  return std::sqrt(sum_squares / count);
}

std::optional<double> MeanAngularErrorDegrees(const ImageF& estimate, const ImageF& truth, const ImageU8& mask) {
  if (estimate.channels() != 3 || truth.channels() != 3 || !estimate.SameSize(truth) || !mask.SameSize(estimate)) {
    throw std::invalid_argument("MeanAngularErrorDegrees: normals " + ShapeText(estimate) + " and " +
                                ShapeText(truth) + ", mask " + ShapeText(mask) + " must be 3, 3 and 1 channels of one size");
  }
  constexpr int kBandRows = 64;
  const int width = estimate.width(), height = estimate.height();
  ImageF truth_rows;
  std::vector<double> angles;
  double sum = 0;
  size_t count = 0;
  for (int y0 = 0; y0 < height; y0 += kBandRows) {
    const int rows = std::min(kBandRows, height - y0);
    truth_rows.Reshape(width, rows, 3);
    std::copy(truth.row(y0), truth.row(y0) + truth_rows.size(), truth_rows.data());
    angles.clear();
    AngularErrorsOfRows(estimate, truth_rows, y0, mask, 0, &angles);
    for (const double angle : angles) sum += angle;
    count += angles.size();
  }
  if (count == 0) return std::nullopt;
  return sum / count;
}

}  // namespace scanbench
