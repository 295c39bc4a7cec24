#include "maps/surface_occlusion.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/sim/simulated_rig.h"
#include "app/sim/textile_scene.h"
#include "core/format.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;

constexpr double kPi = std::numbers::pi;

// The map alone, for checks that look only at it; the call must succeed.
ImageF Occlusion(const AmbientOcclusionOptions& options, const ImageF& height_mm) {
  ImageF visibility;
  const OcclusionSummary summary = AmbientOcclusionFromHeight(options, height_mm, &visibility);
  EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  return visibility;
}

ImageF Cavity(const CavityOptions& options, const ImageF& height_mm) {
  ImageF cavity;
  const OcclusionSummary summary = CavityFromHeight(options, height_mm, &cavity);
  EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  return cavity;
}

double Radians(double degrees) { return degrees * kPi / 180.0; }

// Portable uniform [0, 1) from the raw engine output (std::uniform_real_distribution
// differs between standard libraries).
double Uniform(std::mt19937_64& engine) { return static_cast<double>(engine() >> 11) * 0x1.0p-53; }

// Height map whose pixel (x, y) samples height(x_mm, y_mm) with the origin at
// pixel (cx, cy) = the image centre.
ImageF MakeHeight(int width, int rows, double mm_per_pixel, const std::function<double(double, double)>& height) {
  ImageF map(width, rows, 1);
  const int cx = width / 2, cy = rows / 2;
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < width; ++x) {
      map(x, y) = static_cast<float>(height((x - cx) * mm_per_pixel, (y - cy) * mm_per_pixel));
    }
  }
  return map;
}

AmbientOcclusionOptions AoOptions(double mm_per_pixel, double radius_mm) {
  AmbientOcclusionOptions options;
  options.mm_per_pixel = mm_per_pixel;
  options.radius_mm = radius_mm;
  return options;
}

// The reference: bilinear height field with clamp-to-edge, written out
// independently of the implementation.
double Bilinear(const ImageF& map, double x, double y) {
  x = std::clamp(x, 0.0, map.width() - 1.0);
  y = std::clamp(y, 0.0, map.height() - 1.0);
  const int x0 = std::min(static_cast<int>(x), map.width() - 1), y0 = std::min(static_cast<int>(y), map.height() - 1);
  const int x1 = std::min(x0 + 1, map.width() - 1), y1 = std::min(y0 + 1, map.height() - 1);
  const double fx = x - x0, fy = y - y0;
  return (1 - fy) * ((1 - fx) * map(x0, y0) + fx * map(x1, y0)) + fy * ((1 - fx) * map(x0, y1) + fx * map(x1, y1));
}

// The pixel normal (x right, y down the rows, z up) from central differences
// of the height, one-sided at the border.
Eigen::Vector3d PixelNormal(const ImageF& map, int x, int y, double mm_per_pixel) {
  const int left = std::max(x - 1, 0), right = std::min(x + 1, map.width() - 1);
  const int up = std::max(y - 1, 0), down = std::min(y + 1, map.height() - 1);
  const double gx = right > left ? (map(right, y) - map(left, y)) / ((right - left) * mm_per_pixel) : 0;
  const double gy = down > up ? (map(x, down) - map(x, up)) / ((down - up) * mm_per_pixel) : 0;
  return Eigen::Vector3d(-gx, -gy, 1).normalized();
}

// Brute force eq. 43: cosine-weighted rays from pixel (px, py) over the
// hemisphere around `normal`, stratified n x n in the two uniform variables,
// each marched in 0.2 px steps out to radius_mm horizontally; the fraction
// that never passes under the surface.
double MonteCarloVisibility(const ImageF& map, int px, int py, double mm_per_pixel, double radius_mm, int n,
                            std::mt19937_64& engine, const Eigen::Vector3d& normal = Eigen::Vector3d::UnitZ()) {
  const double h0 = map(px, py);
  const double radius_px = radius_mm / mm_per_pixel;
  const double step_px = 0.2;
  // A frame around the normal.
  const Eigen::Vector3d helper = std::abs(normal.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d b1 = normal.cross(helper).normalized(), b2 = normal.cross(b1);
  int visible = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double u1 = (i + Uniform(engine)) / n, u2 = (j + Uniform(engine)) / n;
      // Cosine-weighted: sin(theta) = sqrt(u1) uniform over the projected disk.
      const double sin_theta = std::sqrt(u1), cos_theta = std::sqrt(1 - u1);
      const double azimuth = 2 * kPi * u2;
      const Eigen::Vector3d ray =
          sin_theta * std::cos(azimuth) * b1 + sin_theta * std::sin(azimuth) * b2 + cos_theta * normal;
      const double horizontal = std::hypot(ray.x(), ray.y());
      if (horizontal < 1e-12) {
        ++visible;
        continue;
      }
      const double dir_x = ray.x() / horizontal, dir_y = ray.y() / horizontal;
      const double rise_per_mm = ray.z() / horizontal;
      bool blocked = false;
      for (double s = step_px; s <= radius_px && !blocked; s += step_px) {
        const double h = Bilinear(map, px + s * dir_x, py + s * dir_y);
        blocked = h > h0 + rise_per_mm * s * mm_per_pixel;
      }
      if (!blocked) ++visible;
    }
  }
  return static_cast<double>(visible) / (n * n);
}

