// The per-pixel dense solves on hand-made samples.
#include "solver/pixel_solvers.h"

#include <array>
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

// --- FitDiffuseLobe: diffuse + GGX lobe on synthetic samples with ground truth.

// Lights on rings from 15 to 85 deg elevation every 10 deg, 12 per ring.
std::vector<Eigen::Vector3d> DenseLights() {
  std::vector<Eigen::Vector3d> dirs;
  for (double elevation = 15; elevation < 90; elevation += 10) {
    for (int a = 0; a < 12; ++a) {
      const double el = elevation * M_PI / 180, az = (30.0 * a + elevation) * M_PI / 180;
      dirs.emplace_back(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    }
  }
  return dirs;
}

struct LobePixel {
  Eigen::Vector3d normal = Eigen::Vector3d(0.25, -0.15, 1).normalized();
  Eigen::Vector3d albedo = {0.5, 0.4, 0.3};  // diffuse, RGB
  double f0 = 0.08, alpha = 0.2;
};

// The model FitDiffuseLobe fits, rendered exactly (white lobe, view +z), plus noise.
PixelSamples MakeLobeSamples(const std::vector<Eigen::Vector3d>& dirs, const LobePixel& pixel, double noise = 0,
                             uint64_t seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gaussian(0, noise > 0 ? noise : 1);
  const Eigen::Vector3d view = Eigen::Vector3d::UnitZ();
  const std::array<double, 3> weights = PhotometricSolverOptions().luminance_weights;
  PixelSamples samples;
  for (const Eigen::Vector3d& dir : dirs) {
    const double nl = pixel.normal.dot(dir);
    if (!(nl > 0)) continue;  // shadowed: the solver leaves it out
    const double c = pixel.normal.dot((dir + view).normalized());
    const double a2 = pixel.alpha * pixel.alpha;
    const double q = c * c * (a2 - 1) + 1;
    const double lobe = pixel.f0 * a2 / (4 * pixel.normal.dot(view) * q * q);
    double rgb[3];
    for (int ch = 0; ch < 3; ++ch) rgb[ch] = pixel.albedo[ch] * nl + lobe + (noise > 0 ? gaussian(rng) : 0.0);
    const double luminance = weights[0] * rgb[0] + weights[1] * rgb[1] + weights[2] * rgb[2];
    samples.Add(dir.x(), dir.y(), dir.z(), luminance, rgb[0], rgb[1], rgb[2]);
  }
  return samples;
}

double Luminance(const Eigen::Vector3d& rgb) {
  const std::array<double, 3> w = PhotometricSolverOptions().luminance_weights;
  return w[0] * rgb[0] + w[1] * rgb[1] + w[2] * rgb[2];
}

TEST(DiffuseLobeTest, RecoversNormalDiffuseAndLobeWithoutNoise) {
  const LobePixel truth;
  const PixelSamples samples = MakeLobeSamples(DenseLights(), truth);
  const PixelFit lambert = FitRobustIrls(samples, true, {}, {});
  const PixelFit fit = FitDiffuseLobe(samples, Eigen::Vector3d::UnitZ(), true, {}, {});
  ASSERT_EQ(fit.status, PixelStatus::kSolved);
  ASSERT_EQ(fit.specular_status, SpecularStatus::kEstimated);
  EXPECT_LT(AngleDegrees(fit.normal, truth.normal), 0.05) << "Lambertian start "
                                                          << AngleDegrees(lambert.normal, truth.normal);
  // The lobe is white: the luminance lobe amplitude is the sum of the weights (0.9999) x F0.
  EXPECT_NEAR(fit.luminance_albedo, Luminance(truth.albedo), 1e-3);
  EXPECT_NEAR(fit.specular_f0, 0.9999 * truth.f0, 0.02 * truth.f0);
  EXPECT_NEAR(fit.roughness_alpha, truth.alpha, 0.02 * truth.alpha);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(fit.albedo[c], truth.albedo[c], 2e-3) << "channel " << c;
  EXPECT_LT(fit.residual, 1e-3);
}

TEST(DiffuseLobeTest, RecoversNormalDiffuseAndLobeWithNoise) {
  LobePixel truth;
  truth.alpha = 0.3;
  truth.f0 = 0.1;
  double worst_lambert = 0;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    const PixelSamples samples = MakeLobeSamples(DenseLights(), truth, 0.003, seed);
    const PixelFit fit = FitDiffuseLobe(samples, Eigen::Vector3d::UnitZ(), true, {}, {});
    ASSERT_EQ(fit.status, PixelStatus::kSolved);
    ASSERT_EQ(fit.specular_status, SpecularStatus::kEstimated) << "seed " << seed;
    EXPECT_LT(AngleDegrees(fit.normal, truth.normal), 0.6) << "seed " << seed;
    EXPECT_NEAR(fit.luminance_albedo, Luminance(truth.albedo), 0.02) << "seed " << seed;
    EXPECT_NEAR(fit.roughness_alpha, truth.alpha, 0.2 * truth.alpha) << "seed " << seed;
    EXPECT_NEAR(fit.specular_f0, truth.f0, 0.3 * truth.f0) << "seed " << seed;
    worst_lambert = std::max(worst_lambert, AngleDegrees(FitRobustIrls(samples, false, {}, {}).normal, truth.normal));
  }
  EXPECT_GT(worst_lambert, 1.0);  // the lobe biases the robust Lambertian fit: the test is not trivial
}

