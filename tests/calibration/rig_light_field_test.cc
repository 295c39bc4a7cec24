#include "calibration/rig_light_field.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "calibration/camera_model.h"

#include "tests/calibration/test_rig.h"
#include "tests/util/eigen_matchers.h"

namespace scanbench {
namespace {

TEST(RigLightFieldTest, PixelsSeeTheirLedFromTheirTablePoint) {
  RigDescription rig;
  rig.camera = testing::DownLookingCamera(40, 30, 600, /*distorted=*/true);
  LedDescription led;
  led.position_in_table_mm = {300, 0, 400};
  led.axis_in_table = -led.position_in_table_mm.normalized();
  led.mu = 2;
  led.rgb_intensity = {0.4, 0.5, 0.6};
  rig.leds = {led};
  const auto field = MakeRigLightField(rig);
  ASSERT_EQ(field->num_lights(), 1);
  ASSERT_EQ(field->width(), 40);

  const ImageF points = ComputeTablePoints(rig.camera);
  for (auto [x, y] : {std::pair{0, 0}, std::pair{39, 29}, std::pair{20, 15}}) {
    float dir[3], intensity[3];
    field->Evaluate(x, y, dir, intensity);
    const Eigen::Vector3d point(points(x, y, 0), points(x, y, 1), points(x, y, 2));
    const Eigen::Vector3d to_led = led.position_in_table_mm - point;
    EXPECT_THAT(Eigen::Vector3f(dir[0], dir[1], dir[2]), testing::EigenNear(to_led.normalized().cast<float>(), 1e-6));
    const double cos_off_axis = (-to_led.normalized()).dot(led.axis_in_table);
    const double expected = 0.5 * std::pow(cos_off_axis, 2) * std::pow(1000.0 / to_led.norm(), 2);
    EXPECT_NEAR(intensity[1], expected, 1e-6 * expected);
  }
}

// A distorted camera tilted 20 degrees about x, so no two rows share points.
CameraGeometry TiltedCamera(int width, int height) {
  CameraGeometry camera = testing::DownLookingCamera(width, height, 600, /*distorted=*/true);
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(20.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Vector3d centre(0, -150, 600);
  camera.cam_from_table.linear() = tilt * camera.cam_from_table.linear();
  camera.cam_from_table.translation() = -camera.cam_from_table.linear() * centre;
  return camera;
}

TEST(RigLightFieldTest, TablePointsOnRequestAreTheHeldPointsBitForBit) {
  const CameraGeometry camera = TiltedCamera(150, 70);
  const ImageF held = ComputeTablePoints(camera);
  const TablePlanePoints on_request(camera);
  ASSERT_EQ(on_request.width(), 150);
  ASSERT_EQ(on_request.height(), 70);
  // One pixel at a time, rows visited out of order so the cache is refilled.
  for (const int y : {69, 0, 35, 36, 1, 68}) {
    for (int x = 149; x >= 0; --x) {
      const Eigen::Vector3f p = on_request.Point(x, y);
      for (int c = 0; c < 3; ++c) ASSERT_EQ(p[c], held(x, y, c)) << x << "," << y << " channel " << c;
    }
  }
  // Spans of several lengths and starts.
  std::vector<float> scratch;
  for (const auto& [x0, y, count] : {std::tuple{0, 0, 150}, std::tuple{17, 40, 1}, std::tuple{63, 12, 70},
                                    std::tuple{100, 69, 50}}) {
    const float* points = on_request.Span(x0, y, count, &scratch);
    EXPECT_TRUE(std::equal(points, points + 3 * count, held.row(y) + 3 * x0)) << x0 << "," << y << " x " << count;
  }
}

TEST(RigLightFieldTest, SparseAndMixedPointsAreTheHeldPointsBitForBit) {
  const CameraGeometry camera = TiltedCamera(150, 70);
  const ImageF held = ComputeTablePoints(camera);
  const TablePlanePoints on_request(camera);
  auto expect_held = [&](int x, int y) {
    const Eigen::Vector3f p = on_request.Point(x, y);
    for (int c = 0; c < 3; ++c) ASSERT_EQ(p[c], held(x, y, c)) << x << "," << y << " channel " << c;
  };
  // Probes 8 px apart (each made alone), then the same rows walked forwards:
  // the walk fills the gaps between the points already made.
  for (int y = 3; y < 70; y += 16) {
    for (int x = 0; x < 150; x += 8) expect_held(x, y);
  }
  for (int y = 3; y < 70; y += 16) {
    for (int x = 0; x < 150; ++x) expect_held(x, y);
  }
  // A fixed pseudo-random order over a few rows, then across the piece
  // boundaries at 63/64 and 127/128 in both directions.
  uint32_t state = 12345;
  for (int n = 0; n < 2000; ++n) {
    state = state * 1664525u + 1013904223u;
    expect_held(static_cast<int>((state >> 8) % 150), 20 + static_cast<int>((state >> 24) % 5));
  }
  for (const int y : {50, 51}) {
    for (const int x : {62, 63, 64, 65, 129, 128, 127, 126, 149, 148, 0, 1}) expect_held(x, y);
  }
}

TEST(RigLightFieldTest, TheRigFieldEqualsOneOnHeldTablePoints) {
  RigDescription rig;
  rig.camera = TiltedCamera(90, 40);
  for (int k = 0; k < 3; ++k) {
    LedDescription led;
    led.position_in_table_mm = {250.0 * std::cos(2.1 * k), 250.0 * std::sin(2.1 * k), 350};
    led.axis_in_table = -led.position_in_table_mm.normalized();
    led.mu = 1.5;
    led.rgb_intensity = {0.4, 0.5, 0.6};
    rig.leds.push_back(led);
  }
  const auto field = MakeRigLightField(rig);
  const PointLightField held(RigPointLights(rig), ComputeTablePoints(rig.camera), CameraCentreInTable(rig.camera));
  constexpr int kWidth = 90;
  std::vector<float> dirs(9), intensities(9), held_dirs(9), held_intensities(9);
  std::vector<float> span_dirs(9 * kWidth), span_intensities(9 * kWidth);
  std::vector<float> held_span_dirs(9 * kWidth), held_span_intensities(9 * kWidth);
  for (int y = 0; y < 40; y += 13) {
    for (int x = 0; x < kWidth; ++x) {
      field->Evaluate(x, y, dirs.data(), intensities.data());
      held.Evaluate(x, y, held_dirs.data(), held_intensities.data());
      ASSERT_EQ(dirs, held_dirs) << x << "," << y;
      ASSERT_EQ(intensities, held_intensities) << x << "," << y;
      float view[3], held_view[3];
      field->ViewDirection(x, y, view);
      held.ViewDirection(x, y, held_view);
      ASSERT_TRUE(std::equal(view, view + 3, held_view)) << x << "," << y;
    }
    field->EvaluateSpan(5, y, 80, kWidth, span_dirs.data(), span_intensities.data());
    held.EvaluateSpan(5, y, 80, kWidth, held_span_dirs.data(), held_span_intensities.data());
    ASSERT_EQ(span_dirs, held_span_dirs) << "row " << y;
    ASSERT_EQ(span_intensities, held_span_intensities) << "row " << y;
  }
}

TEST(RigLightFieldTest, ACameraWhoseRaysMissTheTableIsRejectedUpFront) {
  RigDescription rig;
  rig.camera = testing::DownLookingCamera(40, 30, 600, /*distorted=*/false);
  // Tilted 80 degrees: the upper rows look above the horizon.
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(80.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  rig.camera.cam_from_table.linear() = tilt * rig.camera.cam_from_table.linear();
  rig.camera.cam_from_table.translation() = -rig.camera.cam_from_table.linear() * Eigen::Vector3d(0, 0, 600);
  LedDescription led;
  led.position_in_table_mm = {0, 100, 400};
  rig.leds = {led};
  EXPECT_THAT([&] { MakeRigLightField(rig); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("does not reach the table")));
}

TEST(RigLightFieldTest, LedBelowTheTableIsRejected) {
  RigDescription rig;
  rig.camera = testing::DownLookingCamera(8, 8, 600, false);
  LedDescription led;
  led.id = 7;
  led.position_in_table_mm = {0, 100, -5};
  rig.leds = {led};
  EXPECT_THAT([&] { MakeRigLightField(rig); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("rig.leds[0] (id 7)")));
}

}  // namespace
}  // namespace scanbench
