#include "maps/gloss_mips.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/format.h"

namespace scanbench {
namespace {

using Model = GlossMipOptions::Model;

// A microfacet normal drawn from the GGX NDF with pdf D(m) cos(theta_m)
// (the macrosurface-area model): tan^2(theta) = alpha^2 u / (1 - u).
std::array<double, 3> SampleGgxNormal(double alpha, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double u = uniform(rng), v = uniform(rng);
  const double tan2 = alpha * alpha * u / (1.0 - u);
  const double cos_theta = 1.0 / std::sqrt(1.0 + tan2);
  const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
  const double phi = 2.0 * std::numbers::pi * v;
  return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta};
}

ImageF ConstantNormals(int width, int height, float x, float y, float z) {
  ImageF normals(width, height, 3);
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      normals(c, r, 0) = x;
      normals(c, r, 1) = y;
      normals(c, r, 2) = z;
    }
  }
  return normals;
}

ImageF GgxNormalField(int width, int height, double alpha, uint64_t seed) {
  std::mt19937_64 rng(seed);
  ImageF normals(width, height, 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const std::array<double, 3> n = SampleGgxNormal(alpha, rng);
      for (int c = 0; c < 3; ++c) normals(x, y, c) = static_cast<float>(n[c]);
    }
  }
  return normals;
}

// Every value finite, every normal unit, every roughness in [kMinGgxAlpha, 1].
void ExpectWellFormed(const std::vector<GlossMipLevel>& levels) {
  for (size_t l = 0; l < levels.size(); ++l) {
    const GlossMipLevel& level = levels[l];
    ASSERT_EQ(level.normal_in_tangent.channels(), 3);
    ASSERT_EQ(level.roughness.channels(), 1);
    ASSERT_TRUE(level.roughness.SameSize(level.normal_in_tangent));
    for (int y = 0; y < level.roughness.height(); ++y) {
      for (int x = 0; x < level.roughness.width(); ++x) {
        const float alpha = level.roughness(x, y);
        ASSERT_TRUE(std::isfinite(alpha)) << "level " << l << " at " << x << "," << y;
        ASSERT_GE(alpha, static_cast<float>(kMinGgxAlpha)) << "level " << l;
        ASSERT_LE(alpha, 1.0f) << "level " << l;
        double norm2 = 0;
        for (int c = 0; c < 3; ++c) {
          const float v = level.normal_in_tangent(x, y, c);
          ASSERT_TRUE(std::isfinite(v)) << "level " << l << " at " << x << "," << y;
          norm2 += static_cast<double>(v) * v;
        }
        ASSERT_NEAR(std::sqrt(norm2), 1.0, 1e-6) << "level " << l << " at " << x << "," << y;
      }
    }
  }
}

// ----------------------------------------------------------------------------
// Gloss parameterisation and normal length.

