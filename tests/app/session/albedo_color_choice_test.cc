// Which matrix takes the solved albedo to linear Rec.709, chosen from what is
// there (a calibration set's colour section, the RAW file's camera matrix).
#include "app/session/albedo_color_choice.h"

#include <optional>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/session/calibration_set.h"
#include "calibration/color_science.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;
using Source = AlbedoColorOptions::Source;

// XYZ -> camera native of a made-up but plausible camera (a DNG ColorMatrix).
Eigen::Matrix3d CameraFromXyz() {
  Eigen::Matrix3d m;
  m << 0.89, -0.31, -0.08, -0.40, 1.19, 0.23, -0.05, 0.14, 0.56;
  return m;
}

CalibrationSet SetWithColor(bool with_lights) {
  CalibrationSet set;
  ColorSection color;
  color.date = "2026-01-02T03:04:05Z";
  color.white_reference = "light_field";
  color.summary.method = "ciede2000_fit";
  color.summary.rec709_from_camera << 1.6, -0.5, -0.1, -0.2, 1.3, -0.1, 0.0, -0.4, 1.4;
  color.summary.mean_delta_e_after = 0.9;
  color.summary.max_delta_e_after = 2.5;
  set.color = color;
  if (with_lights) {
    LightsSection lights;
    lights.date = "2026-01-02T03:00:00Z";
    lights.sheets = {WhiteSheetTarget()};
    set.lights = lights;
  }
  return set;
}

TEST(AlbedoColorChoiceTest, AutoTakesTheChartThenTheFileMatrixThenNothing) {
  const CalibrationSet set = SetWithColor(true);
  const AlbedoColor chart = ChooseAlbedoColor({}, &set, "cal.json", CameraFromXyz(), "led_00.dng");
  EXPECT_EQ(chart.source, Source::kChart);
  EXPECT_TRUE(chart.IsLinearRec709());
  EXPECT_EQ(chart.rec709_from_camera, set.color->summary.rec709_from_camera);
  EXPECT_EQ(chart.scale, "absolute");
  EXPECT_THAT(chart.scale_source, HasSubstr("99.0 %"));
  EXPECT_THAT(chart.description, HasSubstr("ciede2000_fit"));

  CalibrationSet no_color = set;
  no_color.color.reset();
  const AlbedoColor matrix = ChooseAlbedoColor({}, &no_color, "cal.json", CameraFromXyz(), "led_00.dng");
  EXPECT_EQ(matrix.source, Source::kCameraMatrix);
  EXPECT_TRUE(matrix.rec709_from_camera.isApprox(Rec709FromWhiteBalancedCamera(CameraFromXyz()), 1e-12));
  EXPECT_THAT(matrix.description, HasSubstr("weaker"));
  // White-balanced neutral stays neutral through the file's matrix.
  EXPECT_TRUE((matrix.rec709_from_camera * Eigen::Vector3d::Ones()).isApprox(Eigen::Vector3d::Ones(), 1e-9));

  const AlbedoColor none = ChooseAlbedoColor({}, nullptr, "", std::nullopt, "led_00.dng");
  EXPECT_EQ(none.source, Source::kNone);
  EXPECT_EQ(none.color_space, "camera_rgb");
  EXPECT_EQ(none.scale, "relative");
  EXPECT_THAT(none.description, HasSubstr("not colour calibrated"));
}

TEST(AlbedoColorChoiceTest, AnAbsentSourceAskedForIsAnErrorAndTheScaleFollowsTheLights) {
  AlbedoColorOptions chart;
  chart.source = Source::kChart;
  EXPECT_THAT([&] { ChooseAlbedoColor(chart, nullptr, "", CameraFromXyz(), "a.dng"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("--calibration")));
  CalibrationSet no_color = SetWithColor(true);
  no_color.color.reset();
  EXPECT_THAT([&] { ChooseAlbedoColor(chart, &no_color, "cal.json", CameraFromXyz(), "a.dng"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("cal.json: color: missing")));
  AlbedoColorOptions matrix;
  matrix.source = Source::kCameraMatrix;
  EXPECT_THAT([&] { ChooseAlbedoColor(matrix, nullptr, "", std::nullopt, "frames/led_00.dng"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("frames/led_00.dng: carries no camera colour")));
  const CalibrationSet without_lights = SetWithColor(false);
  EXPECT_EQ(ChooseAlbedoColor({}, &without_lights, "cal.json", std::nullopt, "a.dng").scale, "relative");
  EXPECT_EQ(AlbedoColorSourceFromName("camera-matrix"), Source::kCameraMatrix);
  EXPECT_THROW(AlbedoColorSourceFromName("srgb"), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
