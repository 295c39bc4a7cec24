// Stiff and extreme inputs. Each test states the expected behaviour and
// asserts it: an error bound, a flag in the status map, and never a NaN.
#include <cmath>
#include <limits>
#include <memory>

#include <Eigen/Dense>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "solver/angular_error.h"
#include "solver/photometric_solver.h"
#include "solver/pixel_solvers.h"
#include "solver/synthetic_scene.h"
#include "tests/solver/solver_test_util.h"

namespace scanbench {
namespace {

using Method = PhotometricSolverOptions::Method;
using testing::AngleDegrees;
using testing::CountStatus;
using testing::ExactPixels;
using testing::ExpectAllFinite;
using testing::InputFor;
using testing::NormalAt;

// Replaces the scene's lights by white distant lights from `dirs` and
// re-renders its images (Lambertian, noise-free).
void RelightDistant(const std::vector<Eigen::Vector3d>& dirs, const Eigen::Vector3d& albedo, SyntheticScene* scene) {
  const int width = scene->normal_in_table.width(), height = scene->normal_in_table.height();
  scene->light_field = std::make_unique<DirectionalLightField>(width, height, dirs,
                                                               std::vector<Eigen::Vector3d>(dirs.size(), Eigen::Vector3d::Ones()));
  scene->images.assign(dirs.size(), ImageF(width, height, 3));
  for (size_t k = 0; k < dirs.size(); ++k) {
    const Eigen::Vector3d dir = dirs[k].normalized();
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const double shading = std::max(0.0, NormalAt(scene->normal_in_table, x, y).dot(dir));
        for (int c = 0; c < 3; ++c) scene->images[k](x, y, c) = float(albedo[c] * shading);
      }
    }
  }
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      bool lit = true;
      for (const Eigen::Vector3d& dir : dirs) lit = lit && NormalAt(scene->normal_in_table, x, y).dot(dir) > 0;
      scene->fully_lit(x, y) = lit;
    }
  }
}

SyntheticSceneOptions FlatPlane() {
  SyntheticSceneOptions options;
  options.shape = SyntheticSceneOptions::Shape::kTiltedPlane;
  options.tilt_degrees = 0;
  options.width = options.height = 32;
  return options;
}

// Lights on one ring at 5 deg elevation (nearly coplanar with the sample):
// condition number about 8, still solved exactly without noise; with noise the
// error grows by about that factor but stays bounded.
TEST(StiffCasesTest, LowElevationLightsAreSolvedWithBoundedError) {
  SyntheticSceneOptions scene_options = FlatPlane();
  scene_options.min_elevation_deg = scene_options.max_elevation_deg = 5;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolution solution;
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  EXPECT_EQ(CountStatus(solution, PixelStatus::kSolved), 32u * 32u);
  EXPECT_NEAR(solution.condition_number(16, 16), 1 / (std::sqrt(2.0) * std::tan(5 * M_PI / 180)), 0.05);
  EXPECT_LE(AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, {}).max, 0.01);

  scene_options.noise_stddev = 0.001;
  const SyntheticScene noisy = MakeSyntheticScene(scene_options);
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(noisy), &solution);
  EXPECT_LT(AngularErrorDegrees(solution.normal_in_table, noisy.normal_in_table, {}).mean, 2.0);
  ExpectAllFinite(solution);
}