// ----------------------------------------------------------------------------
// Ambient occlusion: exact and analytic cases.

TEST(AmbientOcclusion, FlatHeightIsExactlyOneEverywhere) {
  for (float level : {0.0f, 3.7f, -1250.25f}) {
    const ImageF flat(37, 23, 1, level);
    OcclusionSummary summary;
    AmbientOcclusionOptions options = AoOptions(0.1, 1.0);
    options.around_pixel_normal = true;
    ImageF around_pixel_normal;
    AmbientOcclusionFromHeight(options, flat, &around_pixel_normal);
    for (size_t i = 0; i < around_pixel_normal.size(); ++i) ASSERT_EQ(around_pixel_normal.data()[i], 1.0f) << i;
    ImageF ao;
    summary = AmbientOcclusionFromHeight(AoOptions(0.1, 1.0), flat, &ao);
    ASSERT_TRUE(ao.SameSize(flat));
    ASSERT_EQ(ao.channels(), 1);
    for (size_t i = 0; i < ao.size(); ++i) ASSERT_EQ(ao.data()[i], 1.0f) << i;
    EXPECT_EQ(summary.termination, Termination::kSuccess);
    EXPECT_EQ(summary.min, 1.0);
    EXPECT_EQ(summary.max, 1.0);
    EXPECT_EQ(summary.steps_per_direction, 10);
    EXPECT_THAT(summary.message, HasSubstr("37x23"));
  }
}

// Bottom of an infinitely long V-groove with walls rising at beta: every
// azimuth sees a plane, the horizon at tan(h) = tan(beta) |cos(azimuth)|, and
// the cosine-weighted visibility is the view factor to the opening, cos(beta).
// The wall is linear between pixels, so bilinear sampling is exact and the
// only error is the azimuth quadrature (1e-6 at 45 deg, 1.5e-4 at 60 deg with
// 16 directions).
TEST(AmbientOcclusion, VGrooveBottomSeesCosBeta) {
  const double mm_per_pixel = 0.1;
  for (double beta_deg : {15.0, 30.0, 45.0, 60.0}) {
    const double slope = std::tan(Radians(beta_deg));
    const ImageF height = MakeHeight(81, 61, mm_per_pixel, [&](double x, double) { return std::abs(x) * slope; });
    AmbientOcclusionOptions options = AoOptions(mm_per_pixel, 2.0);
    for (bool around_pixel_normal : {false, true}) {  // the normal at the bottom is (0, 0, 1) either way
      options.around_pixel_normal = around_pixel_normal;
      ImageF ao;
      AmbientOcclusionFromHeight(options, height, &ao);
      for (int y : {0, 30, 60}) {  // along the groove, edge rows included (clamp keeps the groove infinite)
        EXPECT_NEAR(ao(40, y), std::cos(Radians(beta_deg)), 3e-4) << beta_deg << " deg, row " << y;
      }
    }
  }
}

TEST(AmbientOcclusion, FewerDirectionsConvergeTowardsTheExactGroove) {
  const double mm_per_pixel = 0.1, slope = std::tan(Radians(60));
  const ImageF height = MakeHeight(41, 41, mm_per_pixel, [&](double x, double) { return std::abs(x) * slope; });
  double previous_error = 1;
  for (int directions : {4, 8, 16, 32}) {
    AmbientOcclusionOptions options = AoOptions(mm_per_pixel, 1.0);
    options.num_directions = directions;
    const double error = std::abs(Occlusion(options, height)(20, 20) - 0.5);
    EXPECT_LT(error, previous_error) << directions;
    previous_error = error;
  }
  EXPECT_LT(previous_error, 1e-5);
}

