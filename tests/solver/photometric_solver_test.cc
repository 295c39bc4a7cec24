#include "solver/photometric_solver.h"

#include <cmath>
#include <limits>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "solver/angular_error.h"
#include "solver/synthetic_scene.h"
#include "tests/util/eigen_matchers.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;

PhotometricSolverInput InputFor(const SyntheticScene& scene) {
  PhotometricSolverInput input;
  input.images = scene.ImagePointers();
  input.light_field = scene.light_field.get();
  return input;
}

// Pixels where the noise-free Lambertian model holds exactly for every light.
ImageU8 ExactPixels(const SyntheticScene& scene) {
  ImageU8 mask = scene.fully_lit;
  for (size_t i = 0; i < mask.num_pixels(); ++i) mask.data()[i] &= scene.object.data()[i];
  return mask;
}

void ExpectNoNonFinite(const PhotometricSolution& solution) {
  for (const ImageF* image : {&solution.normal_in_table, &solution.albedo, &solution.condition_number,
                              &solution.residual}) {
    for (size_t i = 0; i < image->size(); ++i) ASSERT_TRUE(std::isfinite(image->data()[i])) << "at index " << i;
  }
}

struct AnalyticCase {
  SyntheticSceneOptions::Shape shape;
  SyntheticSceneOptions::Lights lights;
};

class AnalyticSceneTest : public ::testing::TestWithParam<AnalyticCase> {};

TEST_P(AnalyticSceneTest, NoiseFreeSolveRecoversNormalAndAlbedoExactly) {
  SyntheticSceneOptions scene_options;
  scene_options.shape = GetParam().shape;
  scene_options.lights = GetParam().lights;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  const ImageU8 exact = ExactPixels(scene);

  // Plain least squares and the default (grazing samples left out) are both exact.
  PhotometricSolverOptions plain;
  plain.method = PhotometricSolverOptions::Method::kJacobiSvd;
  plain.min_sample_value = 0;
  for (const PhotometricSolverOptions& options : {plain, PhotometricSolverOptions()}) {
    PhotometricSolution solution;
    const PhotometricSolverSummary summary = SolvePhotometricStereo(options, InputFor(scene), &solution);
    ASSERT_EQ(summary.termination, Termination::kSuccess) << summary.BriefReport();

    const ErrorStatistics angular = AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, exact);
    ASSERT_GT(angular.num_pixels, 1000u) << "the scene must have many exactly modelled pixels";
    EXPECT_LE(angular.max, 0.01) << "mean " << angular.mean;
    const ErrorStatistics albedo = AbsoluteError(solution.albedo, scene.albedo, exact);
    EXPECT_LE(albedo.max, 1e-5);
    for (size_t i = 0; i < exact.num_pixels(); ++i) {
      if (exact.data()[i]) {
        ASSERT_EQ(solution.status.data()[i], static_cast<uint8_t>(PixelStatus::kSolved));
        if (options.min_sample_value == 0) {
          ASSERT_EQ(solution.lights_used.data()[i], scene_options.num_lights);
        }
        ASSERT_LT(solution.residual.data()[i], 1e-5);
      }
    }
    ExpectNoNonFinite(solution);
  }
}

INSTANTIATE_TEST_SUITE_P(
    SphereAndTiltedPlane, AnalyticSceneTest,
    ::testing::Values(AnalyticCase{SyntheticSceneOptions::Shape::kSphere, SyntheticSceneOptions::Lights::kDistant},
                      AnalyticCase{SyntheticSceneOptions::Shape::kSphere, SyntheticSceneOptions::Lights::kNearField},
                      AnalyticCase{SyntheticSceneOptions::Shape::kTiltedPlane,
                                   SyntheticSceneOptions::Lights::kDistant},
                      AnalyticCase{SyntheticSceneOptions::Shape::kTiltedPlane,
                                   SyntheticSceneOptions::Lights::kNearField}),
    [](const ::testing::TestParamInfo<AnalyticCase>& param_info) {
      return std::string(param_info.param.shape == SyntheticSceneOptions::Shape::kSphere ? "Sphere" : "TiltedPlane") +
             (param_info.param.lights == SyntheticSceneOptions::Lights::kDistant ? "DistantLights" : "NearFieldLights");
    });