// At 0.2 deg elevation the light matrix is near rank 2 (condition ~200 > 100):
// every pixel is flagged ill-conditioned, with its condition number stored.
TEST(StiffCasesTest, GrazingCoplanarLightsAreFlaggedIllConditioned) {
  SyntheticSceneOptions scene_options = FlatPlane();
  scene_options.min_elevation_deg = scene_options.max_elevation_deg = 0.2;
  scene_options.albedo = {1, 1, 1};
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  for (Method method :
       {Method::kAdaptive, Method::kJacobiSvd, Method::kQr, Method::kNormalEquations, Method::kDiffuseLobe}) {
    PhotometricSolverOptions options;
    options.method = method;
    options.min_sample_value = 0;  // keep the dim samples: the geometry is what is tested
    PhotometricSolution solution;
    SolvePhotometricStereo(options, InputFor(scene), &solution);
    EXPECT_EQ(CountStatus(solution, PixelStatus::kIllConditioned), 32u * 32u) << PhotometricMethodName(method);
    EXPECT_GT(solution.condition_number(3, 3), 100.0);
    EXPECT_EQ(NormalAt(solution.normal_in_table, 3, 3), Eigen::Vector3d::UnitZ());
    ExpectAllFinite(solution);
  }
}

// All lights within a narrow cone around the camera axis.
TEST(StiffCasesTest, NarrowConeIsSolvedWhenWideEnoughAndFlaggedWhenNot) {
  SyntheticSceneOptions scene_options = FlatPlane();
  scene_options.min_elevation_deg = scene_options.max_elevation_deg = 80;  // 10 deg cone: condition ~8
  SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolution solution;
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  EXPECT_EQ(CountStatus(solution, PixelStatus::kSolved), 32u * 32u);
  EXPECT_LE(AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, {}).max, 0.01);

  scene_options.min_elevation_deg = scene_options.max_elevation_deg = 89.5;  // 0.5 deg cone: condition ~160
  scene = MakeSyntheticScene(scene_options);
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  EXPECT_EQ(CountStatus(solution, PixelStatus::kIllConditioned), 32u * 32u);
  ExpectAllFinite(solution);
}

// Exactly three lights: the system is square; exact where all three light the
// surface, flagged too-few-lights where one is behind it.
TEST(StiffCasesTest, ExactlyThreeLights) {
  SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  RelightDistant({{0.5, 0, 0.866}, {-0.25, 0.433, 0.866}, {-0.25, -0.433, 0.866}}, {0.6, 0.45, 0.3}, &scene);
  for (Method method : AllPhotometricMethods()) {
    PhotometricSolverOptions options;
    options.method = method;
    PhotometricSolution solution;
    SolvePhotometricStereo(options, InputFor(scene), &solution);
    ExpectAllFinite(solution);
    // The network is not exact (tests/solver/learned_kernel_test.cc holds it to its own figures).
    if (method == Method::kLearned) continue;
    // Exact where all three samples are above the shadow level; where one
    // is at or below it (grazing), too few lights are left.
    ImageU8 exact = ExactPixels(scene);
    for (size_t i = 0; i < exact.num_pixels(); ++i) {
      if (!exact.data()[i] || solution.status.data()[i] == uint8_t(PixelStatus::kSolved)) continue;
      EXPECT_EQ(solution.status.data()[i], uint8_t(PixelStatus::kTooFewLights));
      exact.data()[i] = 0;
    }
    EXPECT_LE(AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, exact).max, 0.01)
        << PhotometricMethodName(method);
    EXPECT_EQ(solution.lights_used(64, 64), 3);
    EXPECT_LT(solution.residual(64, 64), 1e-5);
    EXPECT_GT(CountStatus(solution, PixelStatus::kTooFewLights), 0u) << "the sphere's rim sees fewer than 3";
    ExpectAllFinite(solution);
  }
}

// Duplicated light directions add no information but do no harm.
TEST(StiffCasesTest, DuplicatedLightDirections) {
  SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  std::vector<Eigen::Vector3d> dirs = RingLightDirections(5, 30, 60);
  for (int k = 0; k < 5; ++k) dirs.push_back(dirs[k]);
  RelightDistant(dirs, {0.6, 0.45, 0.3}, &scene);
  PhotometricSolution solution;
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  EXPECT_LE(AngleDegrees(NormalAt(solution.normal_in_table, 64, 64), NormalAt(scene.normal_in_table, 64, 64)), 0.01);
  EXPECT_EQ(solution.lights_used(64, 64), 10);
  ExpectAllFinite(solution);
}

