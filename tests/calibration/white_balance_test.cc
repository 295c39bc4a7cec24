#include "calibration/white_balance.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/calibration/sim_targets.h"

namespace scanbench {
namespace {

using testing::kCalibrationTestHeight;
using testing::kCalibrationTestWidth;

struct ChartCapture {
  RigDescription truth;
  RigDescription measured;
  GrayChartTarget chart;
  testing::TargetFrames frames;
};

ChartCapture RenderChart(double exposure) {
  ChartCapture capture;
  capture.truth = MakeDefaultSimulatedRig(kCalibrationTestWidth, kCalibrationTestHeight);
  capture.measured = MakeMeasuredRigDescription(capture.truth);
  capture.chart = GrayChartTarget::MunsellNeutralScale();
  const TargetRenderer renderer(testing::CalibrationTestSensor(), capture.truth);
  TargetRenderOptions render;
  render.exposure = exposure;
  capture.frames = testing::RenderTargetFrames(renderer, SimulatedTarget::GrayChart(capture.chart), 300, render);
  return capture;
}

TEST(WhiteBalanceTest, MunsellValuesGiveTheirReflectance) {
  // ASTM D1535: V = 10 is the ideal white, middle gray N5 reflects 19.3 %.
  EXPECT_NEAR(MunsellValueToReflectance(10), 1.0, 1e-3);
  EXPECT_NEAR(MunsellValueToReflectance(5), 0.1927, 1e-3);
  EXPECT_DOUBLE_EQ(MunsellValueToReflectance(0), 0.0);
  for (double v = 0.5; v <= 10; v += 0.5) {
    EXPECT_GT(MunsellValueToReflectance(v), MunsellValueToReflectance(v - 0.5)) << v;
  }
  EXPECT_THROW(MunsellValueToReflectance(11), std::invalid_argument);
}

TEST(WhiteBalanceTest, RecoversEachLedsTrueGainsAndALinearResponse) {
  const ChartCapture capture = RenderChart(1.0);
  // The camera is the true one here: registration is the camera test's job.
  const WhiteBalanceSummary summary = CalibrateWhiteBalance({}, capture.chart, capture.truth.camera,
                                                            capture.measured.leds, capture.frames.dark,
                                                            capture.frames.leds);
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  ASSERT_EQ(summary.leds.size(), 10u);
  for (size_t k = 0; k < 10; ++k) {
    const LedWhiteBalance& led = summary.leds[k];
    const Eigen::Vector3d& intensity = capture.truth.leds[k].rgb_intensity;
    // The sensor's response to this LED's light: a neutral patch reads
    // intensity_c per colour, so the gains are intensity_G / intensity_c.
    // Stated tolerance: 0.4 % (the darker patches are shot-noise limited).
    EXPECT_NEAR(led.gains[0] / (intensity[1] / intensity[0]), 1.0, 4e-3) << "LED " << k;
    EXPECT_NEAR(led.gains[2] / (intensity[1] / intensity[2]), 1.0, 4e-3) << "LED " << k;
    EXPECT_DOUBLE_EQ(led.gains[1], 1.0);
    EXPECT_GT(led.gains_std[0], 0.0);
    // A linear sensor: exponent 1, residuals at the noise level.
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(led.response_exponent[c], 1.0, 0.01) << "LED " << k;
    EXPECT_LT(led.linearity_rms.maxCoeff(), 0.005) << "LED " << k;
    EXPECT_GE(led.used_patches, 7) << "LED " << k;
    EXPECT_LT(led.linear_range_min, 0.03);
    EXPECT_GT(led.linear_range_max, 0.2);
    for (const PatchMeasurement& patch : led.patches) {
      EXPECT_FALSE(patch.clipped) << patch.name;
      EXPECT_FALSE(patch.nonlinear) << patch.name;
      // N2 (3 % reflectance) reads under 1 % of the raw range under the low
      // LEDs: flagged, left out, never mistaken for non-linearity.
      if (patch.underexposed) {
        EXPECT_THAT(patch.name, ::testing::AnyOf("N2", "N3")) << "LED " << k;
      }
    }
  }
}

TEST(WhiteBalanceTest, ACancelEndsCancelledAfterTheLedItFinished) {
  const ChartCapture capture = RenderChart(1.0);
  std::vector<double> reported;
  const WhiteBalanceSummary summary =
      CalibrateWhiteBalance({}, capture.chart, capture.truth.camera, capture.measured.leds, capture.frames.dark,
                            capture.frames.leds, [&](double fraction) {
                              reported.push_back(fraction);
                              return reported.size() < 2;
                            });
  EXPECT_TRUE(summary.IsCancelled());
  EXPECT_FALSE(summary.IsUsable());
  EXPECT_EQ(summary.leds.size(), 2u);
  ASSERT_EQ(reported.size(), 2u);
  EXPECT_DOUBLE_EQ(reported[0], 0.1);
  EXPECT_DOUBLE_EQ(reported[1], 0.2);
}

TEST(WhiteBalanceTest, OverexposedPatchesAreFlaggedAndLeftOut) {
  const ChartCapture capture = RenderChart(2.2);
  const WhiteBalanceSummary summary = CalibrateWhiteBalance({}, capture.chart, capture.truth.camera,
                                                            capture.measured.leds, capture.frames.dark,
                                                            capture.frames.leds);
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  int clipped = 0;
  for (size_t k = 0; k < 10; ++k) {
    const LedWhiteBalance& led = summary.leds[k];
    for (const PatchMeasurement& patch : led.patches) {
      if (patch.clipped) {
        ++clipped;
        EXPECT_FALSE(patch.used);
        EXPECT_THAT(patch.name, ::testing::AnyOf("N9.5", "N9", "N8"));
      }
    }
    // The gains hold without the clipped patches.
    const Eigen::Vector3d& intensity = capture.truth.leds[k].rgb_intensity;
    EXPECT_NEAR(led.gains[0] / (intensity[1] / intensity[0]), 1.0, 4e-3) << "LED " << k;
    EXPECT_NEAR(led.gains[2] / (intensity[1] / intensity[2]), 1.0, 4e-3) << "LED " << k;
  }
  EXPECT_GE(clipped, 5);  // the high ring's LEDs clip the whitest patches
  EXPECT_THAT(summary.BriefReport(), ::testing::HasSubstr("N9.5 clipped"));
}

TEST(WhiteBalanceTest, ChecksAndFailuresNameTheProblem) {
  WhiteBalanceOptions options;
  options.patch_inset = 0.5;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::HasSubstr("WhiteBalanceOptions.patch_inset = 0.5 must lie in [0, 0.45]")));
  GrayChartTarget chart = GrayChartTarget::MunsellNeutralScale();
  chart.patches[4].reflectance = 0;
  EXPECT_THAT([&] { chart.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("patches[4] (N7).reflectance = 0")));
  // Far too dark: every patch underexposed.
  const ChartCapture capture = RenderChart(0.01);
  const WhiteBalanceSummary summary = CalibrateWhiteBalance({}, capture.chart, capture.truth.camera, {},
                                                            capture.frames.dark, capture.frames.leds);
  EXPECT_FALSE(summary.IsUsable());
  EXPECT_THAT(summary.message, ::testing::HasSubstr("LED 0: fewer than 3 usable patches"));
}

}  // namespace
}  // namespace scanbench
