#include "app/sim/sensor_color.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "calibration/color_checker.h"
#include "calibration/color_science.h"

namespace scanbench {
namespace {

constexpr int kRedPatch = 14;   // "red", row 3 column 3
constexpr int kWhitePatch = 18; // "white 9.5 (.05 D)"

TEST(SensorColor, NamesRoundTrip) {
  for (const auto model : {SensorColorModel::kNikonD5100, SensorColorModel::kSrgbPrimaries}) {
    EXPECT_EQ(SensorColorModelFromName(SensorColorModelName(model)), model);
  }
  EXPECT_STREQ(SensorColorModelName(SensorColorModel::kNikonD5100), "d5100");
  EXPECT_EQ(SensorColorModelFromName("nikon"), std::nullopt);
}

TEST(SensorColor, PerfectWhiteIsWhiteInCameraSpace) {
  const Spectrum white = Spectrum::Ones();
  for (const auto model : {SensorColorModel::kNikonD5100, SensorColorModel::kSrgbPrimaries}) {
    const Eigen::Vector3d rgb = WhiteBalancedCameraRgbOf(model, white);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgb[c], 1.0, 1e-9) << SensorColorModelName(model) << " " << c;
    // A textile white goes through the Mallett matrix.
    const Eigen::Vector3d textile = SimulatedSensorColor(model).camera_from_linear_rec709 * Eigen::Vector3d::Ones();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(textile[c], 1.0, 2e-3) << SensorColorModelName(model) << " " << c;
  }
}

TEST(SensorColor, PrintFigures) {
  const SensorColor& d = SimulatedSensorColor(SensorColorModel::kNikonD5100);
  std::cout << "camera_from_linear_rec709\n" << d.camera_from_linear_rec709 << "\nraw white " << d.raw_white_relative_to_green.transpose()
            << "\ncamera_from_xyz_d65\n" << d.camera_from_xyz_d65 << "\nas shot " << d.as_shot_neutral.transpose()
            << "\nM*D65 " << (d.camera_from_xyz_d65 * D65WhiteXyz()).transpose() << "\n";
  double sum = 0, mx = 0;
  for (const ColorCheckerPatch& p : ColorCheckerClassic()) {
    const Eigen::Vector3d cam = WhiteBalancedCameraRgbOf(SensorColorModel::kNikonD5100, p.reflectance);
    const double de = Ciede2000(LabFromLinearRec709(cam), p.lab_d65);
    // through the matrix
    const Eigen::Vector3d native = cam.cwiseProduct(d.as_shot_neutral);
    const Eigen::Vector3d xyz = d.camera_from_xyz_d65.inverse() * native;
    // (a crude check: the LED is not D65)
    std::cout << p.name << " cam " << cam.transpose() << " rec709 " << p.linear_rec709.transpose() << " dE raw " << de
              << " dE matrix " << Ciede2000(LabFromXyz(xyz, D65WhiteXyz() ), p.lab_d65) << "\n";
    sum += de; mx = std::max(mx, de);
  }
  std::cout << "mean dE raw " << sum / 24 << " max " << mx << "\n";
}

}  // namespace
}  // namespace scanbench