// Black velvet (albedo 0.0015): every sample is at shadow level, so by default
// the pixels are flagged; with the shadow level lowered they solve exactly.
// White (albedo 1): exact, albedo 1.
TEST(StiffCasesTest, AlbedoNearZeroAndNearOne) {
  SyntheticSceneOptions scene_options;
  scene_options.albedo = {0.0015, 0.0015, 0.0015};
  SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolution solution;
  const PhotometricSolverSummary summary =
      SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  EXPECT_EQ(summary.pixels_by_status[int(PixelStatus::kTooFewLights)], summary.num_pixels);
  ExpectAllFinite(solution);
  PhotometricSolverOptions low_shadow_level;
  low_shadow_level.min_sample_value = 1e-6;
  SolvePhotometricStereo(low_shadow_level, InputFor(scene), &solution);
  EXPECT_LE(AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, ExactPixels(scene)).max, 0.01);
  EXPECT_NEAR(solution.albedo(64, 64, 1), 0.0015, 1e-6);

  scene_options.albedo = {1, 1, 1};
  scene = MakeSyntheticScene(scene_options);
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  EXPECT_LE(AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, ExactPixels(scene)).max, 0.01);
  EXPECT_LE(AbsoluteError(solution.albedo, scene.albedo, ExactPixels(scene)).max, 1e-4);
}

// 16-bit quantisation at both ends of the range: a dark sample (about 1 % of
// full scale) keeps its error small; a bright one clips at full scale, and the
// clipped samples marked in sample_valid are left out.
TEST(StiffCasesTest, SixteenBitDynamicRangeExtremes) {
  auto quantise = [](SyntheticScene* scene, std::vector<ImageU8>* valid) {
    valid->assign(scene->images.size(), ImageU8(scene->images[0].width(), scene->images[0].height(), 1, 1));
    for (size_t k = 0; k < scene->images.size(); ++k) {
      ImageF& image = scene->images[k];
      for (int y = 0; y < image.height(); ++y) {
        for (int x = 0; x < image.width(); ++x) {
          for (int c = 0; c < 3; ++c) {
            const double dn = std::round(std::clamp(double(image(x, y, c)), 0.0, 1.0) * 65535);
            if (dn >= 65535) (*valid)[k](x, y) = 0;
            image(x, y, c) = float(dn / 65535);
          }
        }
      }
    }
  };
  SyntheticSceneOptions scene_options;
  scene_options.albedo = {0.02, 0.02, 0.02};
  SyntheticScene dark = MakeSyntheticScene(scene_options);
  std::vector<ImageU8> valid;
  quantise(&dark, &valid);
  PhotometricSolverOptions low_shadow_level;
  low_shadow_level.min_sample_value = 2.0 / 65535;
  PhotometricSolution solution;
  SolvePhotometricStereo(low_shadow_level, InputFor(dark), &solution);
  EXPECT_LT(AngularErrorDegrees(solution.normal_in_table, dark.normal_in_table, ExactPixels(dark)).mean, 0.1);

  scene_options.albedo = {1, 1, 1};
  scene_options.specular = 0.8;  // highlights above full scale
  SyntheticScene bright = MakeSyntheticScene(scene_options);
  quantise(&bright, &valid);
  PhotometricSolverInput input = InputFor(bright);
  for (const ImageU8& mask : valid) input.sample_valid.push_back(&mask);
  size_t clipped = 0;
  for (const ImageU8& mask : valid) {
    for (size_t i = 0; i < mask.num_pixels(); ++i) clipped += mask.data()[i] == 0;
  }
  ASSERT_GT(clipped, 100u) << "the test needs clipped samples";
  SolvePhotometricStereo(PhotometricSolverOptions(), input, &solution);
  EXPECT_LT(AngularErrorDegrees(solution.normal_in_table, bright.normal_in_table, bright.object).mean, 0.5);
  ExpectAllFinite(solution);
}