TEST(PhotometricSolverTest, ShadowedSamplesAreLeftOutUnlessAsked) {
  // A plane tilted beyond the low ring's elevation: some lights graze it from
  // behind and read exactly 0 there (attached shadow).
  SyntheticSceneOptions scene_options;
  scene_options.shape = SyntheticSceneOptions::Shape::kTiltedPlane;
  scene_options.tilt_degrees = 45;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  ASSERT_EQ(scene.fully_lit(64, 64), 0) << "the test needs shadowed samples";
  const Eigen::Vector3f truth(scene.normal_in_table(64, 64, 0), scene.normal_in_table(64, 64, 1),
                              scene.normal_in_table(64, 64, 2));
  auto normal_at_centre = [&](const PhotometricSolverOptions& options, int* lights_used) {
    PhotometricSolution solution;
    SolvePhotometricStereo(options, InputFor(scene), &solution);
    *lights_used = solution.lights_used(64, 64);
    return Eigen::Vector3f(solution.normal_in_table(64, 64, 0), solution.normal_in_table(64, 64, 1),
                           solution.normal_in_table(64, 64, 2));
  };
  int lights_used = 0;
  EXPECT_THAT(normal_at_centre(PhotometricSolverOptions(), &lights_used), testing::EigenNear(truth, 1e-5));
  EXPECT_LT(lights_used, 10);
  EXPECT_GE(lights_used, 3);

  // Plain least squares keeps the zeros and is pulled away from the truth.
  // (Since the default became adaptive, plain least squares has to be asked
  // for: adaptive would re-solve this pixel robustly.)
  PhotometricSolverOptions plain;
  plain.method = PhotometricSolverOptions::Method::kJacobiSvd;
  plain.min_sample_value = 0;
  const Eigen::Vector3f biased = normal_at_centre(plain, &lights_used);
  EXPECT_EQ(lights_used, 10);
  EXPECT_GT(std::acos(std::min(1.0f, biased.dot(truth))) * 180 / M_PI, 1.0);
}

TEST(PhotometricSolverTest, TiltedPlaneNormalMatchesTheTilt) {
  SyntheticSceneOptions scene_options;
  scene_options.shape = SyntheticSceneOptions::Shape::kTiltedPlane;
  scene_options.tilt_degrees = 25;  // below the low ring elevation: no attached shadow
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolution solution;
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  const double tilt = 25 * M_PI / 180;
  const Eigen::Vector3f normal(solution.normal_in_table(64, 64, 0), solution.normal_in_table(64, 64, 1),
                               solution.normal_in_table(64, 64, 2));
  EXPECT_THAT(normal, testing::EigenNear(Eigen::Vector3f(0, -std::sin(tilt), std::cos(tilt)), 1e-6));
}

TEST(PhotometricSolverTest, NoisySolveStaysCloseAndFinite) {
  SyntheticSceneOptions scene_options;
  scene_options.noise_stddev = 0.002;  // about 0.5 % of a mid-grey sample
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolution solution;
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  const ErrorStatistics angular =
      AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, ExactPixels(scene));
  EXPECT_LT(angular.mean, 0.5);
  EXPECT_GT(angular.mean, 0.001) << "noise must show in the error";
  ExpectNoNonFinite(solution);
}

TEST(PhotometricSolverTest, RegionLimitsTheWork) {
  const SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  PhotometricSolverInput input = InputFor(scene);
  ImageU8 region(128, 128, 1, 0);
  for (int y = 10; y < 20; ++y) {
    for (int x = 30; x < 50; ++x) region(x, y) = 1;
  }
  input.region = &region;
  PhotometricSolution solution;
  const PhotometricSolverSummary summary = SolvePhotometricStereo(PhotometricSolverOptions(), input, &solution);
  EXPECT_EQ(summary.num_solved() + summary.pixels_by_status[static_cast<int>(PixelStatus::kFacingAway)] +
                summary.pixels_by_status[static_cast<int>(PixelStatus::kNoSignal)],
            200u);
  EXPECT_EQ(summary.pixels_by_status[static_cast<int>(PixelStatus::kOutsideRegion)], 128u * 128u - 200u);
  EXPECT_EQ(solution.status(0, 0), static_cast<uint8_t>(PixelStatus::kOutsideRegion));
  EXPECT_EQ(solution.normal_in_table(0, 0, 2), 1.0f);
}

