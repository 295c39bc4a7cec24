// The solver family: every method on analytic scenes, the adaptive default's
// paths, robust rejection, Bayer-domain mode, requested outputs and cropping.
#include <cmath>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "solver/angular_error.h"
#include "solver/photometric_solver.h"
#include "solver/synthetic_scene.h"
#include "tests/solver/solver_test_util.h"

namespace scanbench {
namespace {

using Method = PhotometricSolverOptions::Method;
using ::testing::HasSubstr;
using testing::ExactPixels;
using testing::ExpectAllFinite;
using testing::InputFor;

ImageU8 ObjectPixels(const SyntheticScene& scene) { return scene.object; }

struct MethodCase {
  Method method;
  SyntheticSceneOptions::Lights lights;
};

std::string CaseName(const ::testing::TestParamInfo<MethodCase>& info) {
  return std::string(PhotometricMethodName(info.param.method)) +
         (info.param.lights == SyntheticSceneOptions::Lights::kDistant ? "_DistantLights" : "_NearFieldLights");
}

std::vector<MethodCase> AllCases() {
  std::vector<MethodCase> cases;
  for (Method method : AllPhotometricMethods()) {
    cases.push_back({method, SyntheticSceneOptions::Lights::kDistant});
    if (method != Method::kUniformPseudoInverse) cases.push_back({method, SyntheticSceneOptions::Lights::kNearField});
  }
  return cases;
}

class EveryMethodTest : public ::testing::TestWithParam<MethodCase> {};

// Noise-free Lambertian: every method is exact where every light is seen.
TEST_P(EveryMethodTest, ExactOnNoiseFreeLambertianSphere) {
  SyntheticSceneOptions scene_options;
  scene_options.lights = GetParam().lights;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverOptions options;
  options.method = GetParam().method;
  PhotometricSolution solution;
  const PhotometricSolverSummary summary = SolvePhotometricStereo(options, InputFor(scene), &solution);
  ASSERT_EQ(summary.termination, Termination::kSuccess) << summary.BriefReport();
  EXPECT_EQ(summary.method, PhotometricMethodName(options.method));
  const ImageU8 exact = ExactPixels(scene);
  const ErrorStatistics angular = AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, exact);
  ASSERT_GT(angular.num_pixels, 1000u);
  if (options.method == Method::kLearned) {
    // A network is not exact: within its floor (docs/solver.md, "Learned normals").
    EXPECT_LE(angular.mean, 2.0) << summary.BriefReport();
    EXPECT_LE(AbsoluteError(solution.albedo, scene.albedo, exact).mean, 0.02);
    ExpectAllFinite(solution);
    return;
  }
  EXPECT_LE(angular.max, 0.01) << summary.BriefReport();
  EXPECT_LE(AbsoluteError(solution.albedo, scene.albedo, exact).max, 1e-4);
  // Also where some lights are behind the surface (attached shadow, left out).
  EXPECT_LE(AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, ObjectPixels(scene)).max, 0.01);
  ExpectAllFinite(solution);
}

// Noisy: the least-squares family agrees with the Jacobi SVD reference; the
// robust ones are as accurate within a small margin.
TEST_P(EveryMethodTest, NoisySphereMatchesTheReference) {
  SyntheticSceneOptions scene_options;
  scene_options.lights = GetParam().lights;
  scene_options.noise_stddev = 0.003;
  scene_options.seed = 7;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverOptions reference_options;
  reference_options.method = Method::kJacobiSvd;
  PhotometricSolution reference;
  SolvePhotometricStereo(reference_options, InputFor(scene), &reference);
  PhotometricSolverOptions options;
  options.method = GetParam().method;
  PhotometricSolution solution;
  SolvePhotometricStereo(options, InputFor(scene), &solution);
  const ImageU8 object = ObjectPixels(scene);
  const double reference_error = AngularErrorDegrees(reference.normal_in_table, scene.normal_in_table, object).mean;
  const double error = AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, object).mean;
  ASSERT_GT(reference_error, 0.05) << "noise must show";
  const Method method = GetParam().method;
  if (method == Method::kNormalEquations || method == Method::kQr || method == Method::kUniformPseudoInverse) {
    // Same estimator: differences are rounding only.
    EXPECT_LE(AngularErrorDegrees(solution.normal_in_table, reference.normal_in_table, object).max, 1e-3);
  } else {
    // Robust fits give up a little efficiency on Gaussian noise.
    EXPECT_LE(error, 1.15 * reference_error + 0.01) << "reference " << reference_error;
  }
  ExpectAllFinite(solution);
}

