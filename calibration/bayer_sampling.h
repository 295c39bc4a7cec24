// Raw Bayer samples as linear values per CFA colour, for measurements that
// must not go through demosaicing (gray chart, white sheet): each raw sample
// counts for its own colour only.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "calibration/raw_image.h"

namespace scanbench {

// Running mean and spread of the samples of one colour.
struct ChannelStatistics {
  double sum = 0;
  double sum_squares = 0;
  int count = 0;
  int clipped = 0;  // samples at or above the clip level (not in sum)

  double Mean() const { return count > 0 ? sum / count : 0.0; }
  // Standard error of the mean; 0 with fewer than 2 samples.
  double StandardError() const {
    if (count < 2) return 0.0;
    const double mean = Mean();
    const double variance = std::max(0.0, (sum_squares - count * mean * mean) / (count - 1));
    return std::sqrt(variance / count);
  }
};

using RgbStatistics = std::array<ChannelStatistics, 3>;

// Reads a frame minus its dark frame, as a fraction of the raw range above
// black, at any raw pixel.
class LinearBayerReader {
 public:
  // Throws std::invalid_argument naming the problem if the frames do not fit
  // together (size, CFA layout, levels). `clip_fraction` in (0, 1].
  LinearBayerReader(const RawImage& frame, const RawImage& dark, double clip_fraction, const std::string& name);

  int width() const { return frame_.width(); }
  int height() const { return frame_.height(); }
  int ColourAt(int x, int y) const { return CfaColorAt(frame_.cfa, x, y); }
  // Adds raw pixel (x, y) to stats[its colour] (or counts it as clipped).
  void Accumulate(int x, int y, RgbStatistics& stats) const;

 private:
  const RawImage& frame_;
  const RawImage& dark_;
  std::array<double, 4> inverse_range_{};  // per 2x2 tile position
  int clip_level_ = 0;
};

}  // namespace scanbench
