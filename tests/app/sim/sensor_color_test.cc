#include "app/sim/sensor_color.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "calibration/color_checker.h"
#include "calibration/color_science.h"

namespace scanbench {
namespace {

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

TEST(SensorColor, CameraMatrixMapsTheD65WhiteToTheCamerasD65NeutralAsDngRequires) {
  const SensorColor& d5100 = SimulatedSensorColor(SensorColorModel::kNikonD5100);
  // The D65 white's camera-native response, largest component 1.
  const Eigen::Vector3d d65_native = CameraWhiteRelativeToGreen(NikonD5100Sensitivities(), CieD65Spd());
  const Eigen::Vector3d expected = d65_native / d65_native.maxCoeff();
  const Eigen::Vector3d neutral = d5100.camera_from_xyz_d65 * D65WhiteXyz();
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(neutral[c], expected[c], 1e-3) << c;
  EXPECT_NEAR(neutral.maxCoeff(), 1.0, 1e-3);
  // AsShotNeutral is the LED white, normalised the same way: close to the D65
  // neutral (the LED is a 6598 K white) but not equal (it is no D65).
  const Eigen::Vector3d led = CameraWhiteRelativeToGreen(NikonD5100Sensitivities(), CieLedB5Spd());
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(d5100.as_shot_neutral[c], led[c] / led.maxCoeff(), 1e-12);
  EXPECT_LT((d5100.as_shot_neutral - neutral).cwiseAbs().maxCoeff(), 0.05);
  EXPECT_GT((d5100.as_shot_neutral - neutral).cwiseAbs().maxCoeff(), 0.005);
  // The old camera keeps its matrix: XYZ -> linear Rec.709.
  EXPECT_TRUE(SimulatedCameraFromXyzD65(SensorColorModel::kSrgbPrimaries).isApprox(LinearRec709FromXyz(), 1e-12));
}

TEST(SensorColor, CameraMatrixIsALeastSquaresFitNotAnIdentityOfColour) {
  // Through the fitted matrix the ColorChecker (never trained on) comes out
  // within a few CIEDE2000 but not exactly: the D5100 is not colorimetric.
  const SensorColor& d5100 = SimulatedSensorColor(SensorColorModel::kNikonD5100);
  const Eigen::Vector3d d65_native = CameraWhiteRelativeToGreen(NikonD5100Sensitivities(), CieD65Spd());
  const Eigen::Matrix3d xyz_from_camera = d5100.camera_from_xyz_d65.inverse();
  double sum = 0, worst = 0;
  for (const ColorCheckerPatch& patch : ColorCheckerClassic()) {
    // Camera-native response under D65, with the matrix's scale.
    const Eigen::Vector3d native = WhiteBalancedCameraRgb(NikonD5100Sensitivities(), CieD65Spd(), patch.reflectance)
                                       .cwiseProduct(d65_native / d65_native.maxCoeff());
    const double delta_e = Ciede2000(LabFromXyz(xyz_from_camera * native, D65WhiteXyz()), patch.lab_d65);
    sum += delta_e;
    worst = std::max(worst, delta_e);
  }
  RecordProperty("matrix_mean_delta_e", std::to_string(sum / 24));
  EXPECT_LT(sum / 24, 2.0);  // 0.95 measured
  EXPECT_GT(sum / 24, 0.3);
  EXPECT_GT(worst, 1.5);
}

TEST(SensorColor, RawCameraRgbIsFarFromRec709) {
  // White-balanced camera RGB read as if it were linear Rec.709 (no colour
  // calibration): the ColorChecker is off by several CIEDE2000 on average.
  double sum = 0;
  for (const ColorCheckerPatch& patch : ColorCheckerClassic()) {
    const Eigen::Vector3d camera = WhiteBalancedCameraRgbOf(SensorColorModel::kNikonD5100, patch.reflectance);
    sum += Ciede2000(LabFromLinearRec709(camera), patch.lab_d65);
  }
  RecordProperty("raw_mean_delta_e", std::to_string(sum / 24));
  EXPECT_GT(sum / 24, 4.0);
  // The old camera sees exactly Rec.709.
  const Eigen::Vector3d old = WhiteBalancedCameraRgbOf(SensorColorModel::kSrgbPrimaries, ColorCheckerClassic()[14].reflectance);
  EXPECT_TRUE(old.isApprox(ColorCheckerClassic()[14].linear_rec709, 1e-12));
}

}  // namespace
}  // namespace scanbench
