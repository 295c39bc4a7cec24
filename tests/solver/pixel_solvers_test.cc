// The per-pixel dense solves on hand-made samples.
#include "solver/pixel_solvers.h"

#include <cmath>
#include <limits>
#include <random>

#include <Eigen/SVD>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "solver/synthetic_scene.h"
#include "tests/solver/solver_test_util.h"

namespace scanbench {
namespace {

using testing::AngleDegrees;

// Samples of a Lambertian pixel with scaled normal `scaled` under `dirs`, with
// the listed samples replaced by outliers.
PixelSamples MakeSamples(const std::vector<Eigen::Vector3d>& dirs, const Eigen::Vector3d& scaled,
                         const std::vector<std::pair<int, double>>& outliers = {}, double noise = 0,
                         uint64_t seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gaussian(0, noise > 0 ? noise : 1);
  PixelSamples samples;
  for (size_t k = 0; k < dirs.size(); ++k) {
    double value = std::max(0.0, dirs[k].dot(scaled)) + (noise > 0 ? gaussian(rng) : 0.0);
    for (const auto& [index, replacement] : outliers) {
      if (index == int(k)) value = replacement;
    }
    samples.Add(dirs[k].x(), dirs[k].y(), dirs[k].z(), value, value, value, value);
  }
  return samples;
}

TEST(PixelSolversTest, ConditionNumberMatchesTheSvd) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uniform(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Matrix<double, 8, 3> lights;
    for (int i = 0; i < lights.size(); ++i) lights.data()[i] = uniform(rng);
    // Squash one axis to reach condition numbers up to ~1e4.
    lights.col(trial % 3) *= std::pow(10.0, -4.0 * (trial % 17) / 16);
    const Eigen::Vector3d singular = lights.jacobiSvd().singularValues();
    const double expected = singular[0] / singular[2];
    const double fast = ConditionNumberFromGram(lights.transpose() * lights);
    EXPECT_NEAR(fast / expected, 1.0, 1e-5) << "trial " << trial << ", expected " << expected;
  }
  EXPECT_TRUE(std::isinf(ConditionNumberFromGram(Eigen::Matrix3d::Zero())));
  const Eigen::Vector3d d(0.3, 0.4, 0.866);
  EXPECT_TRUE(std::isinf(ConditionNumberFromGram(Eigen::Matrix3d(d * d.transpose()))));  // rank 1
  Eigen::Matrix3d nan = Eigen::Matrix3d::Identity();
  nan(1, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(std::isinf(ConditionNumberFromGram(nan)));
  // A triple eigenvalue is the hardest case for the cubic: still within 1e-5.
  EXPECT_NEAR(ConditionNumberFromGram(Eigen::Matrix3d::Identity() * 4), 1.0, 1e-5);
}

TEST(PixelSolversTest, LeastSquaresThreeWaysAgree) {
  const std::vector<Eigen::Vector3d> dirs = RingLightDirections(12, 25, 65);
  const Eigen::Vector3d scaled(0.1, -0.2, 0.5);
  const PixelSamples samples = MakeSamples(dirs, scaled, {}, 0.01);
  const PixelFit svd = FitLeastSquares(DenseMethod::kJacobiSvd, samples, true, {});
  const PixelFit qr = FitLeastSquares(DenseMethod::kQr, samples, true, {});
  const PixelFit normal = FitLeastSquares(DenseMethod::kNormalEquations, samples, true, {});
  ASSERT_EQ(svd.status, PixelStatus::kSolved);
  EXPECT_LT(AngleDegrees(svd.normal, qr.normal), 1e-9);
  EXPECT_LT(AngleDegrees(svd.normal, normal.normal), 1e-9);
  EXPECT_NEAR(svd.condition_number, qr.condition_number, 1e-6);
  EXPECT_NEAR(svd.condition_number, normal.condition_number, 1e-6);
  EXPECT_NEAR(svd.residual, normal.residual, 1e-12);
  EXPECT_GT(svd.residual, 0);
  EXPECT_NEAR(svd.albedo[0], scaled.norm(), 0.02);
}

TEST(PixelSolversTest, RobustFitsIgnoreAThirdOfOutliers) {
  const std::vector<Eigen::Vector3d> dirs = RingLightDirections(24, 20, 70);
  const Eigen::Vector3d scaled = Eigen::Vector3d(0.2, 0.1, 0.9).normalized() * 0.6;
  // Highlights (too bright) and cast shadows (zero) on 8 of 24 samples.
  const PixelSamples samples =
      MakeSamples(dirs, scaled, {{1, 2.0}, {4, 1.5}, {7, 0.0}, {9, 0.0}, {12, 3.0}, {15, 0.0}, {18, 1.2}, {21, 0.0}},
                  0.001);
  const PixelFit lsq = FitLeastSquares(DenseMethod::kNormalEquations, samples, true, {});
  EXPECT_GT(AngleDegrees(lsq.normal, scaled), 5.0);
  RobustFitOptions options;
  const PixelFit tukey = FitRobustIrls(samples, true, {}, options);
  EXPECT_LT(AngleDegrees(tukey.normal, scaled), 0.2);
  EXPECT_EQ(tukey.lights_used, 16);
  EXPECT_NEAR(tukey.albedo[1], 0.6, 0.005);
  options.loss = PhotometricSolverOptions::RobustLoss::kCauchy;
  EXPECT_LT(AngleDegrees(FitRobustIrls(samples, true, {}, options).normal, scaled), 1.0);
  options.loss = PhotometricSolverOptions::RobustLoss::kTukey;
  const PixelFit sbl = FitSparseBayesian(samples, true, {}, options);
  EXPECT_LT(AngleDegrees(sbl.normal, scaled), 0.2);
  EXPECT_LE(sbl.lights_used, 17);
  EXPECT_TRUE(std::isfinite(sbl.residual));
}

TEST(PixelSolversTest, TooFewAndDegenerateSamplesAreFlagged) {
  const std::vector<Eigen::Vector3d> dirs = RingLightDirections(2, 30, 60);
  const PixelSamples two = MakeSamples(dirs, Eigen::Vector3d(0, 0, 0.5));
  for (DenseMethod method : {DenseMethod::kJacobiSvd, DenseMethod::kQr, DenseMethod::kNormalEquations}) {
    EXPECT_EQ(FitLeastSquares(method, two, true, {}).status, PixelStatus::kTooFewLights);
  }
  EXPECT_EQ(FitRobustIrls(two, true, {}, {}).status, PixelStatus::kTooFewLights);
  EXPECT_EQ(FitSparseBayesian(two, true, {}, {}).status, PixelStatus::kTooFewLights);
  const Eigen::Vector3d d(0, 0.6, 0.8);
  const PixelSamples same = MakeSamples({d, d, d, d}, Eigen::Vector3d(0, 0, 0.5));
  const PixelFit fit = FitLeastSquares(DenseMethod::kJacobiSvd, same, true, {});
  EXPECT_EQ(fit.status, PixelStatus::kIllConditioned);
  EXPECT_TRUE(std::isfinite(fit.condition_number));
  EXPECT_EQ(fit.normal, Eigen::Vector3d::UnitZ());
}

}  // namespace
}  // namespace scanbench