// The specular-lobe methods (diffuse_lobe and the default adaptive, whose
// robust pass fits the lobe) on a strong, sharp highlight with only 10 lights
// on two rings: finite, well below least squares' error,
// and specular maps that agree with the status map (values only where
// estimated, F0 in [0, 1], alpha in (0, 1]).
TEST(StiffCasesTest, StrongSpecularHighlightWithTenLights) {
  SyntheticSceneOptions scene_options;
  scene_options.num_lights = 10;
  scene_options.specular = 1.0;
  scene_options.shininess = 80;
  scene_options.noise_stddev = 0.001;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverOptions lsq;
  lsq.method = Method::kJacobiSvd;
  PhotometricSolution solution;
  SolvePhotometricStereo(lsq, InputFor(scene), &solution);
  const double lsq_error = AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, scene.object).mean;
  ASSERT_GT(lsq_error, 2.0) << "the highlight must bias least squares for the test to mean anything";
  for (Method method : {Method::kAdaptive, Method::kDiffuseLobe}) {
    PhotometricSolverOptions options;
    options.method = method;
    const PhotometricSolverSummary summary = SolvePhotometricStereo(options, InputFor(scene), &solution);
    ExpectAllFinite(solution);
    const double error = AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, scene.object).mean;
    EXPECT_LT(error, 0.35 * lsq_error) << PhotometricMethodName(method) << ", least squares " << lsq_error;
    EXPECT_LT(error, 1.5) << PhotometricMethodName(method);
    ASSERT_EQ(solution.specular.channels(), 2);
    ASSERT_TRUE(solution.specular_status.SameSize(solution.status.width(), solution.status.height()));
    size_t estimated = 0;
    for (size_t i = 0; i < solution.status.num_pixels(); ++i) {
      const auto status = SpecularStatus(solution.specular_status.data()[i]);
      const bool solved = solution.status.data()[i] == uint8_t(PixelStatus::kSolved);
      EXPECT_EQ(status == SpecularStatus::kNotSolved, !solved) << "pixel " << i;
      const float f0 = solution.specular.data()[2 * i], alpha = solution.specular.data()[2 * i + 1];
      if (status == SpecularStatus::kEstimated) {
        ++estimated;
        EXPECT_TRUE(f0 >= 0 && f0 <= 1) << f0;
        EXPECT_TRUE(alpha > 0 && alpha <= 1) << alpha;
      } else {
        EXPECT_EQ(f0, 0.0f);
        EXPECT_EQ(alpha, 0.0f);
      }
    }
    EXPECT_GT(estimated, 100u) << PhotometricMethodName(method);
    EXPECT_EQ(summary.pixels_by_specular[int(SpecularStatus::kEstimated)], estimated);
  }
}