// Open plane tilted by a: the table-normal hemisphere loses the part below
// the plane, (1 - cos a) / 2 of its cosine weight.
TEST(AmbientOcclusion, OpenSlopeSeesHalfPlusHalfCos) {
  const double mm_per_pixel = 0.05;
  for (double a_deg : {10.0, 30.0, 50.0}) {
    const double slope = std::tan(Radians(a_deg));
    const ImageF height = MakeHeight(61, 61, mm_per_pixel, [&](double x, double y) { return (0.6 * x + 0.8 * y) * slope; });
    AmbientOcclusionOptions options = AoOptions(mm_per_pixel, 1.0);
    EXPECT_NEAR(Occlusion(options, height)(30, 30), 0.5 * (1 + std::cos(Radians(a_deg))),
                2e-3) << a_deg;
    // Around its own normal an open plane sees its whole hemisphere (the
    // azimuth quadrature of GTAO's slice integral is 4e-7 off at 50 degrees).
    options.around_pixel_normal = true;
    EXPECT_NEAR(Occlusion(options, height)(30, 30), 1.0, 1e-4) << a_deg;
  }
}

// Centre of the floor of a cylindrical well, radius r, depth d: the sky is
// the opening disk, view factor F(r) = r^2 / (r^2 + d^2). On pixels the rim is
// a step that the bilinear field smears outwards: full height only once all
// four neighbours lie outside (r + sqrt(2) px at most), found by samples 1 px
// apart (up to 1 px later). So the pixelated well is F(r) <= AO <= F(r + 2.5 px).
TEST(AmbientOcclusion, WellCentreSeesTheDiskViewFactor) {
  const double mm_per_pixel = 0.1, r = 2.05;
  auto view_factor = [](double radius, double depth) { return radius * radius / (radius * radius + depth * depth); };
  for (double d : {0.5, 1.0, 2.0, 4.0}) {
    const ImageF height = MakeHeight(81, 81, mm_per_pixel, [&](double x, double y) {
      return std::hypot(x, y) <= r ? 0.0 : d;
    });
    ImageF ao;
    AmbientOcclusionFromHeight(AoOptions(mm_per_pixel, 3.0), height, &ao);
    EXPECT_GE(ao(40, 40), view_factor(r, d)) << "depth " << d;
    EXPECT_LE(ao(40, 40), view_factor(r + 2.5 * mm_per_pixel, d)) << "depth " << d;
  }
}

TEST(AmbientOcclusion, OccludersBeyondTheRadiusAreIgnored) {
  const double mm_per_pixel = 0.1;
  const ImageF height = MakeHeight(81, 81, mm_per_pixel, [&](double x, double y) {
    return std::hypot(x, y) <= 2.05 ? 0.0 : 2.0;
  });
  ImageF ao;
  AmbientOcclusionFromHeight(AoOptions(mm_per_pixel, 1.9), height, &ao);
  EXPECT_EQ(ao(40, 40), 1.0f);
}

// ----------------------------------------------------------------------------
// Ambient occlusion against brute-force ray casting.

// Brute-force visibility at each of `pixels`: 1024 stratified rays each.
std::vector<double> MonteCarloReference(const ImageF& height, double mm_per_pixel, double radius_mm,
                                        const std::vector<std::pair<int, int>>& pixels, uint64_t seed,
                                        bool around_pixel_normal = false) {
  std::mt19937_64 engine(seed);
  std::vector<double> reference;
  for (const auto& [x, y] : pixels) {
    const Eigen::Vector3d normal =
        around_pixel_normal ? PixelNormal(height, x, y, mm_per_pixel) : Eigen::Vector3d::UnitZ();
    reference.push_back(MonteCarloVisibility(height, x, y, mm_per_pixel, radius_mm, 32, engine, normal));
  }
  return reference;
}

double MeanAbsDifference(const ImageF& ao, const std::vector<std::pair<int, int>>& pixels,
                         const std::vector<double>& reference) {
  double sum = 0;
  for (size_t i = 0; i < pixels.size(); ++i) sum += std::abs(ao(pixels[i].first, pixels[i].second) - reference[i]);
  return sum / pixels.size();
}

double Mean(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return sum / values.size();
}

std::vector<std::pair<int, int>> RandomPixels(int width, int rows, int count, uint64_t seed) {
  std::mt19937_64 engine(seed);
  std::vector<std::pair<int, int>> pixels;
  for (int i = 0; i < count; ++i) {
    pixels.emplace_back(static_cast<int>(Uniform(engine) * width), static_cast<int>(Uniform(engine) * rows));
  }
  return pixels;
}

// The bound on mean |AO - Monte Carlo| over the sampled pixels. Measured with
// the defaults (16 directions, samples 1 px apart): 0.0020 on the bumps
// (0.0016 around the pixel normal), 0.0013 on the textile, which is the Monte
// Carlo noise floor (the same figure with 64 directions and 128 steps); 8
// samples spread quadratically over 20 px measure 0.0019. Weighting the
// horizon by cos(h) (uniform, not cosine, visibility) instead of cos^2(h)
// measures 0.046 and 0.0135: 0.006 fails that.
constexpr double kMonteCarloBound = 0.006;

