#include "calibration/bayer_sampling.h"

#include <stdexcept>

namespace scanbench {

LinearBayerReader::LinearBayerReader(const RawImage& frame, const RawImage& dark, double clip_fraction,
                                     const std::string& name)
    : frame_(frame), dark_(dark) {
  if (!(clip_fraction > 0 && clip_fraction <= 1)) {
    throw std::invalid_argument(name + ": clip_fraction = " + std::to_string(clip_fraction) + " must lie in (0, 1]");
  }
  if (frame.mosaic.empty() || frame.mosaic.channels() != 1) {
    throw std::invalid_argument(name + ": the frame must be a non-empty 1-channel mosaic");
  }
  if (!dark.mosaic.SameSize(frame.mosaic) || dark.cfa != frame.cfa) {
    throw std::invalid_argument(name + ": dark frame " + std::to_string(dark.width()) + "x" +
                                std::to_string(dark.height()) + " " + CfaPatternName(dark.cfa) +
                                " does not match the frame " + std::to_string(frame.width()) + "x" +
                                std::to_string(frame.height()) + " " + CfaPatternName(frame.cfa));
  }
  for (int i = 0; i < 4; ++i) {
    if (frame.white_level <= frame.black_level[i]) {
      throw std::invalid_argument(name + ": white level " + std::to_string(frame.white_level) +
                                  " must exceed black level " + std::to_string(frame.black_level[i]));
    }
    inverse_range_[i] = 1.0 / (double(frame.white_level) - frame.black_level[i]);
  }
  clip_level_ = static_cast<int>(clip_fraction * frame.white_level);
}

void LinearBayerReader::Accumulate(int x, int y, RgbStatistics& stats) const {
  const int raw = frame_.mosaic(x, y);
  ChannelStatistics& s = stats[CfaColorAt(frame_.cfa, x, y)];
  if (raw >= clip_level_) {
    ++s.clipped;
    return;
  }
  // The dark frame holds the black level, the ambient light and fixed
  // pattern: subtracting it leaves the LED's light only.
  const double value = (raw - int(dark_.mosaic(x, y))) * inverse_range_[(y & 1) * 2 + (x & 1)];
  s.sum += value;
  s.sum_squares += value * value;
  ++s.count;
}

}  // namespace scanbench