// A velvet sheen (the seed's cloth BRDF: white F0 0.05, width 0.9) on a dark
// blue sphere under the rig's two rings: its smooth bias stays under the
// residual trigger; the per-pixel sheen pass (adaptive_sheen) and the shared
// sheen (adaptive_coherent_sheen, the default) each remove most of it; on
// the Lambertian scene the per-pixel pass changes next to nothing and the
// shared one nothing at all.
TEST(StiffCasesTest, VelvetSheenWithTenLights) {
  SyntheticSceneOptions scene_options;
  scene_options.num_lights = 10;
  scene_options.albedo = {0.08, 0.10, 0.30};
  scene_options.noise_stddev = 0.0003;
  const SyntheticScene lambert = MakeSyntheticScene(scene_options);
  SyntheticScene velvet = MakeSyntheticScene(scene_options);
  const int width = velvet.normal_in_table.width(), height = velvet.normal_in_table.height();
  const int num_lights = velvet.light_field->num_lights();
  std::vector<float> dirs(3 * num_lights), intensities(3 * num_lights);
  const Eigen::Vector3d view = Eigen::Vector3d::UnitZ();
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      velvet.light_field->Evaluate(x, y, dirs.data(), intensities.data());
      const Eigen::Vector3d n = NormalAt(velvet.normal_in_table, x, y);
      for (int k = 0; k < num_lights; ++k) {
        const Eigen::Vector3d l(dirs[3 * k], dirs[3 * k + 1], dirs[3 * k + 2]);
        const double sheen = 0.05 * VelvetSheenShape(n, l, (l + view).normalized(), view, 0.9);
        for (int c = 0; c < 3; ++c) velvet.images[k](x, y, c) += float(sheen * intensities[3 * k + c]);
      }
    }
  }
  auto mean_error = [](const SyntheticScene& scene, bool sheen, PhotometricSolution* solution,
                       bool coherent_sheen = false) {
    PhotometricSolverOptions options;
    options.adaptive_sheen = sheen;
    options.adaptive_coherent_sheen = coherent_sheen;
    SolvePhotometricStereo(options, InputFor(scene), solution);
    ExpectAllFinite(*solution);
    return AngularErrorDegrees(solution->normal_in_table, scene.normal_in_table, scene.object).mean;
  };
  PhotometricSolution solution;
  const double before = mean_error(velvet, false, &solution);
  ASSERT_GT(before, 0.5) << "the sheen must bias the default for the test to mean anything";
  const double after = mean_error(velvet, true, &solution);
  EXPECT_LT(after, 0.5 * before) << "default " << before;
  size_t sheen_pixels = 0;
  for (size_t i = 0; i < solution.status.num_pixels(); ++i) {
    sheen_pixels += solution.solve_path.data()[i] == uint8_t(SolvePath::kRobust);
  }
  EXPECT_GT(sheen_pixels, solution.status.num_pixels() / 4);
  const double lambert_before = mean_error(lambert, false, &solution);
  const double lambert_after = mean_error(lambert, true, &solution);
  EXPECT_LT(lambert_after, lambert_before + 0.02);
  // The shared sheen (the default): it leaves every pixel solved that least squares solved.
  mean_error(velvet, false, &solution);
  const size_t solved = testing::CountStatus(solution, PixelStatus::kSolved);
  const double shared = mean_error(velvet, false, &solution, true);
  EXPECT_LT(shared, 0.5 * before) << "default without it " << before;
  EXPECT_EQ(testing::CountStatus(solution, PixelStatus::kSolved), solved);
  EXPECT_EQ(mean_error(lambert, false, &solution, true), lambert_before);
}

// Saturated highlights that are not marked: the adaptive robust pass still
// rejects them (clipped samples read far too bright for the Lambertian fit).
TEST(StiffCasesTest, SaturatedHighlightsWithoutMask) {
  SyntheticSceneOptions scene_options;
  scene_options.specular = 1.5;
  scene_options.shininess = 100;
  scene_options.num_lights = 16;
  SyntheticScene scene = MakeSyntheticScene(scene_options);
  for (ImageF& image : scene.images) {
    for (size_t i = 0; i < image.size(); ++i) image.data()[i] = std::min(image.data()[i], 1.0f);
  }
  PhotometricSolverOptions lsq;
  lsq.method = Method::kJacobiSvd;
  PhotometricSolution solution;
  SolvePhotometricStereo(lsq, InputFor(scene), &solution);
  const double lsq_error = AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, scene.object).mean;
  size_t clipped = 0;
  for (const ImageF& image : scene.images) clipped += std::count(image.data(), image.data() + image.size(), 1.0f);
  ASSERT_GT(clipped, 300u);
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  const double error = AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, scene.object).mean;
  EXPECT_LT(error, 0.25 * lsq_error) << "least squares " << lsq_error;
  EXPECT_LT(error, 1.0);
  ExpectAllFinite(solution);
}