TEST(GlossParameterisation, EquationTwoEndpointsAndRoundTrip) {
  EXPECT_EQ(GlossToGgxAlpha(0.0), 1.0);  // the full GGX range: gloss 0 is alpha 1
  EXPECT_NEAR(GlossToGgxAlpha(1.0), std::sqrt(2.0 / (1.0 + std::pow(2.0, 18.0))), 1e-15);
  EXPECT_NEAR(GlossToGgxAlpha(1.0), 0.0027621, 1e-7);
  EXPECT_EQ(GgxAlphaToGloss(1.0), 0.0);
  double previous_alpha = 2.0;
  for (int i = 0; i <= 100; ++i) {
    const double gloss = i / 100.0;
    const double alpha = GlossToGgxAlpha(gloss);
    EXPECT_LT(alpha, previous_alpha) << gloss;
    previous_alpha = alpha;
    EXPECT_NEAR(GgxAlphaToGloss(alpha), gloss, 1e-12) << gloss;
  }
  // Clamped outside the domain, NaN refused.
  EXPECT_EQ(GlossToGgxAlpha(-0.5), 1.0);
  EXPECT_EQ(GlossToGgxAlpha(1.5), GlossToGgxAlpha(1.0));
  EXPECT_EQ(GgxAlphaToGloss(1e-6), 1.0);
  EXPECT_EQ(GgxAlphaToGloss(0.0), 1.0);
  EXPECT_EQ(GgxAlphaToGloss(3.0), 0.0);
  EXPECT_THROW(GlossToGgxAlpha(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_THROW(GgxAlphaToGloss(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
}

TEST(GgxNormalLength, MatchesTheSeedTable) {
  // Listing 8 of seed 004 ({gloss, length}, importance sampled, ~3e-6 noise).
  const std::vector<std::pair<double, double>> table = {
      {0.000000, 0.666670}, {0.003922, 0.669966}, {0.050980, 0.714267}, {0.200000, 0.868652},
      {0.333333, 0.953520}, {0.501961, 0.990513}, {0.800000, 0.999600}, {1.000000, 0.999958}};
  for (const auto& [gloss, length] : table) {
    EXPECT_NEAR(GgxAlphaToNormalLength(GlossToGgxAlpha(gloss)), length, 1e-5) << "gloss " << gloss;
  }
}

TEST(GgxNormalLength, EndpointsAndMonotoneAcrossTheSeriesSwitch) {
  EXPECT_DOUBLE_EQ(GgxAlphaToNormalLength(1.0), 2.0 / 3.0);
  EXPECT_EQ(GgxAlphaToNormalLength(0.0), 1.0);
  EXPECT_EQ(GgxAlphaToNormalLength(-1.0), 1.0);
  EXPECT_DOUBLE_EQ(GgxAlphaToNormalLength(2.0), 2.0 / 3.0);
  // Small alpha: 1 - length ~ alpha^2 (log(2 / alpha) - 1).
  const double alpha = 1e-3;
  EXPECT_NEAR(1.0 - GgxAlphaToNormalLength(alpha), alpha * alpha * (std::log(2.0 / alpha) - 1.0), 1e-8);
  double previous = 1.0;
  for (int i = 1; i <= 20000; ++i) {
    const double a = i / 20000.0;
    const double length = GgxAlphaToNormalLength(a);
    ASSERT_LT(length, previous) << "alpha " << a;
    ASSERT_GE(length, 2.0 / 3.0 - 1e-15) << "alpha " << a;
    previous = length;
  }
  // Continuous where the series hands over to the closed form (a = 0.5).
  const double switch_alpha = std::sqrt(0.75);
  EXPECT_NEAR(GgxAlphaToNormalLength(std::nextafter(switch_alpha, 0.0)),
              GgxAlphaToNormalLength(std::nextafter(switch_alpha, 1.0)), 1e-14);
  EXPECT_THROW(GgxAlphaToNormalLength(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
}

TEST(GgxNormalLength, MatchesMonteCarloSamplingOfTheNdf) {
  std::mt19937_64 rng(20240611);
  constexpr int kSamples = 400000;
  for (const double alpha : {0.01, 0.05, 0.2, 0.45, 0.7, 0.9, 1.0}) {
    double sum = 0, sum2 = 0;
    double mean_x = 0;
    for (int i = 0; i < kSamples; ++i) {
      const std::array<double, 3> n = SampleGgxNormal(alpha, rng);
      sum += n[2];
      sum2 += n[2] * n[2];
      mean_x += n[0];
    }
    const double mean = sum / kSamples;
    const double standard_error = std::sqrt(std::max(0.0, sum2 / kSamples - mean * mean) / kSamples);
    // 5 standard errors: a false alarm about once in 3 million per alpha.
    EXPECT_NEAR(GgxAlphaToNormalLength(alpha), mean, 5 * standard_error + 1e-12)
        << "alpha " << alpha << ", standard error " << standard_error;
    EXPECT_NEAR(mean_x / kSamples, 0.0, 0.01) << alpha;
  }
}

TEST(GgxNormalLength, InverseRoundTrip) {
  for (int i = 0; i <= 400; ++i) {
    const double alpha = std::exp(std::log(kMinGgxAlpha) * (1.0 - i / 400.0));
    ASSERT_NEAR(NormalLengthToGgxAlpha(GgxAlphaToNormalLength(alpha)), alpha, 1e-9 * alpha + 1e-15)
        << "alpha " << alpha;
  }
  for (const double gloss : {0.0, 0.25, 0.5, 0.75, 1.0}) {
    const double alpha = GlossToGgxAlpha(gloss);
    EXPECT_NEAR(NormalLengthToGgxAlpha(GgxAlphaToNormalLength(alpha)), alpha, 1e-12) << gloss;
  }
  // Out of range: clamped into [kMinGgxAlpha, 1].
  EXPECT_EQ(NormalLengthToGgxAlpha(0.0), 1.0);
  EXPECT_EQ(NormalLengthToGgxAlpha(0.5), 1.0);
  EXPECT_EQ(NormalLengthToGgxAlpha(2.0 / 3.0), 1.0);
  EXPECT_EQ(NormalLengthToGgxAlpha(1.0), kMinGgxAlpha);
  EXPECT_EQ(NormalLengthToGgxAlpha(1.5), kMinGgxAlpha);
  EXPECT_THROW(NormalLengthToGgxAlpha(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
}

// ----------------------------------------------------------------------------
// The mip chain.

TEST(GlossMipChain, LevelSizesHalveRoundingUp) {
  std::vector<GlossMipLevel> output;
  const std::vector<std::pair<int, int>> expected = {{37, 20}, {19, 10}, {10, 5}, {5, 3}, {3, 2}, {2, 1}, {1, 1}};
  EXPECT_EQ(GlossMipLevelSizes(37, 20), expected);
  EXPECT_EQ(GlossMipLevelSizes(37, 20, 3).size(), 3u);
  EXPECT_EQ(GlossMipLevelSizes(1, 1), (std::vector<std::pair<int, int>>{{1, 1}}));
  EXPECT_EQ(GlossMipLevelSizes(1, 5).back(), std::make_pair(1, 1));
  EXPECT_EQ(GlossMipLevelSizes(1, 5).size(), 4u);  // 1x5 -> 1x3 -> 1x2 -> 1x1
  EXPECT_THROW(GlossMipLevelSizes(0, 5), std::invalid_argument);

  const ImageF normals = ConstantNormals(37, 20, 0, 0, 1);
  for (const Model model : {Model::kVmf, Model::kGgxNormalLength}) {
    GlossMipOptions options;
    options.model = model;
    GlossMipSummary summary;
    std::vector<GlossMipLevel> levels;
    summary = BuildGlossMipChain(options, normals, nullptr, nullptr, &levels);
    ASSERT_EQ(levels.size(), expected.size());
    for (size_t l = 0; l < levels.size(); ++l) {
      EXPECT_TRUE(levels[l].normal_in_tangent.SameSize(expected[l].first, expected[l].second)) << l;
      EXPECT_TRUE(levels[l].roughness.SameSize(expected[l].first, expected[l].second)) << l;
    }
    EXPECT_EQ(summary.mean_roughness.size(), expected.size());
    EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
    options.max_levels = 2;
    BuildGlossMipChain(options, normals, nullptr, nullptr, &output);
    EXPECT_EQ(output.size(), 2u);
  }
}

TEST(GlossMipChain, FlatMapKeepsBaseRoughnessAtEveryLevel) {
  // Tilted but flat: one direction everywhere, so no variance to push down.
  const ImageF normals = ConstantNormals(37, 20, 0.6f, 0.0f, 0.8f);
  for (const Model model : {Model::kVmf, Model::kGgxNormalLength}) {
    for (const double base : {kMinGgxAlpha, 0.01, 0.3, 1.0}) {
      GlossMipOptions options;
      options.model = model;
      options.base_roughness = base;
      GlossMipSummary summary;
      std::vector<GlossMipLevel> levels;
      summary = BuildGlossMipChain(options, normals, nullptr, nullptr, &levels);
      ExpectWellFormed(levels);
      for (size_t l = 0; l < levels.size(); ++l) {
        const GlossMipLevel& level = levels[l];
        for (int y = 0; y < level.roughness.height(); ++y) {
          for (int x = 0; x < level.roughness.width(); ++x) {
            ASSERT_FLOAT_EQ(level.roughness(x, y), static_cast<float>(base))
                << GlossModelName(model) << " level " << l;
            ASSERT_NEAR(level.normal_in_tangent(x, y, 0), 0.6f, 1e-6);
            ASSERT_NEAR(level.normal_in_tangent(x, y, 2), 0.8f, 1e-6);
          }
        }
        EXPECT_NEAR(summary.mean_roughness[l], base, 1e-7 * base) << l;
      }
    }
  }
}

TEST(GlossMipChain, FlatMapCombinesARoughnessMapPerModel) {
  const ImageF normals = ConstantNormals(2, 1, 0, 0, 1);
  ImageF roughness(2, 1, 1);
  roughness(0, 0) = 0.1f;
  roughness(1, 0) = 0.5f;
  const double a0 = roughness(0, 0), a1 = roughness(1, 0);
  GlossMipOptions options;
  options.model = Model::kVmf;
  std::vector<GlossMipLevel> levels;
  BuildGlossMipChain(options, normals, &roughness, nullptr, &levels);
  ASSERT_EQ(levels.size(), 2u);
  EXPECT_FLOAT_EQ(levels[0].roughness(1, 0), 0.5f);  // mip 0 is the input
  EXPECT_FLOAT_EQ(levels[1].roughness(0, 0), static_cast<float>(std::sqrt((a0 * a0 + a1 * a1) / 2)));
  options.model = Model::kGgxNormalLength;
  BuildGlossMipChain(options, normals, &roughness, nullptr, &levels);
  const double expected =
      NormalLengthToGgxAlpha((GgxAlphaToNormalLength(a0) + GgxAlphaToNormalLength(a1)) / 2);
  EXPECT_FLOAT_EQ(levels[1].roughness(0, 0), static_cast<float>(expected));
  EXPECT_GT(expected, 0.3);  // rougher than the mean alpha: the rough texel's NDF dominates the tails
}

TEST(GlossMipChain, GgxDirectionFavoursTheGlossierTexel) {
  // Seed 004 fig. 7: a glossy normal tilted right and a rough one tilted left
  // average to a normal tilted right (vMF weighs both alike).
  ImageF normals(2, 1, 3);
  normals(0, 0, 0) = 0.6f;
  normals(0, 0, 2) = 0.8f;
  normals(1, 0, 0) = -0.6f;
  normals(1, 0, 2) = 0.8f;
  ImageF roughness(2, 1, 1);
  roughness(0, 0) = 0.05f;
  roughness(1, 0) = 0.9f;
  GlossMipOptions options;
  options.model = Model::kGgxNormalLength;
  std::vector<GlossMipLevel> ggx;
  BuildGlossMipChain(options, normals, &roughness, nullptr, &ggx);
  const double l0 = GgxAlphaToNormalLength(roughness(0, 0)), l1 = GgxAlphaToNormalLength(roughness(1, 0));
  const double mx = 0.3 * (l0 - l1), mz = 0.4 * (l0 + l1);
  EXPECT_GT(ggx[1].normal_in_tangent(0, 0, 0), 0.1f);
  EXPECT_NEAR(ggx[1].normal_in_tangent(0, 0, 0), mx / std::hypot(mx, mz), 1e-6);
  EXPECT_NEAR(ggx[1].roughness(0, 0), NormalLengthToGgxAlpha(std::hypot(mx, mz)), 1e-6);
  options.model = Model::kVmf;
  std::vector<GlossMipLevel> vmf;
  BuildGlossMipChain(options, normals, &roughness, nullptr, &vmf);
  EXPECT_NEAR(vmf[1].normal_in_tangent(0, 0, 0), 0.0f, 1e-7);
}

TEST(GlossMipChain, OddSizesWeighEveryMipZeroTexelEqually) {
  // 3x1 -> 2x1 -> 1x1: the last texel's footprint is all three normals with
  // equal weights, not the average of the 2x1 level's two texels.
  ImageF normals(3, 1, 3);
  const std::array<std::array<double, 3>, 3> n = {{{0.6, 0.0, 0.8}, {0.0, 0.6, 0.8}, {-0.8, 0.0, 0.6}}};
  for (int x = 0; x < 3; ++x) {
    for (int c = 0; c < 3; ++c) normals(x, 0, c) = static_cast<float>(n[x][c]);
  }
  for (const Model model : {Model::kVmf, Model::kGgxNormalLength}) {
    GlossMipOptions options;
    options.model = model;
    options.base_roughness = 0.2;
    std::vector<GlossMipLevel> levels;
    BuildGlossMipChain(options, normals, nullptr, nullptr, &levels);
    ASSERT_EQ(levels.size(), 3u);
    ExpectWellFormed(levels);
    // The edge texel of the 2x1 level covers only the third normal.
    EXPECT_FLOAT_EQ(levels[1].roughness(1, 0), 0.2f);
    EXPECT_NEAR(levels[1].normal_in_tangent(1, 0, 0), -0.8f, 1e-6);
    std::array<double, 3> sum{};
    for (int x = 0; x < 3; ++x) {
      for (int c = 0; c < 3; ++c) sum[c] += n[x][c];
    }
    const double length = std::sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(levels[2].normal_in_tangent(0, 0, c), sum[c] / length, 1e-6) << GlossModelName(model) << c;
    }
    const double r = length / 3.0;  // mean normal length (equal base roughness, so GGX scales all alike)
    const double expected = model == Model::kVmf
                                ? std::sqrt(0.04 + (1 - r * r) / (r * (3 - r * r)))
                                : NormalLengthToGgxAlpha(r * GgxAlphaToNormalLength(0.2));
    EXPECT_NEAR(levels[2].roughness(0, 0), expected, 1e-6) << GlossModelName(model);
  }
}

TEST(GlossMipChain, WithoutMipZeroNormalsEveryOtherLevelIsTheSame) {
  // Random normals (one invalid), a roughness map and a mask, odd sizes.
  constexpr int kW = 37, kH = 23;
  std::mt19937 rng(14);
  std::uniform_real_distribution<float> tilt(-0.6f, 0.6f), alpha(0.05f, 0.8f);
  ImageF normals(kW, kH, 3), roughness(kW, kH, 1);
  ImageU8 valid(kW, kH, 1, 1);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      normals(x, y, 0) = tilt(rng), normals(x, y, 1) = tilt(rng), normals(x, y, 2) = 1.0f;
      roughness(x, y) = alpha(rng);
      valid(x, y) = rng() % 7 != 0;
    }
  }
  normals(3, 4, 0) = normals(3, 4, 1) = normals(3, 4, 2) = 0.0f;
  for (const Model model : {Model::kVmf, Model::kGgxNormalLength}) {
    GlossMipOptions options;
    options.model = model;
    std::vector<GlossMipLevel> with, without;
    const GlossMipSummary a = BuildGlossMipChain(options, normals, &roughness, &valid, &with);
    options.mip0_normals = false;
    const GlossMipSummary b = BuildGlossMipChain(options, normals, &roughness, &valid, &without);
    ASSERT_EQ(a.termination, Termination::kSuccess) << a.message;
    EXPECT_EQ(a.message, b.message);
    EXPECT_EQ(a.mean_roughness, b.mean_roughness);
    EXPECT_EQ(a.invalid_normals, b.invalid_normals);
    ASSERT_EQ(with.size(), without.size());
    EXPECT_FALSE(with[0].normal_in_tangent.empty());
    EXPECT_TRUE(without[0].normal_in_tangent.empty());
    for (size_t k = 0; k < with.size(); ++k) {
      const auto& r1 = with[k].roughness;
      const auto& r2 = without[k].roughness;
      ASSERT_TRUE(r1.SameSize(r2)) << k;
      EXPECT_EQ(std::memcmp(r1.data(), r2.data(), r1.size() * sizeof(float)), 0) << "roughness of level " << k;
      if (k == 0) continue;
      const auto& n1 = with[k].normal_in_tangent;
      const auto& n2 = without[k].normal_in_tangent;
      ASSERT_TRUE(n1.SameSize(n2)) << k;
      EXPECT_EQ(std::memcmp(n1.data(), n2.data(), n1.size() * sizeof(float)), 0) << "normals of level " << k;
    }
  }
}

TEST(GlossMipChain, MaskedPixelsCarryNoWeight) {
  std::vector<GlossMipLevel> output;
  // Unsolved pixels read (0, 0, 1); the sample is tilted. Masked out, the
  // flat pixels must not widen the lobe of the texels they share.
  ImageF normals = ConstantNormals(9, 6, 0.0f, 0.0f, 1.0f);
  ImageU8 valid(9, 6, 1, 0);
  for (int y = 0; y < 6; ++y) {
    for (int x = 3; x < 9; ++x) {
      normals(x, y, 0) = 0.6f;
      normals(x, y, 2) = 0.8f;
      valid(x, y) = 1;
    }
  }
  for (const Model model : {Model::kVmf, Model::kGgxNormalLength}) {
    GlossMipOptions options;
    options.model = model;
    options.base_roughness = 0.1;
    GlossMipSummary summary;
    std::vector<GlossMipLevel> masked;
    summary = BuildGlossMipChain(options, normals, nullptr, &valid, &masked);
    ExpectWellFormed(masked);
    EXPECT_EQ(summary.masked_pixels, 18u);
    EXPECT_EQ(summary.termination, Termination::kSuccess);
    for (const GlossMipLevel& level : masked) {
      // Every texel's footprint holds tilted normals or none at all.
      for (int y = 0; y < level.roughness.height(); ++y) {
        for (int x = 0; x < level.roughness.width(); ++x) {
          ASSERT_FLOAT_EQ(level.roughness(x, y), 0.1f) << GlossModelName(model);
        }
      }
    }
    EXPECT_NEAR(masked.back().normal_in_tangent(0, 0, 0), 0.6f, 1e-6);
    std::vector<GlossMipLevel> unmasked;
    BuildGlossMipChain(options, normals, nullptr, nullptr, &unmasked);
    EXPECT_GT(unmasked.back().roughness(0, 0), 0.15f) << GlossModelName(model);
  }
  const ImageU8 wrong(9, 5, 1);
  EXPECT_THROW(BuildGlossMipChain(GlossMipOptions{}, normals, nullptr, &wrong, &output), std::invalid_argument);
}

TEST(GlossMipChain, GgxFieldPushesItsAlphaIntoTheDeepMips) {
  constexpr int kSize = 128;  // 16384 samples of the NDF
  constexpr double kBase = 0.01;
  for (const double alpha_true : {0.15, 0.4}) {
    const ImageF normals = GgxNormalField(kSize, kSize, alpha_true, 7 + static_cast<uint64_t>(alpha_true * 100));
    // The sample mean of n.z and its standard error, for the tolerance.
    double sum = 0, sum2 = 0;
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        sum += normals(x, y, 2);
        sum2 += static_cast<double>(normals(x, y, 2)) * normals(x, y, 2);
      }
    }
    const double n = kSize * kSize;
    const double standard_error = std::sqrt((sum2 / n - (sum / n) * (sum / n)) / n);
    for (const Model model : {Model::kVmf, Model::kGgxNormalLength}) {
      GlossMipOptions options;
      options.model = model;
      options.base_roughness = kBase;
      GlossMipSummary summary;
      std::vector<GlossMipLevel> levels;
      summary = BuildGlossMipChain(options, normals, nullptr, nullptr, &levels);
      ASSERT_EQ(levels.size(), 8u);
      ExpectWellFormed(levels);
      ASSERT_EQ(summary.mean_roughness.size(), levels.size());
      EXPECT_NEAR(summary.mean_roughness[0], kBase, 1e-9);
      for (size_t l = 1; l < levels.size(); ++l) {
        EXPECT_GT(summary.mean_roughness[l], summary.mean_roughness[l - 1])
            << GlossModelName(model) << " level " << l << " alpha_true " << alpha_true;
      }
      const double deep = levels.back().roughness(0, 0);
      if (model == Model::kGgxNormalLength) {
        // Seed 004 eq. 34: lengths multiply, so the 1x1 mip is the GGX alpha
        // whose length is L(base) * L(alpha_true) -- about alpha_true.
        const double length = GgxAlphaToNormalLength(kBase) * GgxAlphaToNormalLength(alpha_true);
        const double expected = NormalLengthToGgxAlpha(length);
        const double tolerance =
            std::abs(NormalLengthToGgxAlpha(length - 5 * standard_error) - expected) + 1e-4;
        EXPECT_NEAR(deep, expected, tolerance) << "alpha_true " << alpha_true;
        EXPECT_NEAR(deep, alpha_true, 0.01 + tolerance) << "alpha_true " << alpha_true;
      } else {
        // The vMF fit of a GGX lobe is of the same order, not equal.
        EXPECT_GT(deep, 0.5 * alpha_true) << "alpha_true " << alpha_true;
        EXPECT_LT(deep, 2.0 * alpha_true) << "alpha_true " << alpha_true;
      }
    }
  }
}

TEST(GlossMipChain, DegenerateInputsGiveNoNan) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const Model model : {Model::kVmf, Model::kGgxNormalLength}) {
    GlossMipOptions options;
    options.model = model;
    // 1x1, 1xN, Nx1.
    for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {1, 7}, {7, 1}}) {
      const ImageF normals = GgxNormalField(w, h, 0.5, 3);
      GlossMipSummary summary;
      std::vector<GlossMipLevel> levels;
      summary = BuildGlossMipChain(options, normals, nullptr, nullptr, &levels);
      ExpectWellFormed(levels);
      EXPECT_EQ(summary.termination, Termination::kSuccess);
      EXPECT_TRUE(levels.back().roughness.SameSize(1, 1));
    }
    // Zero, NaN and opposed normals, a roughness map with NaN and out-of-range values.
    ImageF normals = ConstantNormals(4, 2, 0, 0, 1);
    ImageF roughness(4, 2, 1, 0.2f);
    normals(0, 0, 2) = 0;                         // zero length
    normals(1, 0, 0) = nan;                       // non-finite
    normals(3, 0, 2) = -1;                        // facing down: valid, averaged like any other
    roughness(0, 1) = nan;
    roughness(1, 1) = 2.0f;
    roughness(2, 1) = 0.0f;
    GlossMipSummary summary;
    std::vector<GlossMipLevel> levels;
    summary = BuildGlossMipChain(options, normals, &roughness, nullptr, &levels);
    ExpectWellFormed(levels);
    EXPECT_EQ(summary.invalid_normals, 2u);
    EXPECT_EQ(summary.clamped_roughness, 3u);
    EXPECT_THAT(summary.message, ::testing::HasSubstr("2 invalid normals"));
    // The footprint of level-1 texel (0, 0) holds one zero, one NaN normal
    // and two valid ones: only the valid ones count.
    EXPECT_FLOAT_EQ(levels[1].normal_in_tangent(0, 0, 2), 1.0f);
    // Opposed normals: the mean has length 0, the roughest alpha.
    ImageF opposed(2, 1, 3);
    opposed(0, 0, 2) = 1;
    opposed(1, 0, 2) = -1;
    std::vector<GlossMipLevel> opposed_levels;
    BuildGlossMipChain(options, opposed, nullptr, nullptr, &opposed_levels);
    ExpectWellFormed(opposed_levels);
    EXPECT_EQ(opposed_levels[1].roughness(0, 0), 1.0f);
    // Nothing valid at all: flat, base roughness, reported as a failure.
    const ImageF zeros(5, 3, 3, 0.0f);
    std::vector<GlossMipLevel> zero_levels;
    summary = BuildGlossMipChain(options, zeros, nullptr, nullptr, &zero_levels);
    ExpectWellFormed(zero_levels);
    EXPECT_EQ(summary.termination, Termination::kFailure);
    EXPECT_THAT(summary.message, ::testing::HasSubstr("no valid normal"));
    EXPECT_FLOAT_EQ(zero_levels.back().roughness(0, 0), static_cast<float>(options.base_roughness));
  }
}