TEST(DiffuseLobeTest, LambertianPixelKeepsTheLambertianFit) {
  const std::vector<Eigen::Vector3d> dirs = DenseLights();
  LobePixel truth;
  truth.f0 = 0;
  for (double noise : {0.0, 0.003}) {
    const PixelSamples samples = MakeLobeSamples(dirs, truth, noise, 7);
    const PixelFit lambert = FitRobustIrls(samples, true, {}, {});
    const PixelFit fit = FitDiffuseLobe(samples, Eigen::Vector3d::UnitZ(), true, {}, {});
    ASSERT_EQ(fit.status, PixelStatus::kSolved);
    EXPECT_EQ(fit.specular_status, SpecularStatus::kUnsupported) << "noise " << noise;
    EXPECT_EQ(fit.specular_f0, 0);
    EXPECT_EQ(fit.roughness_alpha, 0);
    EXPECT_EQ(fit.normal, lambert.normal);
    EXPECT_EQ(fit.albedo, lambert.albedo);
    EXPECT_EQ(fit.residual, lambert.residual);
  }
}

TEST(DiffuseLobeTest, TooFewOrDegenerateSamplesAreFlaggedNeverNaN) {
  const LobePixel truth;
  // Three lights: solved as Lambertian (no spare samples for a lobe).
  const std::vector<Eigen::Vector3d> three = {Eigen::Vector3d(0.5, 0, 0.866), Eigen::Vector3d(-0.4, 0.4, 0.82),
                                              Eigen::Vector3d(0, -0.5, 0.866)};
  const PixelFit few = FitDiffuseLobe(MakeLobeSamples(three, truth), Eigen::Vector3d::UnitZ(), true, {}, {});
  EXPECT_EQ(few.status, PixelStatus::kSolved);
  EXPECT_EQ(few.specular_status, SpecularStatus::kUnsupported);
  PixelSamples none;
  const PixelFit empty = FitDiffuseLobe(none, Eigen::Vector3d::UnitZ(), true, {}, {});
  EXPECT_EQ(empty.status, PixelStatus::kTooFewLights);
  EXPECT_EQ(empty.specular_status, SpecularStatus::kNotSolved);
  // A NaN view direction falls back to the orthographic one.
  const PixelSamples samples = MakeLobeSamples(DenseLights(), truth);
  const PixelFit nan_view =
      FitDiffuseLobe(samples, Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()), true, {}, {});
  EXPECT_TRUE(nan_view.normal.allFinite());
  EXPECT_LT(AngleDegrees(nan_view.normal, truth.normal), 0.05);
  // All-zero samples: no signal.
  PixelSamples dark;
  for (const Eigen::Vector3d& d : DenseLights()) dark.Add(d.x(), d.y(), d.z(), 0, 0, 0, 0);
  const PixelFit black = FitDiffuseLobe(dark, Eigen::Vector3d::UnitZ(), true, {}, {});
  EXPECT_NE(black.status, PixelStatus::kSolved);
  EXPECT_TRUE(black.normal.allFinite());
}

// A cloth pixel after the seed's cloth BRDF: diffuse plus a white velvet
// sheen, F0 constant, view +z, under the rig's two LED rings (30 and 60 deg).
struct SheenPixel {
  Eigen::Vector3d normal = Eigen::Vector3d(0.3, -0.2, 1).normalized();
  Eigen::Vector3d albedo = {0.08, 0.10, 0.30};  // indigo-like diffuse, RGB
  double f0 = 0.05, width = 0.9;
};

