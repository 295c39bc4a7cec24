#include "calibration/color_calibration.h"

#include <cstdio>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "calibration/color_science.h"
#include "calibration/spectra.h"
#include "tests/calibration/color_chart_render.h"
#include "tests/util/eigen_matchers.h"

namespace scanbench {
namespace {

using ::scanbench::testing::CameraValuesFor;
using ::scanbench::testing::ChartRender;
using ::scanbench::testing::EigenNear;
using ::scanbench::testing::PlacedQuad;
using ::scanbench::testing::RenderColorChart;
using ::testing::HasSubstr;

// Raw camera values of the chart as the simulated Nikon D5100 under the LED
// sees them: white-balanced response times the white's raw response (green =
// 1), so the mosaic carries the sensor's real channel imbalance.
std::vector<Eigen::Vector3d> D5100RawPatchValues() {
  const Eigen::Vector3d white = CameraWhiteRelativeToGreen(NikonD5100Sensitivities(), CieLedB5Spd());
  std::vector<Eigen::Vector3d> values;
  for (const ColorCheckerPatch& patch : ColorCheckerClassic()) {
    values.push_back(
        WhiteBalancedCameraRgb(NikonD5100Sensitivities(), CieLedB5Spd(), patch.reflectance).cwiseProduct(white));
  }
  return values;
}

std::vector<PatchSample> D5100WhiteBalancedSamples() {
  std::vector<PatchSample> samples;
  for (const ColorCheckerPatch& patch : ColorCheckerClassic()) {
    PatchSample sample;
    sample.value = WhiteBalancedCameraRgb(NikonD5100Sensitivities(), CieLedB5Spd(), patch.reflectance);
    sample.samples = {100, 200, 100};
    sample.used = true;
    samples.push_back(sample);
  }
  return samples;
}

std::vector<PatchSample> SamplesOf(const std::vector<Eigen::Vector3d>& values) {
  std::vector<PatchSample> samples;
  for (const Eigen::Vector3d& value : values) {
    PatchSample sample;
    sample.value = value;
    sample.used = true;
    samples.push_back(sample);
  }
  return samples;
}

double MaxCornerError(const ColorChartQuad& found, const ColorChartQuad& truth) {
  double error = 0;
  for (int i = 0; i < 4; ++i) error = std::max(error, (found.corners_px[i] - truth.corners_px[i]).norm());
  return error;
}

// A D5100-like matrix from white-balanced camera RGB to linear Rec.709 (rows sum to 1).
Eigen::Matrix3d KnownRec709FromCamera() {
  Eigen::Matrix3d m;
  m << 1.62, -0.51, -0.11,  //
      -0.18, 1.44, -0.26,   //
      0.04, -0.47, 1.43;
  return m;
}

// ---------------------------------------------------------------------------
// Geometry and sampling.

TEST(ColorChartGeometryTest, QuadCornersAndPatchCorners) {
  const ColorChartQuad quad = PlacedQuad({700, 500}, 800, 20, 0.1);
  for (int i = 0; i < 4; ++i) {
    const double u = (i == 1 || i == 2) ? 1 : 0, v = i >= 2 ? 1 : 0;
    EXPECT_THAT(ColorChartPointPx(quad, u, v), EigenNear(quad.corners_px[i], 1e-9));
  }
  // Dark skin's outer corner is the quad's first corner; black's the third.
  EXPECT_THAT(ColorPatchCornersPx(quad, 0)[0], EigenNear(quad.corners_px[0], 1e-9));
  EXPECT_THAT(ColorPatchCornersPx(quad, 23)[2], EigenNear(quad.corners_px[2], 1e-9));
  EXPECT_THROW(ColorPatchCornersPx(quad, 24), std::invalid_argument);
}

TEST(SampleColorChartPatchesTest, MediansPerColourAreTheRenderedValues) {
  ChartRender render;
  render.quad = PlacedQuad({700, 500}, 1000, 7);
  render.patch_camera = CameraValuesFor(KnownRec709FromCamera());
  for (Eigen::Vector3d& value : render.patch_camera) value = value.cwiseMax(0.004);
  render.noise_sigma = 0.003;
  render.cfa = CfaPattern::kGRBG;
  const RawImage frame = RenderColorChart(render);
  const std::vector<PatchSample> samples =
      SampleColorChartPatches(ColorPatchSamplingOptions(), frame, nullptr, render.quad, nullptr);
  ASSERT_EQ(samples.size(), 24u);
  for (int i = 0; i < 24; ++i) {
    EXPECT_TRUE(samples[i].used) << i;
    EXPECT_GT(samples[i].samples[1], 2 * samples[i].samples[0] - 20) << "green has twice the sites";
    EXPECT_THAT(samples[i].value, EigenNear(Eigen::Vector3d(render.exposure * render.patch_camera[i]), 1e-3)) << i;
  }
  // A white response turns the values into the camera values (here: a
  // constant light of `exposure` per channel).
  const ImageF white(frame.width(), frame.height(), 3, static_cast<float>(render.exposure));
  const std::vector<PatchSample> reflectance =
      SampleColorChartPatches(ColorPatchSamplingOptions(), frame, nullptr, render.quad, &white);
  for (int i = 0; i < 24; ++i) EXPECT_THAT(reflectance[i].value, EigenNear(render.patch_camera[i], 2e-3)) << i;
}

TEST(SampleColorChartPatchesTest, ClippedAndDarkPatchesAreFlagged) {
  ChartRender render;
  render.quad = PlacedQuad({700, 500}, 1000, 0);
  render.patch_camera = CameraValuesFor(Eigen::Matrix3d::Identity());
  render.exposure = 1.15;  // white (0.9) reads 1.03 of the range: clips
  render.patch_camera[23] = Eigen::Vector3d(0.02, 0.0005, 0.02);  // black: green below min_level
  const RawImage frame = RenderColorChart(render);
  ColorPatchSamplingOptions options;
  options.min_level = 0.002;
  const std::vector<PatchSample> samples = SampleColorChartPatches(options, frame, nullptr, render.quad, nullptr);
  EXPECT_TRUE(samples[18].clipped);  // white
  EXPECT_FALSE(samples[18].used);
  EXPECT_TRUE(samples[23].too_dark);
  EXPECT_FALSE(samples[23].used);
  EXPECT_TRUE(samples[0].used);  // dark skin
  EXPECT_FALSE(samples[0].clipped);
}

TEST(SampleColorChartPatchesTest, BadInputsThrow) {
  ChartRender render;
  render.width = 200;
  render.height = 150;
  render.quad = PlacedQuad({100, 75}, 150, 0);
  render.patch_camera = CameraValuesFor(Eigen::Matrix3d::Identity());
  const RawImage frame = RenderColorChart(render);
  ColorPatchSamplingOptions options;
  options.patch_inset = 0.5;
  EXPECT_THROW(SampleColorChartPatches(options, frame, nullptr, render.quad, nullptr), std::invalid_argument);
  const ImageF wrong(10, 10, 3, 1.0f);
  EXPECT_THROW(SampleColorChartPatches(ColorPatchSamplingOptions(), frame, nullptr, render.quad, &wrong),
               std::invalid_argument);
}

// ---------------------------------------------------------------------------
// Detection: rendered charts of the simulated D5100 at several poses and
// exposures; the quad must come back in chart order.

struct Pose {
  const char* name;
  double rotation_deg;
  double grid_width_px;
  double tilt;
  double exposure;
  double blur_sigma_px;
};

class DetectColorChartPoseTest : public ::testing::TestWithParam<Pose> {};

TEST_P(DetectColorChartPoseTest, FindsTheChartInChartOrder) {
  const Pose& pose = GetParam();
  ChartRender render;
  render.quad = PlacedQuad({720, 490}, pose.grid_width_px, pose.rotation_deg, pose.tilt);
  render.patch_camera = D5100RawPatchValues();
  render.exposure = pose.exposure;
  render.blur_sigma_px = pose.blur_sigma_px;
  render.vignetting = 0.3;
  render.seed = 11;
  const RawImage frame = RenderColorChart(render);
  const ColorChartDetectionSummary summary = DetectColorChart(ColorChartDetectionOptions(), frame, nullptr);
  std::printf("%s: %s\n", pose.name, summary.BriefReport().c_str());
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_EQ(summary.method, "mcc");
  EXPECT_GT(summary.confidence, 0.5);
  EXPECT_LT(summary.fit_residual, 0.1);
  // Within 2.5 % of the grid width at every corner (a tenth of a patch;
  // the sampling inset is a fifth), and in chart order.
  EXPECT_LT(MaxCornerError(summary.quad, render.quad), 0.025 * pose.grid_width_px)
      << "found " << summary.quad.corners_px[0].transpose() << " | " << summary.quad.corners_px[1].transpose()
      << " | " << summary.quad.corners_px[2].transpose() << " | " << summary.quad.corners_px[3].transpose();
}

INSTANTIATE_TEST_SUITE_P(Poses, DetectColorChartPoseTest,
                         ::testing::Values(Pose{"upright", 0, 900, 0, 0.6, 0},
                                           Pose{"rotated90", 90, 620, 0, 0.6, 0},
                                           Pose{"upsidedown", 180, 900, 0, 0.6, 1.0},
                                           Pose{"tilted", -12, 850, 0.15, 0.6, 0},
                                           Pose{"small", 25, 520, 0, 0.45, 0},
                                           Pose{"dim", 0, 900, 0, 0.12, 0},
                                           Pose{"whiteclips", 170, 900, 0, 1.3, 0.7}),
                         [](const ::testing::TestParamInfo<Pose>& param_info) { return std::string(param_info.param.name); });

TEST(DetectColorChartTest, GivenCornersInTheWrongOrderAreReorderedWithAWarning) {
  ChartRender render;
  render.quad = PlacedQuad({700, 500}, 900, 0);
  render.patch_camera = D5100RawPatchValues();
  const RawImage frame = RenderColorChart(render);
  ColorChartDetectionOptions options;
  // The user clicked the chart as if it were upside down.
  options.corners = ColorChartQuad{{render.quad.corners_px[2], render.quad.corners_px[3], render.quad.corners_px[0],
                                    render.quad.corners_px[1]}};
  const ColorChartDetectionSummary summary = DetectColorChart(options, frame, nullptr);
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_EQ(summary.method, "corners");
  EXPECT_TRUE(summary.reordered);
  EXPECT_THAT(summary.warning, HasSubstr("reordered"));
  EXPECT_LT(MaxCornerError(summary.quad, render.quad), 1e-9);

  options.corners = render.quad;
  const ColorChartDetectionSummary right = DetectColorChart(options, frame, nullptr);
  ASSERT_TRUE(right.IsUsable());
  EXPECT_FALSE(right.reordered);
  EXPECT_TRUE(right.warning.empty());
  EXPECT_GT(right.confidence, 0.5);
}

TEST(DetectColorChartTest, AFrameWithoutAChartFailsClearly) {
  // A gray table with a few coloured blobs and noise: no chart.
  ChartRender render;
  render.quad = PlacedQuad({-5000, -5000}, 10, 0);  // far outside the frame
  render.patch_camera = D5100RawPatchValues();
  render.noise_sigma = 0.01;
  RawImage frame = RenderColorChart(render);
  for (int y = 300; y < 500; ++y) {
    for (int x = 400; x < 700; ++x) frame.mosaic(x, y) = static_cast<uint16_t>(600 + (CfaColorAt(frame.cfa, x, y) + 1) * 2500);
  }
  ColorChartDetectionOptions options;
  options.source_name = "table.dng";
  const ColorChartDetectionSummary summary = DetectColorChart(options, frame, nullptr);
  EXPECT_EQ(summary.termination, Termination::kFailure);
  EXPECT_THAT(summary.message, HasSubstr("no ColorChecker found in table.dng"));
  std::printf("%s\n", summary.BriefReport().c_str());

  // Corners given on the empty table fail as well.
  options.corners = PlacedQuad({700, 500}, 800, 0);
  const ColorChartDetectionSummary at_corners = DetectColorChart(options, frame, nullptr);
  EXPECT_EQ(at_corners.termination, Termination::kFailure);
  EXPECT_THAT(at_corners.message, HasSubstr("at the given corners"));
}

TEST(DetectColorChartTest, CancelStops) {
  ChartRender render;
  render.width = 600;
  render.height = 400;
  render.quad = PlacedQuad({300, 200}, 400, 0);
  render.patch_camera = D5100RawPatchValues();
  const RawImage frame = RenderColorChart(render);
  const ColorChartDetectionSummary summary =
      DetectColorChart(ColorChartDetectionOptions(), frame, nullptr, [](double) { return false; });
  EXPECT_TRUE(summary.IsCancelled());
}

TEST(DetectColorChartTest, OptionsAreChecked) {
  ColorChartDetectionOptions options;
  options.max_fit_residual = 0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = ColorChartDetectionOptions();
  options.max_preview_side = 100;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

// ---------------------------------------------------------------------------
// The colour fit.

TEST(FitColorCorrectionTest, RecoversAKnownMatrixFromExactData) {
  const Eigen::Matrix3d known = KnownRec709FromCamera();
  const std::vector<PatchSample> samples = SamplesOf(CameraValuesFor(known));
  for (const bool preserve_white : {true, false}) {
    ColorCorrectionOptions options;
    options.preserve_white = preserve_white;
    const ColorCorrectionSummary summary = FitColorCorrection(options, samples, ColorCheckerClassic());
    ASSERT_TRUE(summary.IsUsable()) << summary.message;
    EXPECT_THAT(summary.rec709_from_camera, EigenNear(known, 1e-6)) << "preserve_white " << preserve_white;
    EXPECT_LT(summary.mean_delta_e_after, 1e-4);
    EXPECT_GT(summary.mean_delta_e_before, 3.0);
    EXPECT_EQ(summary.used_patches, 24);
  }
  // A matrix whose rows do not sum to 1 is found without the constraint.
  const Eigen::Matrix3d unnormalised = 0.8 * known;
  ColorCorrectionOptions free;
  free.preserve_white = false;
  const ColorCorrectionSummary summary =
      FitColorCorrection(free, SamplesOf(CameraValuesFor(unnormalised)), ColorCheckerClassic());
  EXPECT_THAT(summary.rec709_from_camera, EigenNear(unnormalised, 1e-6));
}

TEST(FitColorCorrectionTest, OpenCvCcmGetsCloseOnExactData) {
  const Eigen::Matrix3d known = KnownRec709FromCamera();
  ColorCorrectionOptions options;
  options.method = ColorCorrectionOptions::Method::kOpenCvCcm;
  options.preserve_white = false;
  const ColorCorrectionSummary summary =
      FitColorCorrection(options, SamplesOf(CameraValuesFor(known)), ColorCheckerClassic());
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_EQ(summary.method, "opencv_ccm");
  EXPECT_THAT(summary.rec709_from_camera, EigenNear(known, 0.02));
  EXPECT_LT(summary.mean_delta_e_after, 0.3);
}

// The simulated D5100 under LED-B5 on the chart's spectra: no 3x3 matrix is
// exact (the camera is not colorimetric); both methods, figures printed.
TEST(FitColorCorrectionTest, SpectralD5100MeetsTheTarget) {
  const std::vector<PatchSample> samples = D5100WhiteBalancedSamples();
  struct Case {
    ColorCorrectionOptions::Method method;
    bool preserve_white;
  };
  double default_mean = 0, default_max = 0;
  for (const Case c : {Case{ColorCorrectionOptions::Method::kCiede2000Fit, true},
                       Case{ColorCorrectionOptions::Method::kCiede2000Fit, false},
                       Case{ColorCorrectionOptions::Method::kOpenCvCcm, false}}) {
    ColorCorrectionOptions options;
    options.method = c.method;
    options.preserve_white = c.preserve_white;
    const ColorCorrectionSummary summary = FitColorCorrection(options, samples, ColorCheckerClassic());
    ASSERT_TRUE(summary.IsUsable()) << summary.message;
    const Eigen::Vector3d white = summary.rec709_from_camera * Eigen::Vector3d::Ones();
    std::printf("%s preserve_white=%d: %s; white -> %.4f %.4f %.4f\n", summary.method.c_str(), c.preserve_white,
                summary.BriefReport().c_str(), white[0], white[1], white[2]);
    EXPECT_LE(summary.mean_delta_e_after, 1.0);
    EXPECT_LT(summary.mean_delta_e_after, summary.mean_delta_e_before);
    if (c.method == ColorCorrectionOptions().method && c.preserve_white == ColorCorrectionOptions().preserve_white) {
      default_mean = summary.mean_delta_e_after;
      default_max = summary.max_delta_e_after;
      EXPECT_THAT(white, EigenNear(Eigen::Vector3d::Ones(), 1e-12));
      std::printf("%s", summary.PatchTable().c_str());
    }
  }
  // Measured: 0.93 mean, 3.22 max (cyan: outside the Rec.709 gamut, R < 0).
  EXPECT_GT(default_mean, 0);
  EXPECT_LE(default_max, 3.5);
}

TEST(FitColorCorrectionTest, ClippedPatchesAreLeftOut) {
  const Eigen::Matrix3d known = KnownRec709FromCamera();
  std::vector<PatchSample> samples = SamplesOf(CameraValuesFor(known));
  // The white patch clipped: its value is wrong and must not count.
  samples[18].value = Eigen::Vector3d(0.7, 0.7, 0.7);
  samples[18].clipped = true;
  samples[18].used = false;
  const ColorCorrectionSummary summary = FitColorCorrection(ColorCorrectionOptions(), samples, ColorCheckerClassic());
  ASSERT_TRUE(summary.IsUsable());
  EXPECT_EQ(summary.used_patches, 23);
  EXPECT_FALSE(summary.patches[18].used);
  EXPECT_THAT(summary.rec709_from_camera, EigenNear(known, 1e-6));
  EXPECT_THAT(summary.PatchTable(), HasSubstr("left out: clipped"));
}

TEST(FitColorCorrectionTest, TooFewPatchesFailNamingWhatIsMissing) {
  std::vector<PatchSample> samples = SamplesOf(CameraValuesFor(KnownRec709FromCamera()));
  for (int i = 0; i < 19; ++i) {
    samples[i].used = false;
    samples[i].too_dark = true;
  }
  ColorCorrectionSummary summary = FitColorCorrection(ColorCorrectionOptions(), samples, ColorCheckerClassic());
  EXPECT_EQ(summary.termination, Termination::kFailure);
  EXPECT_THAT(summary.message, HasSubstr(">= 6 used patches"));
  EXPECT_THAT(summary.message, HasSubstr("5 used"));
  EXPECT_THAT(summary.message, HasSubstr("dark skin (too dark)"));

  // Enough patches but one neutral only.
  samples = SamplesOf(CameraValuesFor(KnownRec709FromCamera()));
  for (int i = 19; i < 24; ++i) samples[i].used = false;
  summary = FitColorCorrection(ColorCorrectionOptions(), samples, ColorCheckerClassic());
  EXPECT_EQ(summary.termination, Termination::kFailure);
  EXPECT_THAT(summary.message, HasSubstr("(1 neutral)"));

  EXPECT_THROW(FitColorCorrection(ColorCorrectionOptions(), std::vector<PatchSample>(3), ColorCheckerClassic()),
               std::invalid_argument);
}

TEST(FitColorCorrectionTest, BalancesOnTheNeutralPatches) {
  // Raw, unbalanced values: the known matrix's camera values times channel gains.
  const Eigen::Matrix3d known = KnownRec709FromCamera();
  std::vector<Eigen::Vector3d> values = CameraValuesFor(known);
  const Eigen::Vector3d raw_white(0.45, 1.0, 0.7);
  for (Eigen::Vector3d& value : values) value = value.cwiseProduct(raw_white);
  ColorCorrectionOptions options;
  options.balance_on_neutral_patches = true;
  const ColorCorrectionSummary summary = FitColorCorrection(options, SamplesOf(values), ColorCheckerClassic());
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_THAT(summary.camera_balance_gains, EigenNear(Eigen::Vector3d(raw_white.cwiseInverse()), 0.05));
  // Not exact: the chart's neutrals are not perfectly flat, so the gains
  // fitted on them are a little off.
  EXPECT_LT(summary.mean_delta_e_after, 1.0);
}

TEST(FitColorCorrectionTest, OptionsAreChecked) {
  ColorCorrectionOptions options;
  options.min_patches = 5;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = ColorCorrectionOptions();
  options.neutral_weight = -1;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

// ---------------------------------------------------------------------------
// End to end: render, detect, sample with a white response, fit.

TEST(ColorCalibrationTest, RenderedD5100ChartCalibratesToTheReference) {
  ChartRender render;
  render.quad = PlacedQuad({700, 480}, 1000, 180, 0.05);
  render.patch_camera = D5100RawPatchValues();
  render.noise_sigma = 0.002;
  render.blur_sigma_px = 0.8;
  const RawImage frame = RenderColorChart(render);
  const ColorChartDetectionSummary detection = DetectColorChart(ColorChartDetectionOptions(), frame, nullptr);
  ASSERT_TRUE(detection.IsUsable()) << detection.message;
  // The perfect white's reading: exposure times the raw white (no vignetting here).
  const Eigen::Vector3d raw_white = CameraWhiteRelativeToGreen(NikonD5100Sensitivities(), CieLedB5Spd());
  ImageF white(frame.width(), frame.height(), 3);
  for (int y = 0; y < frame.height(); ++y) {
    for (int x = 0; x < frame.width(); ++x) {
      for (int c = 0; c < 3; ++c) white(x, y, c) = static_cast<float>(render.exposure * raw_white[c]);
    }
  }
  const std::vector<PatchSample> samples =
      SampleColorChartPatches(ColorPatchSamplingOptions(), frame, nullptr, detection.quad, &white);
  const ColorCorrectionSummary fit = FitColorCorrection(ColorCorrectionOptions(), samples, ColorCheckerClassic());
  ASSERT_TRUE(fit.IsUsable()) << fit.message;
  std::printf("%s\n%s\n", detection.BriefReport().c_str(), fit.BriefReport().c_str());
  EXPECT_EQ(fit.used_patches, 24);
  EXPECT_LE(fit.mean_delta_e_after, 1.0);
  EXPECT_LE(fit.max_delta_e_after, 3.5);
}

// ---------------------------------------------------------------------------
// The fallback: the RAW file's camera matrix.

TEST(Rec709FromWhiteBalancedCameraTest, MatchesAKnownCameraMatrix) {
  // A DSLR-like XYZ -> camera matrix (Adobe DNG ColorMatrix style, D65).
  Eigen::Matrix3d camera_from_xyz;
  camera_from_xyz << 0.8198, -0.2239, -0.0724,  //
      -0.4871, 1.2389, 0.2798,                   //
      -0.1043, 0.2050, 0.7181;
  const Eigen::Matrix3d m = Rec709FromWhiteBalancedCamera(camera_from_xyz);
  EXPECT_THAT(Eigen::Vector3d(m * Eigen::Vector3d::Ones()), EigenNear(Eigen::Vector3d::Ones(), 1e-12));
  const Eigen::Vector3d neutral = camera_from_xyz * D65WhiteXyz();
  // Any colour: through the camera, white-balanced, then M, gives its Rec.709.
  for (const Eigen::Vector3d& rgb : {Eigen::Vector3d(0.2, 0.5, 0.1), Eigen::Vector3d(0.7, 0.1, 0.3),
                                     Eigen::Vector3d(0.05, 0.05, 0.6)}) {
    const Eigen::Vector3d native = camera_from_xyz * (XyzFromLinearRec709() * rgb);
    const Eigen::Vector3d balanced = native.cwiseQuotient(neutral);
    EXPECT_THAT(Eigen::Vector3d(m * balanced), EigenNear(rgb, 1e-4));
  }
  // The matrix's scale does not matter.
  EXPECT_THAT(Rec709FromWhiteBalancedCamera(2.5 * camera_from_xyz), EigenNear(m, 1e-12));
  EXPECT_THROW(Rec709FromWhiteBalancedCamera(Eigen::Matrix3d::Zero()), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