TEST(AmbientOcclusion, MatchesMonteCarloOnRandomBumps) {
  // 60 Gaussian bumps and pits, 0.3 .. 1.5 mm wide, up to 1.3 mm high.
  std::mt19937_64 engine(7);
  struct Bump { double x, y, sigma, amplitude; };
  std::vector<Bump> bumps;
  for (int i = 0; i < 60; ++i) {
    bumps.push_back({(Uniform(engine) - 0.5) * 14, (Uniform(engine) - 0.5) * 14, 0.3 + 1.2 * Uniform(engine),
                     (Uniform(engine) - 0.35) * 2.0});
  }
  const double mm_per_pixel = 0.1, radius_mm = 2.0;
  const ImageF height = MakeHeight(128, 128, mm_per_pixel, [&](double x, double y) {
    double h = 0;
    for (const Bump& b : bumps) h += b.amplitude * std::exp(-(std::pow(x - b.x, 2) + std::pow(y - b.y, 2)) / (2 * b.sigma * b.sigma));
    return h;
  });
  const std::vector<std::pair<int, int>> pixels = RandomPixels(128, 128, 300, 11);
  const std::vector<double> reference = MonteCarloReference(height, mm_per_pixel, radius_mm, pixels, 13);
  EXPECT_LT(Mean(reference), 0.95);  // the scene really occludes
  // 32 steps: one per pixel out to 20 px; 8 steps: spread quadratically.
  for (int max_steps : {32, 8}) {
    AmbientOcclusionOptions options = AoOptions(mm_per_pixel, radius_mm);
    options.max_steps = max_steps;
    const double difference = MeanAbsDifference(Occlusion(options, height), pixels, reference);
    std::printf("random bumps, %d steps: mean visibility %.4f, mean |AO - Monte Carlo| %.4f\n", max_steps,
                Mean(reference), difference);
    EXPECT_LT(difference, kMonteCarloBound) << max_steps;
  }
  // Around each pixel's own normal.
  const std::vector<double> reference_pixel_normal =
      MonteCarloReference(height, mm_per_pixel, radius_mm, pixels, 23, /*around_pixel_normal=*/true);
  AmbientOcclusionOptions options = AoOptions(mm_per_pixel, radius_mm);
  options.around_pixel_normal = true;
  const double difference =
      MeanAbsDifference(Occlusion(options, height), pixels, reference_pixel_normal);
  std::printf("random bumps, pixel normal: mean visibility %.4f, mean |AO - Monte Carlo| %.4f\n",
              Mean(reference_pixel_normal), difference);
  EXPECT_GT(Mean(reference_pixel_normal), Mean(reference));  // slopes no longer count as occlusion
  EXPECT_LT(difference, kMonteCarloBound);
}

// Relief at the pixel scale: 0.35 mm ripples over 0.116 mm pixels (3 px per
// wave) on a creased weave. Occluders within the first pixel matter here: the
// march also takes the slope at which the bilinear field leaves the pixel;
// with samples from 1 px on alone this measured 0.0102 (now 0.0035).
TEST(AmbientOcclusion, MatchesMonteCarloOnPixelScaleRelief) {
  const double mm_per_pixel = 0.116, radius_mm = 1.5, two_pi = 2 * kPi;
  const ImageF height = MakeHeight(160, 160, mm_per_pixel, [&](double u, double v) {
    return 0.2 * std::abs(std::sin(two_pi * u / 2.4)) * std::abs(std::cos(two_pi * v / 3.0)) +
           0.02 * std::sin(two_pi * (u + 0.7 * v) / 0.35);
  });
  const std::vector<std::pair<int, int>> pixels = RandomPixels(160, 160, 200, 29);
  const std::vector<double> reference = MonteCarloReference(height, mm_per_pixel, radius_mm, pixels, 31);
  const double difference = MeanAbsDifference(
      Occlusion(AoOptions(mm_per_pixel, radius_mm), height), pixels, reference);
  std::printf("pixel-scale relief: mean visibility %.4f, mean |AO - Monte Carlo| %.4f\n", Mean(reference), difference);
  EXPECT_LT(difference, kMonteCarloBound);
}

