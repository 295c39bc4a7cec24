// A sensor's Bayer mosaic as the RAW file states it, before any processing.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "core/image.h"

namespace scanbench {

// The colour of the 2x2 CFA tile, read row by row from the top-left pixel.
enum class CfaPattern { kRGGB, kBGGR, kGRBG, kGBRG };

// 0 = red, 1 = green, 2 = blue.
int CfaColorAt(CfaPattern pattern, int x, int y);
std::string CfaPatternName(CfaPattern pattern);
// Parses "RGGB" etc.; throws std::invalid_argument naming the text otherwise.
CfaPattern CfaPatternFromName(const std::string& name);

struct RawImage {
  ImageU16 mosaic;                          // 1 channel, raw digital numbers
  CfaPattern cfa = CfaPattern::kRGGB;
  std::array<uint16_t, 4> black_level{};    // per 2x2 tile position, row-major
  uint16_t white_level = 0;                 // saturation level in raw DN

  int width() const { return mosaic.width(); }
  int height() const { return mosaic.height(); }
  uint16_t BlackAt(int x, int y) const { return black_level[(y & 1) * 2 + (x & 1)]; }
};

}  // namespace scanbench
