#include "calibration/raw_image.h"

#include <stdexcept>

namespace scanbench {
namespace {
// Colour of tile positions (0,0) (1,0) (0,1) (1,1) for each pattern.
constexpr int kTileColors[4][4] = {
    {0, 1, 1, 2},  // RGGB
    {2, 1, 1, 0},  // BGGR
    {1, 0, 2, 1},  // GRBG
    {1, 2, 0, 1},  // GBRG
};
}  // namespace

int CfaColorAt(CfaPattern pattern, int x, int y) {
  return kTileColors[static_cast<int>(pattern)][(y & 1) * 2 + (x & 1)];
}

std::string CfaPatternName(CfaPattern pattern) {
  switch (pattern) {
    case CfaPattern::kRGGB: return "RGGB";
    case CfaPattern::kBGGR: return "BGGR";
    case CfaPattern::kGRBG: return "GRBG";
    case CfaPattern::kGBRG: return "GBRG";
  }
  return "?";
}

CfaPattern CfaPatternFromName(const std::string& name) {
  for (CfaPattern p : {CfaPattern::kRGGB, CfaPattern::kBGGR, CfaPattern::kGRBG, CfaPattern::kGBRG}) {
    if (CfaPatternName(p) == name) return p;
  }
  throw std::invalid_argument("CFA pattern '" + name + "' is not one of RGGB, BGGR, GRBG, GBRG");
}

}  // namespace scanbench
