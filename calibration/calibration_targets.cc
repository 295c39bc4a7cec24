#include "calibration/calibration_targets.h"

#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>
#include "core/field_error.h"

namespace scanbench {
namespace {

void CheckHeight(const std::string& where, double height_mm) {
  SCANBENCH_REQUIRE_GE_LE(where, "height_mm", height_mm, 0, 200);
}

}  // namespace

void CheckerboardTarget::Check() const {
  const std::string where = "CheckerboardTarget";
  SCANBENCH_REQUIRE_GE_LE(where, "inner_corners_x", inner_corners_x, 3, 100);
  SCANBENCH_REQUIRE_GE_LE(where, "inner_corners_y", inner_corners_y, 3, 100);
  SCANBENCH_REQUIRE_GT_LE(where, "square_mm", square_mm, 0, 1000);
}

Eigen::Vector3d CheckerboardTarget::CornerInTarget(int i, int j) const {
  return {(i - 0.5 * (inner_corners_x - 1)) * square_mm, (0.5 * (inner_corners_y - 1) - j) * square_mm, 0.0};
}

std::vector<Eigen::Vector3d> CheckerboardTarget::CornersInTarget() const {
  std::vector<Eigen::Vector3d> corners;
  corners.reserve(num_corners());
  for (int j = 0; j < inner_corners_y; ++j) {
    for (int i = 0; i < inner_corners_x; ++i) corners.push_back(CornerInTarget(i, j));
  }
  return corners;
}

void GrayChartTarget::Check() const {
  const std::string where = "GrayChartTarget";
  SCANBENCH_REQUIRE_GE(where, "patches.size()", patches.size(), 3);
  std::set<double> reflectances;
  for (size_t i = 0; i < patches.size(); ++i) {
    const GrayPatch& patch = patches[i];
    const std::string name = where + ".patches[" + std::to_string(i) + "] (" + patch.name + ")";
    SCANBENCH_REQUIRE_GT_LE(name, "reflectance", patch.reflectance, 0, 1);
    if (!patch.centre_in_table_mm.allFinite()) {
      throw FieldError(name, "centre_in_table_mm.x", patch.centre_in_table_mm.x(), "(and y) must be finite");
    }
    SCANBENCH_REQUIRE_GT_LE(name, "size_mm", patch.size_mm, 0, 500);
    reflectances.insert(patch.reflectance);
  }
  if (reflectances.size() < 2) {
    throw FieldError(where, "patches", "(all one reflectance)", "must hold at least 2 different reflectances");
  }
  CheckHeight(where, height_mm);
}

double MunsellValueToReflectance(double value) {
  SCANBENCH_REQUIRE_GE_LE("MunsellValueToReflectance", "value", value, 0, 10);
  const double v = value;
  const double percent = v * (1.1914 + v * (-0.22533 + v * (0.23352 + v * (-0.020484 + v * 0.00081939))));
  return percent / 100.0;
}

GrayChartTarget GrayChartTarget::MunsellNeutralScale() {
  // Values in a scrambled order over the 3 x 3 grid (row by row from the top
  // left), so that a light gradient across the chart is not mistaken for a
  // non-linear response.
  constexpr double kValues[9] = {6, 9.5, 3, 2, 7, 5, 8, 4, 9};
  constexpr double kSizeMm = 14, kPitchMm = 18;
  GrayChartTarget chart;
  for (int k = 0; k < 9; ++k) {
    GrayPatch patch;
    std::ostringstream name;
    name << "N" << kValues[k];
    patch.name = name.str();
    patch.reflectance = MunsellValueToReflectance(kValues[k]);
    patch.centre_in_table_mm = {(k % 3 - 1) * kPitchMm, (1 - k / 3) * kPitchMm};
    patch.size_mm = kSizeMm;
    chart.patches.push_back(patch);
  }
  return chart;
}

void WhiteSheetTarget::Check() const {
  const std::string where = "WhiteSheetTarget";
  SCANBENCH_REQUIRE_GT_LE(where, "reflectance", reflectance, 0, 1);
  CheckHeight(where, height_mm);
}

}  // namespace scanbench