// The velvet reading per unit irradiance, written out from the seed's
// equations (not the solver's code): pi F D (n.l) / (4 (n.l + n.v - n.l n.v)),
// D = (1 + 4 exp(-cot^2 th_h / a^2) / sin^4 th_h) / (pi (1 + 4 a^2)).
double SeedVelvetReading(const Eigen::Vector3d& n, const Eigen::Vector3d& l, const Eigen::Vector3d& v, double f0,
                         double a) {
  const double nl = n.dot(l), nv = n.dot(v);
  if (!(nl > 0) || !(nv > 0)) return 0;
  const double cos_h = n.dot((l + v).normalized());
  const double th = std::acos(std::clamp(cos_h, -1.0, 1.0));
  const double d = th < 1e-9 ? 1 / (M_PI * (1 + 4 * a * a))
                             : (1 + 4 * std::exp(-std::pow(1 / std::tan(th), 2) / (a * a)) / std::pow(std::sin(th), 4)) /
                                   (M_PI * (1 + 4 * a * a));
  return M_PI * f0 * d * nl / (4 * (nl + nv - nl * nv));
}

PixelSamples MakeSheenSamples(const SheenPixel& pixel, double noise = 0, uint64_t seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gaussian(0, noise > 0 ? noise : 1);
  const Eigen::Vector3d view = Eigen::Vector3d::UnitZ();
  PixelSamples samples;
  for (const Eigen::Vector3d& dir : RingLightDirections(10, 30, 60)) {
    const double nl = pixel.normal.dot(dir);
    if (!(nl > 0)) continue;
    const double sheen = SeedVelvetReading(pixel.normal, dir, view, pixel.f0, pixel.width);
    double rgb[3];
    for (int ch = 0; ch < 3; ++ch) rgb[ch] = pixel.albedo[ch] * nl + sheen + (noise > 0 ? gaussian(rng) : 0.0);
    samples.Add(dir.x(), dir.y(), dir.z(), Luminance(Eigen::Vector3d(rgb[0], rgb[1], rgb[2])), rgb[0], rgb[1], rgb[2]);
  }
  return samples;
}

TEST(DiffuseSheenTest, ShapeIsTheSeedsVelvetDistribution) {
  const Eigen::Vector3d view = Eigen::Vector3d::UnitZ();
  for (const Eigen::Vector3d& n : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.3, -0.2, 1).normalized(),
                                   Eigen::Vector3d(-0.6, 0.1, 0.5).normalized()}) {
    for (const Eigen::Vector3d& l : RingLightDirections(10, 30, 60)) {
      for (double a : {0.4, 0.9, 1.5}) {
        const double s = VelvetSheenShape(n, l, (l + view).normalized(), view, a);
        EXPECT_NEAR(s, SeedVelvetReading(n, l, view, 1.0, a), 1e-12 + 1e-9 * s);
      }
    }
  }
  // The half vector on the normal (th_h = 0): the distribution's offset alone, not NaN.
  const double at_normal = VelvetSheenShape(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ(),
                                            Eigen::Vector3d::UnitZ(), view, 0.9);
  EXPECT_NEAR(at_normal, 1 / (4 * (1 + 4 * 0.81)), 1e-12);
  EXPECT_EQ(VelvetSheenShape(Eigen::Vector3d::UnitZ(), -Eigen::Vector3d::UnitZ(), view, view, 0.9), 0);  // unlit
  EXPECT_EQ(VelvetSheenShape(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(), view, view, 0), 0);  // no width
}

TEST(DiffuseSheenTest, RecoversNormalAlbedoAndSheenWithoutNoise) {
  const SheenPixel truth;
  const PixelSamples samples = MakeSheenSamples(truth);
  const PixelFit lsq = FitLeastSquares(DenseMethod::kNormalEquations, samples, true, {});
  ASSERT_EQ(lsq.status, PixelStatus::kSolved);
  const double lsq_error = AngleDegrees(lsq.normal, truth.normal);
  EXPECT_GT(lsq_error, 0.5);  // the sheen biases least squares: the test is not trivial
  EXPECT_TRUE(SheenPatternInResidual(samples, Eigen::Vector3d::UnitZ(), lsq));
  const PixelFit fit = FitDiffuseSheen(samples, Eigen::Vector3d::UnitZ(), true, {}, lsq);
  ASSERT_EQ(fit.status, PixelStatus::kSolved);
  EXPECT_LT(AngleDegrees(fit.normal, truth.normal), 0.02) << "least squares " << lsq_error;
  EXPECT_NEAR(fit.sheen_f0, 0.9999 * truth.f0, 0.02 * truth.f0);  // white: the luminance weights sum to 0.9999
  EXPECT_NEAR(fit.sheen_width, truth.width, 0.05 * truth.width);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(fit.albedo[c], truth.albedo[c], 1e-3) << "channel " << c;
  EXPECT_LT(fit.residual, 1e-3);
  EXPECT_EQ(fit.specular_status, SpecularStatus::kUnsupported);  // the GGX maps are not the sheen's
}