TEST(AmbientOcclusion, MatchesMonteCarloOnTheSimulatedTextile) {
  // Quarter-resolution capture (0.116 mm/px, about 20 px per thread); AO on a
  // 160 x 160 window at the centre of the sample.
  SimulatedRigOptions rig_options;
  rig_options.width = kD5100Width / 4;
  rig_options.height = kD5100Height / 4;
  rig_options.add_noise = false;
  const SimulatedRig rig(rig_options, TextileScene(), MakeDefaultSimulatedRig(rig_options.width, rig_options.height));
  const GroundTruthMaps truth = rig.RenderGroundTruth();
  const int size = 160, x0 = (truth.height_mm.width() - size) / 2, y0 = (truth.height_mm.height() - size) / 2;
  ImageF window(size, size, 1);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      ASSERT_EQ(truth.sample_mask(x0 + x, y0 + y), 1);
      window(x, y) = truth.height_mm(x0 + x, y0 + y);
    }
  }
  const AmbientOcclusionOptions options = AoOptions(truth.mm_per_pixel, 1.5);
  const std::vector<std::pair<int, int>> pixels = RandomPixels(size, size, 300, 17);
  const std::vector<double> reference = MonteCarloReference(window, options.mm_per_pixel, options.radius_mm, pixels, 19);
  const double difference = MeanAbsDifference(Occlusion(options, window), pixels, reference);
  std::printf("textile at %.4f mm/px: mean visibility %.4f, mean |AO - Monte Carlo| %.4f\n", truth.mm_per_pixel,
              Mean(reference), difference);
  EXPECT_LT(Mean(reference), 0.985);  // thread relief is shallow, but it occludes
  EXPECT_LT(difference, kMonteCarloBound);
}

// ----------------------------------------------------------------------------
// Ambient occlusion: mechanics.

TEST(AmbientOcclusion, ResultDoesNotDependOnTheThreadCount) {
  std::mt19937_64 engine(3);
  ImageF height(57, 41, 1);
  for (size_t i = 0; i < height.size(); ++i) height.data()[i] = static_cast<float>(Uniform(engine));
  AmbientOcclusionOptions options = AoOptions(0.1, 1.2);
  options.num_threads = 1;
  ImageF one;
  AmbientOcclusionFromHeight(options, height, &one);
  options.num_threads = 3;
  ImageF three;
  AmbientOcclusionFromHeight(options, height, &three);
  for (size_t i = 0; i < one.size(); ++i) {
    ASSERT_EQ(one.data()[i], three.data()[i]) << i;
    ASSERT_GE(one.data()[i], 0.0f);
    ASSERT_LE(one.data()[i], 1.0f);
  }
}

TEST(AmbientOcclusion, CancelReturnsCancelledAndAnEmptyImage) {
  const ImageF flat(64, 64, 1, 0.0f);
  for (int allowed_calls : {0, 1}) {
    int calls = 0;
    OcclusionSummary summary;
    ImageF ao;
    summary =
        AmbientOcclusionFromHeight(AoOptions(0.1, 1.0), flat, &ao, [&](double) { return calls++ < allowed_calls; });
    EXPECT_EQ(summary.termination, Termination::kCancelled) << allowed_calls;
    EXPECT_TRUE(ao.empty());
  }
}

TEST(AmbientOcclusion, AnExceptionFromProgressReachesTheCaller) {
  ImageF output;
  AmbientOcclusionOptions options = AoOptions(0.1, 0.5);
  options.num_threads = 2;
  int calls = 0;
  EXPECT_THROW(AmbientOcclusionFromHeight(options, ImageF(20, 200, 1, 0.0f), &output, [&](double) -> bool {
                                            if (++calls == 2) throw std::runtime_error("stop");
                                            return true;
                                          }),
               std::runtime_error);
}

TEST(AmbientOcclusion, ProgressRisesToOne) {
  ImageF output;
  std::vector<double> fractions;
  AmbientOcclusionFromHeight(AoOptions(0.1, 0.5), ImageF(20, 50, 1, 0.0f), &output, [&](double f) {
    fractions.push_back(f);
    return true;
  });
  ASSERT_GE(fractions.size(), 2u);
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_EQ(fractions.back(), 1.0);
}