TEST(GlossMipChain, BadOptionsAndShapesAreNamed) {
  std::vector<GlossMipLevel> output;
  const ImageF normals = ConstantNormals(4, 4, 0, 0, 1);
  auto expect_error = [&](const GlossMipOptions& options, const ImageF& n, const ImageF* r, const std::string& text) {
    try {
      BuildGlossMipChain(options, n, r, nullptr, &output);
      ADD_FAILURE() << "no error for " << text;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(text));
    }
  };
  GlossMipOptions options;
  options.base_roughness = 0;
  expect_error(options, normals, nullptr, "GlossMipOptions.base_roughness = 0");
  options.base_roughness = 1.5;
  expect_error(options, normals, nullptr, "base_roughness = 1.5");
  options = {};
  options.max_levels = -1;
  expect_error(options, normals, nullptr, "GlossMipOptions.max_levels = -1");
  options = {};
  expect_error(options, ImageF(4, 4, 1), nullptr, "normal_in_tangent is 4x4x1");
  expect_error(options, ImageF(), nullptr, "normal_in_tangent is 0x0x0");
  const ImageF small_roughness(3, 4, 1);
  expect_error(options, normals, &small_roughness, "roughness is 3x4x1, must be 4x4x1");

  EXPECT_EQ(GlossModelFromName("vmf"), Model::kVmf);
  EXPECT_EQ(GlossModelFromName("ggx"), Model::kGgxNormalLength);
  EXPECT_STREQ(GlossModelName(GlossModelFromName("ggx")), "ggx");
  try {
    GlossModelFromName("phong");
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("'phong'"));
  }
}

