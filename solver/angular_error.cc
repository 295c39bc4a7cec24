#include "solver/angular_error.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <vector>

namespace scanbench {
namespace {

void CheckSameShape(const ImageF& a, const ImageF& b, const ImageU8& mask, int channels) {
  if (!a.SameSize(b) || a.channels() != b.channels() || a.channels() != channels) {
    throw std::invalid_argument("error statistics: estimate " + std::to_string(a.width()) + "x" +
                                std::to_string(a.height()) + "x" + std::to_string(a.channels()) +
                                " and truth " + std::to_string(b.width()) + "x" + std::to_string(b.height()) +
                                "x" + std::to_string(b.channels()) + " must have the same shape");
  }
  if (!mask.empty() && !mask.SameSize(a)) {
    throw std::invalid_argument("error statistics: mask size differs from the images");
  }
}

double AngleDegrees(const float* estimate, const float* truth) {
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

}  // namespace

ErrorStatistics SummarizeErrors(std::vector<double> errors) {
  ErrorStatistics stats;
  stats.num_pixels = errors.size();
  if (errors.empty()) return stats;
  stats.mean = std::accumulate(errors.begin(), errors.end(), 0.0) / errors.size();
  auto at_fraction = [&](double fraction) {
    const size_t index = std::min(errors.size() - 1, static_cast<size_t>(fraction * (errors.size() - 1) + 0.5));
    std::nth_element(errors.begin(), errors.begin() + index, errors.end());
    return errors[index];
  };
  stats.median = at_fraction(0.5);
  stats.percentile_95 = at_fraction(0.95);
  stats.max = *std::max_element(errors.begin(), errors.end());
  return stats;
}

ErrorStatistics AngularErrorDegrees(const ImageF& estimated, const ImageF& truth, const ImageU8& mask) {
  CheckSameShape(estimated, truth, mask, 3);
  std::vector<double> errors;
  errors.reserve(estimated.num_pixels());
  for (int y = 0; y < estimated.height(); ++y) {
    for (int x = 0; x < estimated.width(); ++x) {
      if (!mask.empty() && mask(x, y) == 0) continue;
      errors.push_back(AngleDegrees(&estimated(x, y), &truth(x, y)));
    }
  }
  return SummarizeErrors(std::move(errors));
}

ImageF AngularErrorMapDegrees(const ImageF& estimated, const ImageF& truth, const ImageU8& mask) {
  CheckSameShape(estimated, truth, mask, 3);
  ImageF map(estimated.width(), estimated.height(), 1, 0.0f);
  for (int y = 0; y < estimated.height(); ++y) {
    for (int x = 0; x < estimated.width(); ++x) {
      if (!mask.empty() && mask(x, y) == 0) continue;
      map(x, y) = static_cast<float>(AngleDegrees(&estimated(x, y), &truth(x, y)));
    }
  }
  return map;
}

ErrorStatistics AbsoluteError(const ImageF& estimated, const ImageF& truth, const ImageU8& mask) {
  CheckSameShape(estimated, truth, mask, estimated.channels());
  std::vector<double> errors;
  errors.reserve(estimated.size());
  for (int y = 0; y < estimated.height(); ++y) {
    for (int x = 0; x < estimated.width(); ++x) {
      if (!mask.empty() && mask(x, y) == 0) continue;
      for (int c = 0; c < estimated.channels(); ++c) {
        const double difference = double(estimated(x, y, c)) - truth(x, y, c);
        errors.push_back(std::isfinite(difference) ? std::abs(difference) : 1e30);
      }
    }
  }
  return SummarizeErrors(std::move(errors));
}

}  // namespace scanbench
