#include "app/sim/target_renderer.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/sim/sensor_color.h"
#include "calibration/camera_model.h"
#include "calibration/color_checker.h"
#include "tests/app/sim/light_model.h"

namespace scanbench {
namespace {

constexpr int kWidth = kD5100Width / 8;   // 616
constexpr int kHeight = kD5100Height / 8;  // 408

SimulatedRigOptions Sensor() {
  SimulatedRigOptions options;
  options.width = kWidth;
  options.height = kHeight;
  return options;
}

using testing::ExpectedDirect;

Eigen::Vector3d TablePointOfPixel(const CameraGeometry& camera, int x, int y, double height) {
  return ComputePlanePointsInTable(camera, {Eigen::Vector2d(x, y)}, height)[0];
}

TEST(TargetRendererTest, WhiteSheetFollowsTheTrueLightModelAtItsHeight) {
  const RigDescription truth = MakeDefaultSimulatedRig(kWidth, kHeight);
  const TargetRenderer renderer(Sensor(), truth);
  WhiteSheetTarget sheet;
  sheet.height_mm = 40;
  SimulatedTarget target = SimulatedTarget::WhiteSheet(sheet);
  target.paper_texture = 0;
  const ImageF image = renderer.RenderLinear(target, 3);
  const ImageF dark = renderer.RenderLinear(target, std::nullopt);
  for (const auto& [x, y] : {std::pair{10, 10}, std::pair{300, 200}, std::pair{600, 400}}) {
    const Eigen::Vector3d p = TablePointOfPixel(truth.camera, x, y, 40);
    for (int c = 0; c < 3; ++c) {
      const double expected = 0.99 * ExpectedDirect(truth.leds[3], p, Eigen::Vector3d::UnitZ(), c);
      EXPECT_NEAR(image(x, y, c) - dark(x, y, c), expected, 1e-5 * expected + 1e-7) << x << "," << y;
      EXPECT_NEAR(dark(x, y, c), 0.99 * Sensor().ambient, 1e-7);
    }
  }
  // Paper texture: about the requested rms, around the sheet's reflectance.
  target.paper_texture = 0.01;
  const PreparedTarget prepared = renderer.Prepare(target);
  double sum = 0, sum_squares = 0;
  for (size_t i = 0; i < prepared.reflectance.num_pixels(); ++i) {
    sum += prepared.reflectance.data()[i];
    sum_squares += prepared.reflectance.data()[i] * prepared.reflectance.data()[i];
  }
  const double n = prepared.reflectance.num_pixels();
  const double mean = sum / n, rms = std::sqrt(sum_squares / n - mean * mean) / mean;
  EXPECT_NEAR(mean, 0.99, 0.002);
  EXPECT_GT(rms, 0.004);
  EXPECT_LT(rms, 0.012);
}

TEST(TargetRendererTest, GrayChartPatchesReadTheirReflectance) {
  const RigDescription truth = MakeDefaultSimulatedRig(kWidth, kHeight);
  const TargetRenderer renderer(Sensor(), truth);
  const SimulatedTarget target = SimulatedTarget::GrayChart(GrayChartTarget::MunsellNeutralScale());
  const PreparedTarget prepared = renderer.Prepare(target);
  for (const GrayPatch& patch : target.gray_chart.patches) {
    const Eigen::Vector3d centre(patch.centre_in_table_mm.x(), patch.centre_in_table_mm.y(), 0);
    const Eigen::Vector2d pixel = ProjectToPixel(truth.camera.intrinsics, truth.camera.cam_from_table * centre);
    EXPECT_FLOAT_EQ(prepared.reflectance(int(std::lround(pixel.x())), int(std::lround(pixel.y()))),
                    static_cast<float>(patch.reflectance))
        << patch.name;
  }
}

TEST(TargetRendererTest, ColorChartPatchesReadTheirSpectralCameraRgbAndShowALittleGloss) {
  const RigDescription truth = MakeDefaultSimulatedRig(kWidth, kHeight);
  const TargetRenderer renderer(Sensor(), truth);
  const SimulatedTarget target = SimulatedTarget::ColorChart(16, 20, 0);
  const PreparedTarget prepared = renderer.Prepare(target);
  ASSERT_EQ(prepared.reflectance.channels(), 3);
  ASSERT_FALSE(prepared.gloss.empty());
  for (int k = 0; k < 24; ++k) {
    const Eigen::Vector3d centre((k % 6 - 2.5) * 20, (1.5 - k / 6) * 20, 0);
    const Eigen::Vector2d pixel = ProjectToPixel(truth.camera.intrinsics, truth.camera.cam_from_table * centre);
    const int x = int(std::lround(pixel.x())), y = int(std::lround(pixel.y()));
    const Eigen::Vector3d expected =
        WhiteBalancedCameraRgbOf(Sensor().color, ColorCheckerClassic()[k].reflectance);
    for (int c = 0; c < 3; ++c) {
      EXPECT_FLOAT_EQ(prepared.reflectance(x, y, c), static_cast<float>(expected[c])) << k << " " << c;
    }
  }
  // Lit by LED 6 (60 deg ring), at the centre of "dark skin": the Lambertian
  // value plus a gloss of at most chart_gloss of the white's.
  const ImageF lit = renderer.RenderLinear(prepared, {6});
  const Eigen::Vector3d p(-50, 30, 0);
  const Eigen::Vector2d pixel = ProjectToPixel(truth.camera.intrinsics, truth.camera.cam_from_table * p);
  const int x = int(std::lround(pixel.x())), y = int(std::lround(pixel.y()));
  const Eigen::Vector3d dark_skin = WhiteBalancedCameraRgbOf(Sensor().color, ColorCheckerClassic()[0].reflectance);
  for (int c = 0; c < 3; ++c) {
    const double white = ExpectedDirect(truth.leds[6], p, Eigen::Vector3d::UnitZ(), c);
    const double lambert = dark_skin[c] * (white + Sensor().ambient);
    EXPECT_GE(lit(x, y, c), lambert * (1 - 1e-3) - 1e-6) << c;
    EXPECT_LE(lit(x, y, c), lambert + target.chart_gloss * white + 1e-6) << c;
  }
  // The card edge and the table: neutral.
  EXPECT_FLOAT_EQ(prepared.reflectance(2, 2, 0), prepared.reflectance(2, 2, 2));
}

TEST(TargetRendererTest, EveryDefaultBoardPoseShowsAllCornersWellInsideTheImage) {
  const RigDescription truth = MakeDefaultSimulatedRig(kWidth, kHeight);
  const CheckerboardTarget board;
  const std::vector<Eigen::Isometry3d> poses = DefaultCheckerboardPoses();
  ASSERT_EQ(poses.size(), 9u);
  EXPECT_TRUE(poses[0].isApprox(Eigen::Isometry3d::Identity()));  // the table view
  for (size_t p = 0; p < poses.size(); ++p) {
    for (const Eigen::Vector3d& corner : board.CornersInTarget()) {
      const Eigen::Vector3d in_cam = truth.camera.cam_from_table * (poses[p] * corner);
      const Eigen::Vector2d pixel = ProjectToPixel(truth.camera.intrinsics, in_cam);
      EXPECT_GT(pixel.x(), 0.05 * kWidth) << "pose " << p;
      EXPECT_LT(pixel.x(), 0.95 * kWidth) << "pose " << p;
      EXPECT_GT(pixel.y(), 0.05 * kHeight) << "pose " << p;
      EXPECT_LT(pixel.y(), 0.95 * kHeight) << "pose " << p;
    }
  }
  // The board's squares alternate and its edges are area-averaged.
  const TargetRenderer renderer(Sensor(), truth);
  const PreparedTarget flat = renderer.Prepare(SimulatedTarget::Checkerboard(board, poses[0]));
  int mixed = 0;
  for (size_t i = 0; i < flat.reflectance.num_pixels(); ++i) {
    const float r = flat.reflectance.data()[i];
    if (r > 0.05f && r < 0.84f && std::abs(r - 0.35f) > 1e-4f) ++mixed;
  }
  EXPECT_GT(mixed, 500);  // edge pixels between dark and light
}

TEST(TargetRendererTest, MeasuredRigIsOffByAFewMillimetresWithNominalLedsAndCamera) {
  const RigDescription truth = MakeDefaultSimulatedRig(kWidth, kHeight);
  const RigDescription measured = MakeMeasuredRigDescription(truth);
  const RigDescription again = MakeMeasuredRigDescription(truth);
  ASSERT_EQ(measured.leds.size(), truth.leds.size());
  double sum_squares = 0;
  for (size_t k = 0; k < truth.leds.size(); ++k) {
    const double error = (measured.leds[k].position_in_table_mm - truth.leds[k].position_in_table_mm).norm();
    sum_squares += error * error;
    EXPECT_LT(error, 20.0);
    EXPECT_EQ(measured.leds[k].position_in_table_mm, again.leds[k].position_in_table_mm);  // repeatable
    EXPECT_DOUBLE_EQ(measured.leds[k].mu, 1.0);
    EXPECT_EQ(measured.leds[k].rgb_intensity, measured.leds[0].rgb_intensity);
    EXPECT_EQ(measured.leds[k].id, truth.leds[k].id);
    EXPECT_NEAR((measured.leds[k].axis_in_table + measured.leds[k].position_in_table_mm.normalized()).norm(), 0, 1e-12);
  }
  // 3 mm rms per axis: about 5 mm rms in 3-D.
  EXPECT_GT(std::sqrt(sum_squares / truth.leds.size()), 2.5);
  EXPECT_LT(std::sqrt(sum_squares / truth.leds.size()), 8.0);
  const CameraIntrinsics& k = measured.camera.intrinsics;
  EXPECT_EQ(k.width, kWidth);
  EXPECT_DOUBLE_EQ(k.cx, 0.5 * (kWidth - 1));
  EXPECT_EQ(k.k1, 0.0);
  EXPECT_NEAR(k.fx, truth.camera.intrinsics.fx, 1e-9);  // the nominal focal length is the thin-lens one
  EXPECT_NEAR(CameraCentreInTable(measured.camera).z(), 600.0, 1e-9);
}

TEST(TargetRendererTest, ChecksNameTheFieldValueAndRule) {
  SimulatedTarget target = SimulatedTarget::WhiteSheet(WhiteSheetTarget());
  target.paper_texture = 0.5;
  EXPECT_THAT([&] { target.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::HasSubstr("SimulatedTarget.paper_texture = 0.5 must lie in [0, 0.2]")));
  TargetRenderOptions render;
  render.exposure = 0;
  EXPECT_THAT([&] { render.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::HasSubstr("TargetRenderOptions.exposure = 0 must lie in (0, 100]")));
  const TargetRenderer renderer(Sensor(), MakeDefaultSimulatedRig(kWidth, kHeight));
  EXPECT_THROW(renderer.RenderLinear(SimulatedTarget::WhiteSheet(WhiteSheetTarget()), 10), std::out_of_range);
  EXPECT_THROW(TargetRenderer(Sensor(), MakeDefaultSimulatedRig(100, 80)), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