INSTANTIATE_TEST_SUITE_P(Methods, EveryMethodTest, ::testing::ValuesIn(AllCases()), CaseName);

TEST(SolverMethodsTest, UniformPinvRejectsAPerPixelLightField) {
  SyntheticSceneOptions scene_options;
  scene_options.lights = SyntheticSceneOptions::Lights::kNearField;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverOptions options;
  options.method = Method::kUniformPseudoInverse;
  PhotometricSolution solution;
  EXPECT_THAT([&] { SolvePhotometricStereo(options, InputFor(scene), &solution); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("needs a uniform light field")));
}

TEST(AdaptiveTest, DistantLightsShareOneLightMatrixAndNeedNoRobustPass) {
  const SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  PhotometricSolution solution;
  const PhotometricSolverSummary summary =
      SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  EXPECT_EQ(summary.pixels_by_path[int(SolvePath::kSharedLights)], summary.num_solved());
  EXPECT_EQ(summary.pixels_by_path[int(SolvePath::kRobust)], 0u);
  EXPECT_THAT(summary.BriefReport(), HasSubstr("shared_lights"));
}

TEST(AdaptiveTest, NearFieldLightsAreInterpolatedWithinTolerance) {
  SyntheticSceneOptions scene_options;
  scene_options.lights = SyntheticSceneOptions::Lights::kNearField;
  scene_options.width = scene_options.height = 256;
  scene_options.light_distance = 300;  // strongly varying: about 5 deg across the image
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverOptions options;
  options.tile_size = 32;
  PhotometricSolution interpolated, exact;
  const PhotometricSolverSummary summary = SolvePhotometricStereo(options, InputFor(scene), &interpolated);
  EXPECT_GT(summary.pixels_by_path[int(SolvePath::kInterpolatedLights)], summary.num_solved() / 2)
      << summary.BriefReport();
  options.light_tolerance = 0;  // exact only
  const PhotometricSolverSummary exact_summary = SolvePhotometricStereo(options, InputFor(scene), &exact);
  EXPECT_EQ(exact_summary.pixels_by_path[int(SolvePath::kExactLights)], exact_summary.num_solved());
  // Tolerance 1e-4 rad is 0.0057 deg: the interpolated normals stay that close.
  const ErrorStatistics difference =
      AngularErrorDegrees(interpolated.normal_in_table, exact.normal_in_table, ExactPixels(scene));
  EXPECT_LE(difference.max, 0.012);
  EXPECT_LE(AngularErrorDegrees(interpolated.normal_in_table, scene.normal_in_table, ExactPixels(scene)).max, 0.012);
}