TEST(AmbientOcclusion, CheckNamesTheBadField) {
  ImageF output;
  auto message = [](const AmbientOcclusionOptions& options) {
    try {
      options.Check();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  AmbientOcclusionOptions options;
  EXPECT_EQ(message(options), "no error");
  options.mm_per_pixel = 0;
  EXPECT_THAT(message(options), HasSubstr("AmbientOcclusionOptions.mm_per_pixel = 0 must be"));
  options = {};
  options.radius_mm = -1;
  EXPECT_THAT(message(options), HasSubstr("radius_mm = -1"));
  options = {};
  options.num_directions = 3;
  EXPECT_THAT(message(options), HasSubstr("num_directions = 3 must be in [4, 1024]"));
  options = {};
  options.max_steps = 0;
  EXPECT_THAT(message(options), HasSubstr("max_steps = 0"));
  options = {};
  options.num_threads = -1;
  EXPECT_THAT(message(options), HasSubstr("num_threads = -1"));
  options = {};
  options.num_directions = 2;
  EXPECT_THROW(AmbientOcclusionFromHeight(options, ImageF(4, 4, 1), &output), std::invalid_argument);
}

TEST(AmbientOcclusion, BadShapesAndNonFiniteHeightsAreNamed) {
  ImageF output;
  try {
    AmbientOcclusionFromHeight(AmbientOcclusionOptions(), ImageF(5, 4, 3), &output);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("5x4x3"));
  }
  EXPECT_THROW(AmbientOcclusionFromHeight(AmbientOcclusionOptions(), ImageF(), &output), std::invalid_argument);
  ImageF height(5, 4, 1);
  height(2, 3) = std::nanf("");
  try {
    AmbientOcclusionFromHeight(AmbientOcclusionOptions(), height, &output);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("height_mm(2, 3) = nan"));
  }
}

// ----------------------------------------------------------------------------
// Cavity.

CavityOptions CavityOptionsFor(double mm_per_pixel, double radius_mm, double depth_scale_mm) {
  CavityOptions options;
  options.mm_per_pixel = mm_per_pixel;
  options.radius_mm = radius_mm;
  options.depth_scale_mm = depth_scale_mm;
  return options;
}

TEST(Cavity, FlatHeightIsExactlyOneEverywhere) {
  for (float level : {0.0f, 0.3f, -77.125f}) {
    OcclusionSummary summary;
    ImageF cavity;
    summary = CavityFromHeight(CavityOptions(), ImageF(45, 31, 1, level), &cavity);
    for (size_t i = 0; i < cavity.size(); ++i) ASSERT_EQ(cavity.data()[i], 1.0f) << i;
    EXPECT_EQ(summary.termination, Termination::kSuccess);
    EXPECT_EQ(summary.mean, 1.0);
  }
}

// A Gaussian pit of width s and depth D blurred by sigma is a Gaussian of
// width sqrt(s^2 + sigma^2) holding the same volume, so at the centre the
// neighbourhood mean lies D s^2 / (s^2 + sigma^2) below the table and the pit
// is D sigma^2 / (s^2 + sigma^2) below its neighbourhood.
TEST(Cavity, GaussianPitCentreMatchesTheBlurredGaussian) {
  const double mm_per_pixel = 0.05, s = 0.5, sigma = 1.0, scale = 0.2;
  for (double depth : {0.05, 0.1, 0.2}) {
    const ImageF height = MakeHeight(161, 161, mm_per_pixel, [&](double x, double y) {
      return 1.0 - depth * std::exp(-(x * x + y * y) / (2 * s * s));
    });
    ImageF cavity;
    CavityFromHeight(CavityOptionsFor(mm_per_pixel, sigma, scale), height, &cavity);
    const double below = depth * sigma * sigma / (s * s + sigma * sigma);
    EXPECT_NEAR(cavity(80, 80), std::max(0.0, 1 - below / scale), 2e-3) << depth;
    EXPECT_NEAR(cavity(0, 0), 1.0, 1e-5);  // far away: flat
  }
  // Deeper than depth_scale_mm below the neighbourhood saturates at 0; a bump is 1.
  const ImageF deep = MakeHeight(161, 161, mm_per_pixel, [&](double x, double y) {
    return -1.0 * std::exp(-(x * x + y * y) / (2 * s * s));
  });
  EXPECT_EQ(Cavity(CavityOptionsFor(mm_per_pixel, sigma, scale), deep)(80, 80), 0.0f);
  const ImageF bump = MakeHeight(161, 161, mm_per_pixel, [&](double x, double y) {
    return 1.0 * std::exp(-(x * x + y * y) / (2 * s * s));
  });
  EXPECT_EQ(Cavity(CavityOptionsFor(mm_per_pixel, sigma, scale), bump)(80, 80), 1.0f);
}