TEST(PhotometricSolverTest, TooFewValidSamplesIsFlaggedNotNaN) {
  const SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  PhotometricSolverInput input = InputFor(scene);
  // Only two lights usable at pixel (64, 64): clipped everywhere else.
  std::vector<ImageU8> valid(scene.images.size(), ImageU8(128, 128, 1, 1));
  for (size_t k = 2; k < valid.size(); ++k) valid[k](64, 64) = 0;
  for (const ImageU8& mask : valid) input.sample_valid.push_back(&mask);
  PhotometricSolution solution;
  SolvePhotometricStereo(PhotometricSolverOptions(), input, &solution);
  EXPECT_EQ(solution.status(64, 64), static_cast<uint8_t>(PixelStatus::kTooFewLights));
  EXPECT_EQ(solution.lights_used(64, 64), 2);
  EXPECT_EQ(solution.status(63, 64), static_cast<uint8_t>(PixelStatus::kSolved));
  ExpectNoNonFinite(solution);
}

TEST(PhotometricSolverTest, NonFiniteSamplesAreLeftOut) {
  const SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  SyntheticScene corrupted = MakeSyntheticScene(SyntheticSceneOptions());
  corrupted.images[0](64, 64, 0) = std::numeric_limits<float>::quiet_NaN();
  corrupted.images[1](64, 64, 1) = std::numeric_limits<float>::infinity();
  PhotometricSolution solution;
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(corrupted), &solution);
  EXPECT_EQ(solution.status(64, 64), static_cast<uint8_t>(PixelStatus::kSolved));
  EXPECT_EQ(solution.lights_used(64, 64), 8);
  const Eigen::Vector3f normal(solution.normal_in_table(64, 64, 0), solution.normal_in_table(64, 64, 1),
                               solution.normal_in_table(64, 64, 2));
  const Eigen::Vector3f truth(scene.normal_in_table(64, 64, 0), scene.normal_in_table(64, 64, 1),
                              scene.normal_in_table(64, 64, 2));
  EXPECT_THAT(normal, testing::EigenNear(truth, 1e-5));
  ExpectNoNonFinite(solution);
}

TEST(PhotometricSolverTest, CoincidentLightsAreIllConditioned) {
  SyntheticSceneOptions scene_options;
  scene_options.num_lights = 4;
  scene_options.min_elevation_deg = 45;
  scene_options.max_elevation_deg = 45;
  SyntheticScene scene = MakeSyntheticScene(scene_options);
  // All four lights from one direction: the system has rank 1.
  const Eigen::Vector3d dir(0.5, 0.5, std::sqrt(0.5));
  scene.light_field = std::make_unique<DirectionalLightField>(
      128, 128, std::vector<Eigen::Vector3d>(4, dir), std::vector<Eigen::Vector3d>(4, Eigen::Vector3d::Ones()));
  PhotometricSolverOptions options;
  options.min_sample_value = 0;  // keep the dim samples: the rank is what is tested
  PhotometricSolution solution;
  const PhotometricSolverSummary summary = SolvePhotometricStereo(options, InputFor(scene), &solution);
  EXPECT_EQ(summary.pixels_by_status[static_cast<int>(PixelStatus::kIllConditioned)], 128u * 128u);
  ExpectNoNonFinite(solution);
}

TEST(PhotometricSolverTest, BlackSurfaceHasNoSignal) {
  SyntheticSceneOptions scene_options;
  scene_options.albedo = Eigen::Vector3d::Zero();
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverOptions plain;
  plain.min_sample_value = 0;
  PhotometricSolution solution;
  const PhotometricSolverSummary summary = SolvePhotometricStereo(plain, InputFor(scene), &solution);
  EXPECT_EQ(summary.pixels_by_status[static_cast<int>(PixelStatus::kNoSignal)], 128u * 128u);
  EXPECT_EQ(summary.num_solved(), 0u);
  ExpectNoNonFinite(solution);
  // By default every sample of a black surface reads as shadow.
  const PhotometricSolverSummary by_default =
      SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  EXPECT_EQ(by_default.pixels_by_status[static_cast<int>(PixelStatus::kTooFewLights)], 128u * 128u);
  ExpectNoNonFinite(solution);
}

TEST(PhotometricSolverTest, ProgressReachesOneAndCancelStops) {
  SyntheticSceneOptions scene_options;
  scene_options.width = 256;
  scene_options.height = 256;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  double last = -1;
  PhotometricSolution solution;
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution, [&](double fraction) {
    EXPECT_GE(fraction, last);
    last = fraction;
    return true;
  });
  EXPECT_EQ(last, 1.0);

  const PhotometricSolverSummary cancelled =
      SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution, [](double) { return false; });
  EXPECT_EQ(cancelled.termination, Termination::kCancelled);
  EXPECT_LT(cancelled.num_solved(), 256u * 256u);
  EXPECT_THAT(cancelled.message, HasSubstr("cancelled"));
}