TEST(DiffuseSheenTest, ReducesTheErrorWithNoise) {
  const SheenPixel truth;
  double lsq_sum = 0, sheen_sum = 0;
  int kept = 0;
  for (uint64_t seed = 1; seed <= 40; ++seed) {
    const PixelSamples samples = MakeSheenSamples(truth, 0.0005, seed);  // ~0.5 % of the reading
    const PixelFit lsq = FitLeastSquares(DenseMethod::kNormalEquations, samples, true, {});
    ASSERT_EQ(lsq.status, PixelStatus::kSolved);
    const PixelFit fit = FitDiffuseSheen(samples, Eigen::Vector3d::UnitZ(), true, {}, lsq);
    ASSERT_EQ(fit.status, PixelStatus::kSolved);
    ASSERT_TRUE(fit.normal.allFinite());
    kept += fit.sheen_f0 > 0;
    lsq_sum += AngleDegrees(lsq.normal, truth.normal);
    sheen_sum += AngleDegrees(fit.normal, truth.normal);
  }
  EXPECT_GE(kept, 30);
  EXPECT_LT(sheen_sum, 0.6 * lsq_sum) << "mean " << sheen_sum / 40 << " against least squares " << lsq_sum / 40;
}

TEST(DiffuseSheenTest, LambertianPixelKeepsTheLeastSquaresFit) {
  SheenPixel truth;
  truth.f0 = 0;
  const PixelSamples samples = MakeSheenSamples(truth);
  const PixelFit lsq = FitLeastSquares(DenseMethod::kNormalEquations, samples, true, {});
  EXPECT_FALSE(SheenPatternInResidual(samples, Eigen::Vector3d::UnitZ(), lsq));
  const PixelFit fit = FitDiffuseSheen(samples, Eigen::Vector3d::UnitZ(), true, {}, lsq);
  EXPECT_EQ(fit.sheen_f0, 0);
  EXPECT_EQ(fit.sheen_width, 0);
  EXPECT_EQ(fit.normal, lsq.normal);
  EXPECT_EQ(fit.albedo, lsq.albedo);
  // A darker ring reading (negative "sheen") is not a sheen either.
  PixelSamples dimmed;
  for (int k = 0; k < samples.count(); ++k) {
    const auto l = samples.lights().row(k);
    const double f = l.z() < 0.7 ? 0.9 : 1.0;  // the 30 deg ring 10 % darker
    dimmed.Add(l.x(), l.y(), l.z(), f * samples.values()(k, 0), f * samples.values()(k, 1), f * samples.values()(k, 2),
               f * samples.values()(k, 3));
  }
  const PixelFit dimmed_lsq = FitLeastSquares(DenseMethod::kNormalEquations, dimmed, true, {});
  EXPECT_FALSE(SheenPatternInResidual(dimmed, Eigen::Vector3d::UnitZ(), dimmed_lsq));
}

TEST(DiffuseSheenTest, TooFewOrDegenerateSamplesNeverNaN) {
  const SheenPixel truth;
  const PixelSamples samples = MakeSheenSamples(truth);
  const PixelFit lsq = FitLeastSquares(DenseMethod::kNormalEquations, samples, true, {});
  // An unsolved start is returned as it is.
  PixelFit unsolved;
  unsolved.status = PixelStatus::kIllConditioned;
  EXPECT_EQ(FitDiffuseSheen(samples, Eigen::Vector3d::UnitZ(), true, {}, unsolved).status,
            PixelStatus::kIllConditioned);
  EXPECT_FALSE(SheenPatternInResidual(samples, Eigen::Vector3d::UnitZ(), unsolved));
  // Five samples: too few for the sheen.
  PixelSamples five;
  for (int k = 0; k < 5; ++k) {
    const auto l = samples.lights().row(k);
    const auto b = samples.values().row(k);
    five.Add(l.x(), l.y(), l.z(), b(0), b(1), b(2), b(3));
  }
  const PixelFit five_lsq = FitLeastSquares(DenseMethod::kNormalEquations, five, true, {});
  EXPECT_EQ(FitDiffuseSheen(five, Eigen::Vector3d::UnitZ(), true, {}, five_lsq).sheen_f0, 0);
  // A NaN view direction falls back to the orthographic one.
  const Eigen::Vector3d nan_view = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const PixelFit fit = FitDiffuseSheen(samples, nan_view, true, {}, lsq);
  EXPECT_TRUE(fit.normal.allFinite());
  EXPECT_LT(AngleDegrees(fit.normal, truth.normal), 0.02);
}

}  // namespace
}  // namespace scanbench