// The default Gaussian on a grid 4x coarser (sigma 1 mm = 33 px at 0.03 mm/px,
// the 16 MP rig's pitch) against cv::GaussianBlur at full resolution
// (min_coarse_sigma_px = 0), on a fold, a weave of ridges, random bumps and
// a step, with a size that is no multiple of 4 so the last blocks are partial.
// On the 16 MP export: max 1.7e-4, RMS 1.4e-5 (docs/derived-maps.md); the
// bicubic of cv::resize (Keys, a = -0.75: first order) measured 0.01 there.
TEST(Cavity, CoarseGridGaussianMatchesTheFullResolutionOne) {
  std::mt19937_64 engine(23);
  struct Bump { double x, y, sigma, amplitude; };
  std::vector<Bump> bumps;
  for (int i = 0; i < 40; ++i) {
    bumps.push_back({(Uniform(engine) - 0.5) * 18, (Uniform(engine) - 0.5) * 12, 0.1 + 0.5 * Uniform(engine),
                     (Uniform(engine) - 0.5) * 0.4});
  }
  const double mm_per_pixel = 0.03;
  const ImageF height = MakeHeight(601, 403, mm_per_pixel, [&](double x, double y) {
    double h = 0.8 * std::sin(x / 3.0) + 0.05 * std::sin(x / 0.13) * std::cos(y / 0.11) + (y > 2.0 ? 0.3 : 0.0);
    for (const Bump& b : bumps) h += b.amplitude * std::exp(-(std::pow(x - b.x, 2) + std::pow(y - b.y, 2)) / (2 * b.sigma * b.sigma));
    return h;
  });
  CavityOptions exact = CavityOptionsFor(mm_per_pixel, 1.0, 0.2);
  exact.min_coarse_sigma_px = 0;
  const CavityOptions coarse = CavityOptionsFor(mm_per_pixel, 1.0, 0.2);  // the default 8 px: 4x coarser
  ASSERT_EQ(coarse.min_coarse_sigma_px, 8.0);
  const ImageF a = Cavity(exact, height), b = Cavity(coarse, height);
  ASSERT_TRUE(a.SameSize(b));
  double max_difference = 0, sum_difference = 0, sum_a = 0;
  int open = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = static_cast<double>(b.data()[i]) - a.data()[i];
    max_difference = std::max(max_difference, std::abs(d));
    sum_difference += d;
    sum_a += a.data()[i];
    if (a.data()[i] < 1.0f) ++open;
  }
  std::printf("coarse-grid cavity: max |difference| %.3g, mean difference %.3g, mean %.4f, %d of %zu below 1\n",
              max_difference, sum_difference / a.size(), sum_a / a.size(), open, a.size());
  EXPECT_GT(open, static_cast<int>(a.size() / 4));  // the relief reaches the cavity's range
  EXPECT_LT(max_difference, 4e-4);
  EXPECT_LT(std::abs(sum_difference) / a.size(), 1e-5);
}

TEST(Cavity, CheckNamesTheBadField) {
  ImageF output;
  EXPECT_NO_THROW(CavityOptions().Check());
  CavityOptions options;
  options.depth_scale_mm = 0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  try {
    options.Check();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("CavityOptions.depth_scale_mm = 0 must be"));
  }
  options = {};
  options.min_coarse_sigma_px = 1;  // a coarse grid as fine as the Gaussian's own width
  try {
    options.Check();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("CavityOptions.min_coarse_sigma_px = 1 must be 0 or"));
  }
  options.min_coarse_sigma_px = 0;
  EXPECT_NO_THROW(options.Check());
  options = {};
  options.radius_mm = 200;  // 2000 px at 0.1 mm
  try {
    CavityFromHeight(options, ImageF(4, 4, 1), &output);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("CavityOptions.radius_mm = 200 must be at most 1000 pixels"));
  }
  try {
    CavityFromHeight(CavityOptions(), ImageF(4, 6, 2), &output);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("4x6x2"));
  }
}

// ----------------------------------------------------------------------------
// Eq. 49.

TEST(AdjustOcclusionForAlbedo, BlackKeepsAWhiteGivesOneAndItRisesWithAlbedo) {
  const int n = 11;
  ImageF visibility(n, 1, 1);
  for (int i = 0; i < n; ++i) visibility(i, 0) = static_cast<float>(i) / (n - 1);
  const ImageF black = AdjustOcclusionForAlbedo(visibility, ImageF(n, 1, 3, 0.0f));
  const ImageF white = AdjustOcclusionForAlbedo(visibility, ImageF(n, 1, 3, 1.0f));
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(black(i, 0), visibility(i, 0)) << i;
    EXPECT_EQ(white(i, 0), 1.0f) << i;  // A = 0 too: a furnace of perfect reflectors
  }
  // Monotone in rho at fixed A, and in A at fixed rho.
  for (int i = 0; i < n; ++i) {
    float previous = -1;
    for (double rho = 0; rho <= 1.0001; rho += 0.1) {
      const float adjusted = AdjustOcclusionForAlbedo(visibility, ImageF(n, 1, 1, static_cast<float>(rho)))(i, 0);
      EXPECT_GE(adjusted, previous) << i << " " << rho;
      EXPECT_GE(adjusted, visibility(i, 0));
      previous = adjusted;
    }
  }
  const ImageF grey = AdjustOcclusionForAlbedo(visibility, ImageF(n, 1, 1, 0.5f));
  for (int i = 1; i < n; ++i) EXPECT_GT(grey(i, 0), grey(i - 1, 0));
  // The formula itself at A = 0.4, rho = 0.5: 0.4 / 0.7.
  EXPECT_NEAR(grey(4, 0), 0.4 / 0.7, 1e-6);
}

