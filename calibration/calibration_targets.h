// The physical targets the calibrations measure: a checkerboard (camera), a
// matte neutral gray chart (sensor linearity and white balance) and a flat
// white sheet (light intensity and direction at every pixel).
//
// Target frame: a plane z = 0 whose visible face points along +z. A target
// lying flat on the table has its axes along the table's (x to the right of
// the image, y to the top, z up), offset by its height above the table.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace scanbench {

struct CheckerboardTarget {
  int inner_corners_x = 9;  // corners along a row (target x), >= 3
  int inner_corners_y = 6;  // corners along a column (target -y), >= 3
  double square_mm = 9.0;   // side of one square, (0, 1000]

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
  int num_corners() const { return inner_corners_x * inner_corners_y; }
  // Inner corner (i, j), i along the row, j down the column, in the target
  // frame: the grid is centred on the origin and corner (0, 0) is at the top
  // left when the board lies flat in the table's orientation.
  Eigen::Vector3d CornerInTarget(int i, int j) const;
  // All corners, row by row (j outer, i inner): OpenCV's order.
  std::vector<Eigen::Vector3d> CornersInTarget() const;
};

// One patch of a gray chart lying flat on the table.
struct GrayPatch {
  std::string name;                                            // e.g. "N5"
  double reflectance = 0;                                      // diffuse reflectance, (0, 1]
  Eigen::Vector2d centre_in_table_mm = Eigen::Vector2d::Zero();  // table x, y of the patch centre
  double size_mm = 0;                                          // side of the square patch, > 0
};

struct GrayChartTarget {
  std::vector<GrayPatch> patches;  // at least 3, of at least 2 different reflectances
  double height_mm = 0;            // patch surface above the table, [0, 200]

  // Throws std::invalid_argument naming the patch, field, value and rule.
  void Check() const;
  // Nine patches of the Munsell neutral value scale (N2, N3, ... N9, N9.5:
  // 3 % to 88 % reflectance),
  // 14 mm squares on an 18 mm pitch around the table origin, in an order that
  // keeps reflectance uncorrelated with position.
  static GrayChartTarget MunsellNeutralScale();
};

// Luminous reflectance (0..1) of Munsell value V in [0, 10] (ASTM D1535's
// fifth-order polynomial; N10 = 1 is the ideal white, N5 = 0.193).
double MunsellValueToReflectance(double value);

struct WhiteSheetTarget {
  double reflectance = 0.99;  // diffuse reflectance, neutral, (0, 1]
  double height_mm = 0;       // sheet surface above the table, [0, 200]

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

}  // namespace scanbench