// Attached shadows at grazing normals (the sphere's rim): samples from behind
// read 0 and are left out; pixels with >= 3 lit samples solve exactly, the
// others are flagged. Plain least squares keeps the zeros and is biased.
TEST(StiffCasesTest, AttachedShadowsAtGrazingNormals) {
  const SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  ImageU8 rim(128, 128, 1, 0);
  size_t rim_pixels = 0;
  for (int y = 0; y < 128; ++y) {
    for (int x = 0; x < 128; ++x) {
      rim(x, y) = scene.object(x, y) && scene.normal_in_table(x, y, 2) < 0.35 && !scene.fully_lit(x, y);
      rim_pixels += rim(x, y);
    }
  }
  ASSERT_GT(rim_pixels, 200u);
  PhotometricSolution solution;
  SolvePhotometricStereo(PhotometricSolverOptions(), InputFor(scene), &solution);
  ImageU8 solved_rim = rim;
  for (size_t i = 0; i < rim.num_pixels(); ++i) {
    const uint8_t status = solution.status.data()[i];
    if (!rim.data()[i]) continue;
    EXPECT_TRUE(status == uint8_t(PixelStatus::kSolved) || status == uint8_t(PixelStatus::kTooFewLights));
    solved_rim.data()[i] = status == uint8_t(PixelStatus::kSolved);
  }
  EXPECT_LE(AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, solved_rim).max, 0.01);
  PhotometricSolverOptions plain;
  plain.method = Method::kJacobiSvd;
  plain.min_sample_value = 0;
  SolvePhotometricStereo(plain, InputFor(scene), &solution);
  EXPECT_GT(AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, solved_rim).mean, 1.0);
  ExpectAllFinite(solution);
}

class NanAtOnePixelField final : public LightField {
 public:
  explicit NanAtOnePixelField(const LightField& base) : base_(base) {}
  int num_lights() const override { return base_.num_lights(); }
  int width() const override { return base_.width(); }
  int height() const override { return base_.height(); }
  void Evaluate(int x, int y, float* dirs, float* intensities) const override {
    base_.Evaluate(x, y, dirs, intensities);
    if (x == 40 && y == 50) dirs[4] = std::numeric_limits<float>::quiet_NaN();
  }

 private:
  const LightField& base_;
};

// NaN, infinite and negative samples are left out (a negative one is below
// the shadow level); a non-finite light value flags the pixel invalid_input.
TEST(StiffCasesTest, NonFiniteAndNegativeSamplesAndLights) {
  const SyntheticScene clean = MakeSyntheticScene(SyntheticSceneOptions());
  SyntheticScene scene = MakeSyntheticScene(SyntheticSceneOptions());
  scene.images[0](64, 64, 0) = std::numeric_limits<float>::quiet_NaN();
  scene.images[1](64, 64, 1) = std::numeric_limits<float>::infinity();
  scene.images[2](64, 64, 2) = -std::numeric_limits<float>::infinity();
  scene.images[3](64, 64, 0) = -0.5f;
  scene.images[3](64, 64, 1) = -0.5f;
  scene.images[3](64, 64, 2) = -0.5f;
  for (Method method : AllPhotometricMethods()) {
    PhotometricSolverOptions options;
    options.method = method;
    PhotometricSolution solution;
    SolvePhotometricStereo(options, InputFor(scene), &solution);
    EXPECT_EQ(solution.status(64, 64), uint8_t(PixelStatus::kSolved)) << PhotometricMethodName(method);
    if (method == Method::kLearned) {
      // Not exact: near the clean normal, and nothing non-finite from the bad samples.
      EXPECT_LE(AngleDegrees(NormalAt(solution.normal_in_table, 64, 64), NormalAt(clean.normal_in_table, 64, 64)), 5.0);
      ExpectAllFinite(solution);
      continue;
    }
    EXPECT_EQ(solution.lights_used(64, 64), 6);
    EXPECT_LE(AngleDegrees(NormalAt(solution.normal_in_table, 64, 64), NormalAt(clean.normal_in_table, 64, 64)), 0.01);
    ExpectAllFinite(solution);
  }
  // Shadow level 0 keeps the negative sample: biased, but finite.
  PhotometricSolverOptions keep_all;
  keep_all.method = Method::kJacobiSvd;
  keep_all.min_sample_value = 0;
  PhotometricSolution solution;
  SolvePhotometricStereo(keep_all, InputFor(scene), &solution);
  EXPECT_EQ(solution.lights_used(64, 64), 7);
  ExpectAllFinite(solution);

  // The per-pixel methods evaluate the light at every pixel and flag it;
  // adaptive evaluates it at grid nodes only (the field is smooth by
  // construction), so it either flags the pixel or solves it from the
  // interpolated lights: finite either way.
  const NanAtOnePixelField field(*scene.light_field);
  PhotometricSolverInput input = InputFor(clean);
  input.light_field = &field;
  for (Method method : AllPhotometricMethods()) {
    if (method == Method::kUniformPseudoInverse) continue;  // not a uniform field
    PhotometricSolverOptions options;
    options.method = method;
    SolvePhotometricStereo(options, input, &solution);
    if (method == Method::kAdaptive) {
      EXPECT_TRUE(solution.status(40, 50) == uint8_t(PixelStatus::kInvalidInput) ||
                  solution.status(40, 50) == uint8_t(PixelStatus::kSolved));
    } else {
      EXPECT_EQ(solution.status(40, 50), uint8_t(PixelStatus::kInvalidInput)) << PhotometricMethodName(method);
    }
    EXPECT_EQ(solution.status(41, 50), uint8_t(PixelStatus::kSolved));
    ExpectAllFinite(solution);
  }
}