TEST(AdjustOcclusionForAlbedo, UsesRec709LuminanceAndClamps) {
  ImageF visibility(3, 1, 1, 0.5f);
  visibility(2, 0) = 1.7f;  // out of range: clamped to 1
  ImageF albedo(3, 1, 3, 0.0f);
  albedo(0, 0, 1) = 1.0f;  // pure green: rho = 0.7152
  albedo(1, 0, 0) = 2.0f;  // red beyond 1: rho = 0.4252
  const ImageF adjusted = AdjustOcclusionForAlbedo(visibility, albedo);
  EXPECT_NEAR(adjusted(0, 0), 0.5 / (1 - 0.7152 + 0.7152 * 0.5), 1e-6);
  EXPECT_NEAR(adjusted(1, 0), 0.5 / (1 - 0.4252 + 0.4252 * 0.5), 1e-6);
  EXPECT_EQ(adjusted(2, 0), 1.0f);
}

TEST(AdjustOcclusionForAlbedo, BadShapesAreNamed) {
  try {
    AdjustOcclusionForAlbedo(ImageF(4, 3, 1), ImageF(3, 4, 3));
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("3x4x3"));
    EXPECT_THAT(e.what(), HasSubstr("4x3x1"));
  }
  EXPECT_THROW(AdjustOcclusionForAlbedo(ImageF(4, 3, 2), ImageF(4, 3, 3)), std::invalid_argument);
  EXPECT_THROW(AdjustOcclusionForAlbedo(ImageF(4, 3, 1), ImageF(4, 3, 2)), std::invalid_argument);
  ImageF bad(4, 3, 1, 0.5f);
  bad(1, 1) = std::nanf("");
  EXPECT_THROW(AdjustOcclusionForAlbedo(bad, ImageF(4, 3, 1)), std::invalid_argument);
}

TEST(Cavity, CancelReturnsCancelledAndAnEmptyImage) {
  const ImageF flat(32, 32, 1, 0.0f);
  for (int allowed_calls : {0, 1}) {  // before and after the blur
    int calls = 0;
    ImageF cavity(4, 4, 1);
    const OcclusionSummary summary =
        CavityFromHeight(CavityOptionsFor(0.1, 0.5, 0.2), flat, &cavity,
                         [&](double) { return calls++ < allowed_calls; });
    EXPECT_EQ(summary.termination, Termination::kCancelled) << allowed_calls;
    EXPECT_TRUE(cavity.empty());
  }
}

TEST(Cavity, ProgressRisesToOne) {
  std::vector<double> fractions;
  ImageF cavity;
  CavityFromHeight(CavityOptionsFor(0.1, 0.5, 0.2), ImageF(20, 50, 1, 0.0f), &cavity, [&](double f) {
    fractions.push_back(f);
    return true;
  });
  ASSERT_GE(fractions.size(), 2u);
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_EQ(fractions.back(), 1.0);
}

TEST(Occlusion, NullOutputsThrowNamingThem) {
  try {
    AmbientOcclusionFromHeight(AmbientOcclusionOptions(), ImageF(4, 4, 1), nullptr);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("visibility must not be null"));
  }
  try {
    CavityFromHeight(CavityOptions(), ImageF(4, 4, 1), nullptr);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("cavity must not be null"));
  }
}

TEST(Occlusion, BriefReportNamesTheMapAndItsFigures) {
  const ImageF height = MakeHeight(40, 30, 0.1, [](double x, double y) { return 0.3 * std::sin(x) * std::cos(y); });
  ImageF map;
  const OcclusionSummary ao = AmbientOcclusionFromHeight(AoOptions(0.1, 0.5), height, &map);
  EXPECT_THAT(ao.BriefReport(), HasSubstr("Ambient occlusion: success, mean " + Fixed(ao.mean, 3)));
  EXPECT_THAT(ao.BriefReport(), HasSubstr(std::to_string(ao.steps_per_direction) + " steps per direction"));
  const OcclusionSummary cavity = CavityFromHeight(CavityOptionsFor(0.1, 0.5, 0.2), height, &map);
  EXPECT_THAT(cavity.BriefReport(), HasSubstr("Cavity: success, mean " + Fixed(cavity.mean, 3)));
  EXPECT_THAT(cavity.BriefReport(), ::testing::Not(HasSubstr("steps per direction")));
}

}  // namespace
}  // namespace scanbench