TEST(PhotometricSolverTest, SingleAndManyThreadsAgree) {
  const SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  PhotometricSolverOptions options;
  options.num_threads = 1;
  options.tile_size = 32;  // 16 tiles: threads are capped at the number of tiles
  PhotometricSolution one, many;
  SolvePhotometricStereo(options, InputFor(scene), &one);
  options.num_threads = 4;
  const PhotometricSolverSummary summary = SolvePhotometricStereo(options, InputFor(scene), &many);
  EXPECT_EQ(summary.num_threads, 4);
  for (size_t i = 0; i < one.normal_in_table.size(); ++i) {
    ASSERT_EQ(one.normal_in_table.data()[i], many.normal_in_table.data()[i]);
  }
}

// A solution solved into again keeps its images where they have the right
// shape (filled in place) and must end up exactly as a fresh one: here after
// a whole-image adaptive solve (specular maps filled), a normal_equations
// solve within a region (no specular maps; outside pixels not solved again).
TEST(PhotometricSolverTest, SolvingIntoAnEarlierSolutionGivesAFreshSolvesMaps) {
  const SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  PhotometricSolverInput input = InputFor(scene);
  PhotometricSolution reused;
  PhotometricSolverOptions options;
  options.num_threads = 1;
  SolvePhotometricStereo(options, input, &reused);
  ASSERT_FALSE(reused.specular.empty());
  const float* normal_data = reused.normal_in_table.data();
  ImageU8 region(128, 128, 1, 0);
  for (int y = 10; y < 90; ++y) {
    for (int x = 30; x < 110; ++x) region(x, y) = 1;
  }
  input.region = &region;
  options.method = PhotometricSolverOptions::Method::kNormalEquations;
  PhotometricSolution fresh;
  const PhotometricSolverSummary summary = SolvePhotometricStereo(options, input, &fresh);
  const PhotometricSolverSummary again = SolvePhotometricStereo(options, input, &reused);
  EXPECT_EQ(reused.normal_in_table.data(), normal_data) << "the normal image was not reused";
  EXPECT_TRUE(reused.specular.empty());
  EXPECT_TRUE(reused.specular_status.empty());
  EXPECT_EQ(again.pixels_by_status, summary.pixels_by_status);
  EXPECT_GT(summary.pixels_by_status[static_cast<int>(PixelStatus::kOutsideRegion)], 0u);
  auto expect_equal = [](const auto& a, const auto& b, const char* what) {
    ASSERT_EQ(a.size(), b.size()) << what;
    for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a.data()[i], b.data()[i]) << what << " at index " << i;
  };
  expect_equal(fresh.normal_in_table, reused.normal_in_table, "normal");
  expect_equal(fresh.albedo, reused.albedo, "albedo");
  expect_equal(fresh.condition_number, reused.condition_number, "condition");
  expect_equal(fresh.residual, reused.residual, "residual");
  expect_equal(fresh.status, reused.status, "status");
  expect_equal(fresh.lights_used, reused.lights_used, "lights_used");
  expect_equal(fresh.solve_path, reused.solve_path, "solve_path");
}

TEST(PhotometricSolverTest, OptionsCheckNamesTheField) {
  PhotometricSolverOptions options;
  options.min_lights = 2;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("min_lights = 2 must lie in [3, 1000]")));
  options = PhotometricSolverOptions();
  options.max_condition_number = 0.5;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("max_condition_number")));
  options = PhotometricSolverOptions();
  options.luminance_weights = {0, 0, 0};
  EXPECT_THAT([&] { options.Check(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("sum to > 0")));
}

TEST(PhotometricSolverTest, MismatchedInputIsRejectedBeforeWork) {
  const SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  PhotometricSolverInput input = InputFor(scene);
  input.images.pop_back();
  PhotometricSolution solution;
  EXPECT_THAT([&] { SolvePhotometricStereo(PhotometricSolverOptions(), input, &solution); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("9 images but the light field has 10")));
  ImageF wrong_size(64, 64, 3);
  input = InputFor(scene);
  input.images[3] = &wrong_size;
  EXPECT_THAT([&] { SolvePhotometricStereo(PhotometricSolverOptions(), input, &solution); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("image 3 is 64x64")));
}

}  // namespace
}  // namespace scanbench
