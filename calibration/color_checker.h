// The X-Rite ColorChecker Classic (24 patches) as a colour reference: BabelColor's average spectral
// reflectances (data/spectra/colorchecker_babelcolor_avg.csv) and their colours under D65.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "calibration/spectra.h"

namespace scanbench {

struct ColorCheckerPatch {
  std::string name;               // "dark skin", ..., "black 2 (1.5 D)"
  Spectrum reflectance;           // BabelColor average
  Eigen::Vector3d linear_rec709;  // LinearRec709OfReflectance (under D65)
  Eigen::Vector3d lab_d65;        // CIELAB, D65 white
  bool neutral = false;           // the bottom row (patches 19..24)
};

inline constexpr int kColorCheckerRows = 4, kColorCheckerColumns = 6;

// The 24 patches of the X-Rite ColorChecker Classic in chart order: row by row from the top left
// (dark skin) as the chart is viewed with its gray row at the bottom; 4 rows x 6 columns.
const std::vector<ColorCheckerPatch>& ColorCheckerClassic();

}  // namespace scanbench