TEST(GlossMipChain, ProgressRisesToOneOverTheLevels) {
  const ImageF normals = ConstantNormals(37, 20, 0, 0, 1);
  std::vector<double> fractions;
  std::vector<GlossMipLevel> levels;
  const GlossMipSummary summary = BuildGlossMipChain({}, normals, nullptr, nullptr, &levels, [&](double f) {
    fractions.push_back(f);
    return true;
  });
  ASSERT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  EXPECT_EQ(fractions.size(), levels.size()) << "one report per level";
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_EQ(fractions.back(), 1.0);
}

TEST(GlossMipChain, CancelLeavesNoLevels) {
  const ImageF normals = ConstantNormals(37, 20, 0, 0, 1);
  for (int allowed_calls : {0, 3}) {
    int calls = 0;
    std::vector<GlossMipLevel> levels(2);
    const GlossMipSummary summary = BuildGlossMipChain({}, normals, nullptr, nullptr, &levels,
                                                       [&](double) { return calls++ < allowed_calls; });
    EXPECT_EQ(summary.termination, Termination::kCancelled) << allowed_calls;
    EXPECT_EQ(calls, allowed_calls + 1) << "no level after the cancel";
    EXPECT_TRUE(levels.empty());
    EXPECT_THAT(summary.BriefReport(), ::testing::HasSubstr("cancelled"));
  }
}

TEST(GlossMipChain, NullOutputThrowsAndBriefReportGivesTheFigures) {
  const ImageF normals = ConstantNormals(9, 5, 0, 0, 1);
  EXPECT_THROW(BuildGlossMipChain({}, normals, nullptr, nullptr, nullptr), std::invalid_argument);
  std::vector<GlossMipLevel> levels;
  const GlossMipSummary summary = BuildGlossMipChain({}, normals, nullptr, nullptr, &levels);
  EXPECT_THAT(summary.BriefReport(), ::testing::HasSubstr("(vmf): success, " + std::to_string(levels.size()) +
                                                          " levels, mean GGX alpha " +
                                                          Fixed(summary.mean_roughness.front(), 3)));
}

}  // namespace
}  // namespace scanbench