// Float inputs, double arithmetic: the solver agrees with a double-precision
// SVD of the same (float) samples and lights to 1e-4 deg, even where the
// light matrix is poorly conditioned (lights at 8 deg elevation, noisy).
TEST(StiffCasesTest, FloatInputsMatchADoubleReference) {
  SyntheticSceneOptions scene_options;
  scene_options.min_elevation_deg = scene_options.max_elevation_deg = 8;
  scene_options.noise_stddev = 0.002;
  scene_options.shape = SyntheticSceneOptions::Shape::kTiltedPlane;
  scene_options.tilt_degrees = 5;
  scene_options.width = scene_options.height = 16;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  const int num_lights = scene_options.num_lights;
  std::vector<float> dirs(3 * num_lights), intensities(3 * num_lights);
  for (Method method : {Method::kAdaptive, Method::kJacobiSvd, Method::kQr, Method::kNormalEquations,
                        Method::kUniformPseudoInverse}) {
    PhotometricSolverOptions options;
    options.method = method;
    options.min_sample_value = 0;
    options.adaptive_robust_residual = 1e9;  // the least-squares part is compared
    PhotometricSolution solution;
    SolvePhotometricStereo(options, InputFor(scene), &solution);
    double worst = 0;
    for (int y = 0; y < 16; ++y) {
      for (int x = 0; x < 16; ++x) {
        scene.light_field->Evaluate(x, y, dirs.data(), intensities.data());
        Eigen::MatrixXd lights(num_lights, 3);
        Eigen::VectorXd luminance(num_lights);
        for (int k = 0; k < num_lights; ++k) {
          lights.row(k) << dirs[3 * k], dirs[3 * k + 1], dirs[3 * k + 2];
          double value = 0;
          for (int c = 0; c < 3; ++c) {
            value += options.luminance_weights[c] * double(scene.images[k](x, y, c)) / double(intensities[3 * k + c]);
          }
          luminance[k] = value;
        }
        const Eigen::Vector3d reference = lights.jacobiSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(luminance);
        worst = std::max(worst, AngleDegrees(NormalAt(solution.normal_in_table, x, y), reference));
      }
    }
    EXPECT_LE(worst, 1e-4) << PhotometricMethodName(method);
  }
}

}  // namespace
}  // namespace scanbench