// A shiny sphere (Blinn-Phong sheen, as DiLiGenT's ball): least squares is
// pulled towards the highlights, the robust methods are not.
TEST(RobustTest, SpecularHighlightsAreRejected) {
  SyntheticSceneOptions scene_options;
  scene_options.specular = 0.6;
  scene_options.shininess = 60;
  scene_options.num_lights = 20;
  scene_options.noise_stddev = 0.001;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  const ImageU8 object = ObjectPixels(scene);
  PhotometricSolverOptions lsq;
  lsq.method = Method::kJacobiSvd;
  PhotometricSolution lsq_solution;
  SolvePhotometricStereo(lsq, InputFor(scene), &lsq_solution);
  const double lsq_error = AngularErrorDegrees(lsq_solution.normal_in_table, scene.normal_in_table, object).mean;
  ASSERT_GT(lsq_error, 1.0) << "the sheen must bias least squares";
  for (Method method : {Method::kAdaptive, Method::kRobustIrls, Method::kSparseBayesian}) {
    PhotometricSolverOptions options;
    options.method = method;
    PhotometricSolution solution;
    const PhotometricSolverSummary summary = SolvePhotometricStereo(options, InputFor(scene), &solution);
    const double error = AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, object).mean;
    EXPECT_LT(error, 0.25 * lsq_error) << PhotometricMethodName(method) << ": " << summary.BriefReport();
    ExpectAllFinite(solution);
    if (method == Method::kAdaptive) {
      // Robust only where the residual calls for it: the highlight pixels.
      EXPECT_GT(summary.pixels_by_path[int(SolvePath::kRobust)], 0u);
      EXPECT_LT(summary.pixels_by_path[int(SolvePath::kRobust)], summary.num_solved() * 3 / 4);
    }
  }
}

TEST(RobustTest, CauchyLossAlsoRejectsHighlights) {
  SyntheticSceneOptions scene_options;
  scene_options.specular = 0.6;
  scene_options.shininess = 60;
  scene_options.num_lights = 20;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverOptions options;
  options.method = Method::kRobustIrls;
  options.robust_loss = PhotometricSolverOptions::RobustLoss::kCauchy;
  PhotometricSolution solution;
  SolvePhotometricStereo(options, InputFor(scene), &solution);
  EXPECT_LT(AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, ObjectPixels(scene)).mean, 1.0);
}

TEST(AdaptiveTest, RegionCropsTheWorkToItsTiles) {
  SyntheticSceneOptions scene_options;
  scene_options.width = scene_options.height = 256;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  ImageU8 region(256, 256, 1, 0);
  for (int y = 100; y < 120; ++y) {
    for (int x = 100; x < 120; ++x) region(x, y) = 1;
  }
  PhotometricSolverInput input = InputFor(scene);
  input.region = &region;
  PhotometricSolverOptions options;
  options.tile_size = 64;
  PhotometricSolution solution;
  const PhotometricSolverSummary summary = SolvePhotometricStereo(options, input, &solution);
  EXPECT_EQ(summary.num_tiles, 16u);
  EXPECT_EQ(summary.tiles_skipped, 15u);  // the region lies in one tile
  EXPECT_EQ(summary.num_solved(), 400u);
  EXPECT_EQ(solution.status(0, 0), uint8_t(PixelStatus::kOutsideRegion));
  EXPECT_EQ(solution.solve_path(0, 0), uint8_t(SolvePath::kNone));
}

TEST(AdaptiveTest, OnlyTheRequestedOutputsAreFilled) {
  const SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  PhotometricSolution full, lean;
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &full);
  PhotometricSolverOptions options;
  options.compute_albedo = false;
  options.compute_confidence = false;
  SolvePhotometricStereo(options, InputFor(scene), &lean);
  EXPECT_TRUE(lean.albedo.empty());
  EXPECT_TRUE(lean.condition_number.empty());
  EXPECT_TRUE(lean.residual.empty());
  ASSERT_FALSE(lean.status.empty());
  for (size_t i = 0; i < full.normal_in_table.size(); ++i) {
    ASSERT_EQ(full.normal_in_table.data()[i], lean.normal_in_table.data()[i]);
  }
}

TEST(AdaptiveTest, CancelStopsAndReportsIt) {
  SyntheticSceneOptions scene_options;
  scene_options.width = scene_options.height = 512;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverOptions options;
  options.tile_size = 32;
  PhotometricSolution solution;
  const PhotometricSolverSummary summary =
      SolvePhotometricStereo(options, InputFor(scene), &solution, [](double) { return false; });
  EXPECT_EQ(summary.termination, Termination::kCancelled);
  EXPECT_THAT(summary.message, HasSubstr("tiles"));
  EXPECT_LT(summary.num_solved(), 512u * 512u);
}

