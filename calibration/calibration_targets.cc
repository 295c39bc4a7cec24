#include "calibration/calibration_targets.h"

#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>
#include "core/field_error.h"

namespace scanbench {
namespace {

void CheckHeight(const std::string& where, double height_mm) {
  if (!(height_mm >= 0 && height_mm <= 200)) throw FieldError(where, "height_mm", height_mm, "must lie in [0, 200]");
}

}  // namespace

void CheckerboardTarget::Check() const {
  const std::string where = "CheckerboardTarget";
  if (inner_corners_x < 3 || inner_corners_x > 100) {
    throw FieldError(where, "inner_corners_x", inner_corners_x, "must lie in [3, 100]");
  }
  if (inner_corners_y < 3 || inner_corners_y > 100) {
    throw FieldError(where, "inner_corners_y", inner_corners_y, "must lie in [3, 100]");
  }
  if (!(square_mm > 0 && square_mm <= 1000)) throw FieldError(where, "square_mm", square_mm, "must lie in (0, 1000]");
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
  if (patches.size() < 3) throw FieldError(where, "patches.size()", patches.size(), "must be >= 3");
  std::set<double> reflectances;
  for (size_t i = 0; i < patches.size(); ++i) {
    const GrayPatch& patch = patches[i];
    const std::string name = where + ".patches[" + std::to_string(i) + "] (" + patch.name + ")";
    if (!(patch.reflectance > 0 && patch.reflectance <= 1)) {
      throw FieldError(name, "reflectance", patch.reflectance, "must lie in (0, 1]");
    }
    if (!patch.centre_in_table_mm.allFinite()) {
      throw FieldError(name, "centre_in_table_mm.x", patch.centre_in_table_mm.x(), "(and y) must be finite");
    }
    if (!(patch.size_mm > 0 && patch.size_mm <= 500)) throw FieldError(name, "size_mm", patch.size_mm, "must lie in (0, 500]");
    reflectances.insert(patch.reflectance);
  }
  if (reflectances.size() < 2) {
    throw FieldError(where, "patches", "(all one reflectance)", "must hold at least 2 different reflectances");
  }
  CheckHeight(where, height_mm);
}

double MunsellValueToReflectance(double value) {
  if (!(value >= 0 && value <= 10)) {
    throw FieldError("MunsellValueToReflectance", "value", value, "must lie in [0, 10]");
  }
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
  if (!(reflectance > 0 && reflectance <= 1)) throw FieldError(where, "reflectance", reflectance, "must lie in (0, 1]");
  CheckHeight(where, height_mm);
}

}  // namespace scanbench