// Bayer-domain mode: each raw pixel's own CFA channel, divided by that
// channel's light intensity (white balance per CFA channel).
struct MosaicScene {
  std::vector<ImageF> mosaics;
  std::vector<const ImageF*> pointers;
};

MosaicScene Mosaic(const SyntheticScene& scene, const std::array<int, 4>& cfa) {
  MosaicScene out;
  for (const ImageF& image : scene.images) {
    ImageF mosaic(image.width(), image.height(), 1);
    for (int y = 0; y < image.height(); ++y) {
      for (int x = 0; x < image.width(); ++x) mosaic(x, y) = image(x, y, cfa[(y & 1) * 2 + (x & 1)]);
    }
    out.mosaics.push_back(std::move(mosaic));
  }
  for (const ImageF& mosaic : out.mosaics) out.pointers.push_back(&mosaic);
  return out;
}

TEST(BayerTest, NormalAtEveryRawPixelAndDemosaicedAlbedo) {
  for (const auto lights : {SyntheticSceneOptions::Lights::kDistant, SyntheticSceneOptions::Lights::kNearField}) {
    SyntheticSceneOptions scene_options;
    scene_options.lights = lights;
    const SyntheticScene scene = MakeSyntheticScene(scene_options);
    const std::array<int, 4> rggb = {0, 1, 1, 2};
    const MosaicScene mosaic = Mosaic(scene, rggb);
    BayerSolverInput input;
    input.mosaics = mosaic.pointers;
    input.cfa_channels = rggb;
    input.light_field = scene.light_field.get();
    PhotometricSolution solution;
    const PhotometricSolverSummary summary = SolvePhotometricStereoBayer(PhotometricSolverOptions(), input, &solution);
    EXPECT_TRUE(summary.bayer_domain);
    EXPECT_THAT(summary.BriefReport(), HasSubstr("Bayer domain"));
    const ImageU8 exact = ExactPixels(scene);
    EXPECT_LE(AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, exact).max, 0.01);
    // Uniform albedo: the demosaiced albedo is exact away from unsolved neighbours.
    ImageU8 interior = exact;
    for (int y = 0; y < 128; ++y) {
      for (int x = 0; x < 128; ++x) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = std::clamp(x + dx, 0, 127), yy = std::clamp(y + dy, 0, 127);
            if (!exact(xx, yy)) interior(x, y) = 0;
          }
        }
      }
    }
    EXPECT_LE(AbsoluteError(solution.albedo, scene.albedo, interior).max, 1e-4);
    ExpectAllFinite(solution);
  }
}

TEST(BayerTest, RejectsABadCfaChannel) {
  const SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  const MosaicScene mosaic = Mosaic(scene, {0, 1, 1, 2});
  BayerSolverInput input;
  input.mosaics = mosaic.pointers;
  input.cfa_channels = {0, 1, 3, 2};
  input.light_field = scene.light_field.get();
  PhotometricSolution solution;
  EXPECT_THAT([&] { SolvePhotometricStereoBayer(PhotometricSolverOptions(), input, &solution); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("cfa_channels[2] = 3")));
  input.cfa_channels = {0, 1, 1, 2};
  input.mosaics = InputFor(scene).images;  // RGB, not mosaics
  EXPECT_THAT([&] { SolvePhotometricStereoBayer(PhotometricSolverOptions(), input, &solution); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("mosaic 0 has 3 channels; 1 required")));
}

TEST(SolverOptionsTest, NewFieldsAreChecked) {
  PhotometricSolverOptions options;
  options.tile_size = 4;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("tile_size = 4 must lie in [8, 4096]")));
  options = PhotometricSolverOptions();
  options.light_tolerance = 0.5;
  EXPECT_THAT([&] { options.Check(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("light_tolerance")));
  options = PhotometricSolverOptions();
  options.robust_min_scale = 0;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("robust_min_scale = 0 must be finite and > 0")));
  options = PhotometricSolverOptions();
  options.robust_dark_fraction = 1;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("robust_dark_fraction = 1 must lie in [0, 1)")));
}

}  // namespace
}  // namespace scanbench
