#include "maps/height_from_normals.h"

#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/sim/simulated_rig.h"
#include "app/sim/textile_scene.h"
#include "core/format.h"
#include "tests/util/option_check.h"

namespace scanbench {
namespace {

using Method = HeightFromNormalsOptions::Method;
using ::testing::HasSubstr;

constexpr double kPi = std::numbers::pi;

// A height field in mm over pixel coordinates (x right, y = row, down), with
// its analytic derivatives in mm per pixel.
struct HeightField {
  std::function<double(double, double)> height;
  std::function<double(double, double)> d_dx;    // d height / d column
  std::function<double(double, double)> d_drow;  // d height / d row (down)
};

struct Scene {
  ImageF normal_in_tangent;
  ImageF height_mm;
};

// Exact normals in the tangent frame: x right, y up (towards row 0), so
// dz/dy_up = -dz/drow.
Scene Render(const HeightField& field, int width, int height, double mm_per_pixel) {
  Scene scene{ImageF(width, height, 3), ImageF(width, height, 1)};
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double slope_x = field.d_dx(x, y) / mm_per_pixel;
      const double slope_y_up = -field.d_drow(x, y) / mm_per_pixel;
      const Eigen::Vector3d n = Eigen::Vector3d(-slope_x, -slope_y_up, 1.0).normalized();
      for (int c = 0; c < 3; ++c) scene.normal_in_tangent(x, y, c) = static_cast<float>(n[c]);
      scene.height_mm(x, y) = static_cast<float>(field.height(x, y));
    }
  }
  return scene;
}

// RMS of (a - b) over the masked pixels after removing the mean difference;
// with fit_plane, after removing the best plane a + b x + c y instead.
double RmsDifference(const ImageF& a, const ImageF& b, const ImageU8* mask = nullptr, bool fit_plane = false) {
  std::vector<Eigen::Vector3d> rows;
  std::vector<double> values;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) {
      if (mask != nullptr && (*mask)(x, y) == 0) continue;
      rows.emplace_back(1.0, fit_plane ? x : 0.0, fit_plane ? y : 0.0);
      values.push_back(static_cast<double>(a(x, y)) - b(x, y));
    }
  }
  Eigen::MatrixXd design(rows.size(), 3);
  Eigen::VectorXd rhs(rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    design.row(i) = rows[i].transpose();
    rhs[i] = values[i];
  }
  Eigen::VectorXd coefficients = Eigen::Vector3d::Zero();
  if (fit_plane) {
    coefficients = design.colPivHouseholderQr().solve(rhs);
  } else {
    coefficients[0] = rhs.mean();
  }
  return std::sqrt((rhs - design * coefficients).squaredNorm() / static_cast<double>(rows.size()));
}

// Fits a ~ scale * b + c0 + c1 x + c2 y over the masked pixels; returns the
// scale and (through rms) the RMS of what is left.
double FitScale(const ImageF& a, const ImageF& b, const ImageU8& mask, double* rms) {
  std::vector<Eigen::Vector4d> rows;
  std::vector<double> values;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) {
      if (mask(x, y) == 0) continue;
      rows.emplace_back(b(x, y), 1.0, x, y);
      values.push_back(a(x, y));
    }
  }
  Eigen::MatrixXd design(rows.size(), 4);
  Eigen::VectorXd rhs(rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    design.row(i) = rows[i].transpose();
    rhs[i] = values[i];
  }
  const Eigen::VectorXd coefficients = design.colPivHouseholderQr().solve(rhs);
  *rms = std::sqrt((rhs - design * coefficients).squaredNorm() / static_cast<double>(rows.size()));
  return coefficients[0];
}

double Rms(const ImageF& a, const ImageU8* mask = nullptr) {
  ImageF zero(a.width(), a.height(), 1, 0.0f);
  return RmsDifference(a, zero, mask);
}

bool AllFinite(const ImageF& image) {
  for (size_t i = 0; i < image.size(); ++i) {
    if (!std::isfinite(image.data()[i])) return false;
  }
  return true;
}

HeightFromNormalsOptions Options(Method method, double mm_per_pixel) {
  HeightFromNormalsOptions options;
  options.method = method;
  options.mm_per_pixel = mm_per_pixel;
  return options;
}

// Sines of 40 and 64 px wavelength (0.8 mm and 0.5 mm amplitude) at 0.1 mm/px:
// slopes up to ~1.6, a 58 degree tilt.
HeightField SumOfSines() {
  HeightField field;
  const double kx = 2 * kPi / 40, ky = 2 * kPi / 64, kd = 2 * kPi / 90;
  field.height = [=](double x, double y) {
    return 0.8 * std::sin(kx * x + 0.3) + 0.5 * std::cos(ky * y - 1.1) + 0.3 * std::sin(kd * (x + y));
  };
  field.d_dx = [=](double x, double y) {
    return 0.8 * kx * std::cos(kx * x + 0.3) + 0.3 * kd * std::cos(kd * (x + y));
  };
  field.d_drow = [=](double x, double y) {
    return -0.5 * ky * std::sin(ky * y - 1.1) + 0.3 * kd * std::cos(kd * (x + y));
  };
  return field;
}

// Gaussian bumps and a dent at random places (fixed seed).
HeightField GaussianBumps(int width, int height) {
  struct Bump {
    double x, y, sigma, amplitude;
  };
  std::mt19937 random(17);
  std::uniform_real_distribution<double> ux(0, width), uy(0, height), us(5, 20), ua(-1.5, 2.0);
  std::vector<Bump> bumps;
  for (int i = 0; i < 12; ++i) bumps.push_back({ux(random), uy(random), us(random), ua(random)});
  HeightField field;
  field.height = [=](double x, double y) {
    double sum = 0;
    for (const Bump& b : bumps) {
      sum += b.amplitude * std::exp(-((x - b.x) * (x - b.x) + (y - b.y) * (y - b.y)) / (2 * b.sigma * b.sigma));
    }
    return sum;
  };
  field.d_dx = [=](double x, double y) {
    double sum = 0;
    for (const Bump& b : bumps) {
      const double g =
          b.amplitude * std::exp(-((x - b.x) * (x - b.x) + (y - b.y) * (y - b.y)) / (2 * b.sigma * b.sigma));
      sum += -g * (x - b.x) / (b.sigma * b.sigma);
    }
    return sum;
  };
  field.d_drow = [=](double x, double y) {
    double sum = 0;
    for (const Bump& b : bumps) {
      const double g =
          b.amplitude * std::exp(-((x - b.x) * (x - b.x) + (y - b.y) * (y - b.y)) / (2 * b.sigma * b.sigma));
      sum += -g * (y - b.y) / (b.sigma * b.sigma);
    }
    return sum;
  };
  return field;
}

// A plane rising towards the top of the image (row 0): `rise` mm per row up, plus a tilt along x.
HeightField TiltedPlane(double rise_per_row, double rise_per_column) {
  HeightField field;
  field.height = [=](double x, double y) { return -rise_per_row * y + rise_per_column * x; };
  field.d_dx = [=](double, double) { return rise_per_column; };
  field.d_drow = [=](double, double) { return -rise_per_row; };
  return field;
}

class HeightMethods : public ::testing::TestWithParam<Method> {};

TEST_P(HeightMethods, PlaneRisingTowardsTheTopGetsHigherTowardsRowZero) {
  constexpr int kWidth = 96, kHeight = 64;
  constexpr double kMmPerPixel = 0.2;
  // 0.05 mm per row up: slope 0.25 (14 deg) along y.
  const Scene scene = Render(TiltedPlane(0.05, 0.02), kWidth, kHeight, kMmPerPixel);
  // Uphill towards the top and the right: the normal leans down and left.
  ASSERT_LT(scene.normal_in_tangent(10, 10, 1), 0.0f);
  ASSERT_LT(scene.normal_in_tangent(10, 10, 0), 0.0f);
  HeightFromNormalsSummary summary;
  ImageF height;
  summary = HeightFromNormals(Options(GetParam(), kMmPerPixel), scene.normal_in_tangent, nullptr, &height);
  EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  ASSERT_EQ(height.width(), kWidth);
  ASSERT_EQ(height.height(), kHeight);
  ASSERT_EQ(height.channels(), 1);
  // Higher towards row 0, rising 0.05 mm per row and 0.02 mm per column; a
  // plane is integrated exactly (up to float rounding and, for the
  // relaxation, the sweeps left).
  const double tolerance = GetParam() == Method::kDctPoisson ? 1e-4 : 1e-3;
  EXPECT_NEAR(height(40, 0) - height(40, kHeight - 1), 0.05 * (kHeight - 1), tolerance);
  EXPECT_NEAR(height(kWidth - 1, 30) - height(0, 30), 0.02 * (kWidth - 1), tolerance);
  EXPECT_LT(RmsDifference(height, scene.height_mm), tolerance);
  EXPECT_LT(summary.rms_slope_residual, 1e-3);
  double mean = 0;
  for (size_t i = 0; i < height.size(); ++i) mean += height.data()[i];
  EXPECT_NEAR(mean / height.size(), 0.0, 1e-5);
}

TEST_P(HeightMethods, SumOfSinesMatchesTheTruth) {
  constexpr int kWidth = 256, kHeight = 160;
  constexpr double kMmPerPixel = 0.1;
  const Scene scene = Render(SumOfSines(), kWidth, kHeight, kMmPerPixel);
  HeightFromNormalsSummary summary;
  ImageF height;
  summary = HeightFromNormals(Options(GetParam(), kMmPerPixel), scene.normal_in_tangent, nullptr, &height);
  EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  const double truth_rms = Rms(scene.height_mm);
  const double error = RmsDifference(height, scene.height_mm);
  RecordProperty("rms_error_mm", std::to_string(error));
  std::printf("  [%s] sum of sines: RMS error %.5f mm of %.3f mm RMS height; %s\n", HeightMethodName(GetParam()), error,
              truth_rms, summary.message.c_str());
  // Trapezoidal slopes over 40 px wavelengths: ~0.2% discretisation error
  // (measured 0.17% for both methods).
  EXPECT_LT(error, 0.0025 * truth_rms);
}

TEST_P(HeightMethods, GaussianBumpsMatchTheTruth) {
  constexpr int kWidth = 200, kHeight = 150;
  constexpr double kMmPerPixel = 0.05;
  const Scene scene = Render(GaussianBumps(kWidth, kHeight), kWidth, kHeight, kMmPerPixel);
  HeightFromNormalsSummary summary;
  ImageF height;
  summary = HeightFromNormals(Options(GetParam(), kMmPerPixel), scene.normal_in_tangent, nullptr, &height);
  EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  const double truth_rms = Rms(scene.height_mm);
  const double error = RmsDifference(height, scene.height_mm);
  std::printf("  [%s] gaussian bumps: RMS error %.5f mm of %.3f mm RMS height; %s\n", HeightMethodName(GetParam()),
              error, truth_rms, summary.message.c_str());
  EXPECT_LT(error, 0.001 * truth_rms);  // measured 0.04%
}

TEST_P(HeightMethods, HolesAreFilledWithoutNanAndTheValidAreaStaysRight) {
  constexpr int kWidth = 160, kHeight = 120;
  constexpr double kMmPerPixel = 0.1;
  Scene scene = Render(SumOfSines(), kWidth, kHeight, kMmPerPixel);
  ImageU8 valid(kWidth, kHeight, 1, 1);
  // A round hole, a stripe along the left edge, and garbage normals (NaN, zero) inside them.
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const bool hole = (x - 90) * (x - 90) + (y - 60) * (y - 60) < 20 * 20 || x < 12;
      if (!hole) continue;
      valid(x, y) = 0;
      const float garbage = (x + y) % 2 == 0 ? std::nanf("") : 0.0f;
      for (int c = 0; c < 3; ++c) scene.normal_in_tangent(x, y, c) = garbage;
    }
  }
  HeightFromNormalsSummary summary;
  ImageF height;
  summary = HeightFromNormals(Options(GetParam(), kMmPerPixel), scene.normal_in_tangent, &valid, &height);
  EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  ASSERT_TRUE(AllFinite(height));
  const double truth_rms = Rms(scene.height_mm, &valid);
  const double error = RmsDifference(height, scene.height_mm, &valid);
  std::printf("  [%s] with holes: RMS error on valid %.5f mm of %.3f mm; %s\n", HeightMethodName(GetParam()), error,
              truth_rms, summary.message.c_str());
  EXPECT_LT(error, 0.003 * truth_rms);  // measured 0.17% (as without holes)
  // Zero mean over the valid pixels.
  double sum = 0;
  size_t count = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      if (valid(x, y)) sum += height(x, y), ++count;
    }
  }
  EXPECT_NEAR(sum / count, 0.0, 1e-5);
  // The fill is smooth: inside the hole it stays within the range of its rim.
  float rim_min = 1e9f, rim_max = -1e9f, hole_min = 1e9f, hole_max = -1e9f;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const int r2 = (x - 90) * (x - 90) + (y - 60) * (y - 60);
      if (r2 < 19 * 19) hole_min = std::min(hole_min, height(x, y)), hole_max = std::max(hole_max, height(x, y));
      if (r2 >= 20 * 20 && r2 < 21 * 21)
        rim_min = std::min(rim_min, height(x, y)), rim_max = std::max(rim_max, height(x, y));
    }
  }
  EXPECT_GE(hole_min, rim_min - 1e-3f);
  EXPECT_LE(hole_max, rim_max + 1e-3f);
}

TEST_P(HeightMethods, OddSizesWork) {
  constexpr int kWidth = 75, kHeight = 49;
  constexpr double kMmPerPixel = 0.1;
  const Scene scene = Render(SumOfSines(), kWidth, kHeight, kMmPerPixel);
  HeightFromNormalsSummary summary;
  ImageF height;
  summary = HeightFromNormals(Options(GetParam(), kMmPerPixel), scene.normal_in_tangent, nullptr, &height);
  EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  EXPECT_LT(RmsDifference(height, scene.height_mm), 0.005 * Rms(scene.height_mm));
}

TEST_P(HeightMethods, CancelFromTheProgressCallbackReturnsFiniteHeights) {
  constexpr int kWidth = 128, kHeight = 96;
  const Scene scene = Render(SumOfSines(), kWidth, kHeight, 0.1);
  HeightFromNormalsSummary summary;
  int calls = 0;
  ImageF height;
  summary = HeightFromNormals(Options(GetParam(), 0.1), scene.normal_in_tangent, nullptr, &height, [&](double) {
        ++calls;
        return false;
      });
  EXPECT_EQ(summary.termination, Termination::kCancelled);
  EXPECT_THAT(summary.message, HasSubstr("cancelled"));
  EXPECT_FALSE(summary.converged);
  EXPECT_EQ(calls, 1);  // no more work after the cancel
  ASSERT_EQ(height.width(), kWidth);
  ASSERT_EQ(height.height(), kHeight);
  EXPECT_TRUE(AllFinite(height));
}

TEST_P(HeightMethods, CancelMidwayWithHolesStopsAskingAndReturnsFiniteHeights) {
  const Scene scene = Render(SumOfSines(), 128, 96, 0.1);
  ImageU8 valid(128, 96, 1, 1);
  for (int y = 30; y < 60; ++y) {
    for (int x = 50; x < 80; ++x) valid(x, y) = 0;
  }
  int calls = 0;
  HeightFromNormalsSummary summary;
  ImageF height;
  summary = HeightFromNormals(Options(GetParam(), 0.1), scene.normal_in_tangent, &valid, &height,
                              [&](double) { return ++calls < 3; });
  EXPECT_EQ(summary.termination, Termination::kCancelled) << summary.message;
  EXPECT_EQ(calls, 3);
  EXPECT_TRUE(AllFinite(height));
}

TEST_P(HeightMethods, ProgressReachesOneWhenNotCancelled) {
  ImageF output;
  const Scene scene = Render(SumOfSines(), 64, 48, 0.1);
  double last_fraction = -1;
  bool monotonic = true;
  HeightFromNormalsSummary summary;
  auto progress = [&](double fraction) {
    monotonic = monotonic && fraction >= last_fraction && fraction <= 1.0;
    last_fraction = fraction;
    return true;
  };
  summary = HeightFromNormals(Options(GetParam(), 0.1), scene.normal_in_tangent, nullptr, &output, progress);
  EXPECT_EQ(summary.termination, Termination::kSuccess);
  EXPECT_TRUE(monotonic);
  EXPECT_NEAR(last_fraction, 1.0, 1e-9);
}

TEST_P(HeightMethods, ProgressWithHolesIsThrottledAndReachesOne) {
  ImageF output;
  const Scene scene = Render(SumOfSines(), 96, 64, 0.1);
  ImageU8 valid(96, 64, 1, 1);
  valid(40, 30) = 0;  // one pixel-sized hole: DCT re-solves stop early
  HeightFromNormalsOptions options = Options(GetParam(), 0.1);
  options.tolerance = 1e-4;  // lets relaxation levels stop early too
  double last_fraction = -1;
  int calls = 0;
  HeightFromNormalsSummary summary;
  summary = HeightFromNormals(options, scene.normal_in_tangent, &valid, &output, [&](double fraction) {
    last_fraction = fraction;
    ++calls;
    return true;
  });
  EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  EXPECT_TRUE(summary.converged) << summary.message;
  EXPECT_NEAR(last_fraction, 1.0, 1e-9);
  EXPECT_LE(calls, 1001);  // at most every 0.1%
}

INSTANTIATE_TEST_SUITE_P(Both, HeightMethods,
                         ::testing::Values(Method::kMultiresolutionRelaxation, Method::kDctPoisson),
                         [](const ::testing::TestParamInfo<Method>& param_info) {
                           return std::string(HeightMethodName(param_info.param));
                         });

TEST(HeightFromNormals, RelaxationReportsLevelsSweepsAndConvergence) {
  ImageF output;
  const Scene scene = Render(SumOfSines(), 256, 160, 0.1);
  HeightFromNormalsSummary summary;
  summary =
      HeightFromNormals(Options(Method::kMultiresolutionRelaxation, 0.1), scene.normal_in_tangent, nullptr, &output);
  EXPECT_EQ(summary.method, "relaxation");
  // 256 -> 128 -> 64 -> 32 -> 16 -> 8 columns (coarsest_level_size 8): six levels.
  EXPECT_EQ(summary.levels, 6);
  EXPECT_GE(summary.total_sweeps, summary.levels);
  EXPECT_LE(summary.total_sweeps, summary.levels * 400);
  EXPECT_GE(summary.seconds, 0.0);
  // One sweep per level cannot converge to 1e-6.
  HeightFromNormalsOptions few = Options(Method::kMultiresolutionRelaxation, 0.1);
  few.max_sweeps_per_level = 1;
  HeightFromNormalsSummary few_summary;
  ImageF rough;
  few_summary = HeightFromNormals(few, scene.normal_in_tangent, nullptr, &rough);
  EXPECT_FALSE(few_summary.converged);
  EXPECT_EQ(few_summary.total_sweeps, few_summary.levels);
  EXPECT_GT(few_summary.rms_slope_residual, summary.rms_slope_residual);
  EXPECT_TRUE(AllFinite(rough));
}

TEST(HeightFromNormals, PlainGaussSeidelWorksAndOverRelaxationIsMoreAccurate) {
  const Scene scene = Render(GaussianBumps(200, 150), 200, 150, 0.05);
  HeightFromNormalsOptions plain = Options(Method::kMultiresolutionRelaxation, 0.05);
  plain.over_relaxation = 1.0;
  HeightFromNormalsSummary plain_summary, sor_summary;
  ImageF plain_height;
  plain_summary = HeightFromNormals(plain, scene.normal_in_tangent, nullptr, &plain_height);
  ImageF sor_height;
  sor_summary = HeightFromNormals(Options(Method::kMultiresolutionRelaxation, 0.05), scene.normal_in_tangent, nullptr,
                                  &sor_height);
  const double truth_rms = Rms(scene.height_mm);
  const double plain_error = RmsDifference(plain_height, scene.height_mm);
  const double sor_error = RmsDifference(sor_height, scene.height_mm);
  std::printf("  gaussian bumps, 400 sweeps per level: plain Gauss-Seidel %.5f mm, SOR 1.9 %.5f mm of %.3f mm\n",
              plain_error, sor_error, truth_rms);
  EXPECT_LT(plain_error, 0.005 * truth_rms);
  EXPECT_LT(sor_error, 0.5 * plain_error);
  EXPECT_LT(sor_summary.rms_slope_residual, plain_summary.rms_slope_residual);
}

TEST(HeightFromNormals, TinyAndThinImagesGiveFiniteHeights) {
  for (const Method method : {Method::kMultiresolutionRelaxation, Method::kDctPoisson}) {
    for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {2, 1}, {1, 7}, {3, 2}, {300, 2}}) {
      const Scene scene = Render(TiltedPlane(0.01, 0.02), w, h, 0.1);
      HeightFromNormalsSummary summary;
      ImageF height;
      summary = HeightFromNormals(Options(method, 0.1), scene.normal_in_tangent, nullptr, &height);
      EXPECT_EQ(summary.termination, Termination::kSuccess) << w << "x" << h << " " << summary.message;
      ASSERT_TRUE(AllFinite(height)) << w << "x" << h;
      if (w > 1) {
        EXPECT_NEAR(height(w - 1, 0) - height(0, 0), 0.02 * (w - 1), 1e-3) << w << "x" << h;
      }
      if (h > 1) {
        EXPECT_NEAR(height(0, 0) - height(0, h - 1), 0.01 * (h - 1), 1e-3) << w << "x" << h;
      }
    }
  }
}

TEST(HeightFromNormals, DctReportsOneLevel) {
  ImageF output;
  const Scene scene = Render(SumOfSines(), 64, 48, 0.1);
  HeightFromNormalsSummary summary;
  summary = HeightFromNormals(Options(Method::kDctPoisson, 0.1), scene.normal_in_tangent, nullptr, &output);
  EXPECT_EQ(summary.method, "dct");
  EXPECT_EQ(summary.levels, 1);
  EXPECT_EQ(summary.total_sweeps, 0);
}

TEST(HeightFromNormals, HeightScalesWithThePixelPitch) {
  const Scene scene = Render(SumOfSines(), 96, 64, 0.1);
  ImageF at_01;
  HeightFromNormals(Options(Method::kDctPoisson, 0.1), scene.normal_in_tangent, nullptr, &at_01);
  ImageF at_03;
  HeightFromNormals(Options(Method::kDctPoisson, 0.3), scene.normal_in_tangent, nullptr, &at_03);
  for (int i = 0; i < 50; ++i) {
    const int x = (i * 37) % 96, y = (i * 11) % 64;
    EXPECT_NEAR(at_03(x, y), 3 * at_01(x, y), 1e-4);
  }
}

TEST(HeightFromNormalsOptions, CheckNamesTheField) {
  ImageF output;
  HeightFromNormalsOptions options;
  EXPECT_NO_THROW(options.Check());
  options.mm_per_pixel = 0;
  testing::ExpectCheckRejects(options, "HeightFromNormalsOptions.mm_per_pixel");
  options = {};
  options.mm_per_pixel = std::nan("");
  testing::ExpectCheckRejects(options, "HeightFromNormalsOptions.mm_per_pixel");
  options = {};
  options.max_sweeps_per_level = 0;
  testing::ExpectCheckRejects(options, "HeightFromNormalsOptions.max_sweeps_per_level");
  options = {};
  options.tolerance = -1;
  testing::ExpectCheckRejects(options, "HeightFromNormalsOptions.tolerance");
  options = {};
  options.coarsest_level_size = 1;
  testing::ExpectCheckRejects(options, "HeightFromNormalsOptions.coarsest_level_size");
  options = {};
  options.max_slope = 0;
  testing::ExpectCheckRejects(options, "HeightFromNormalsOptions.max_slope");
  options = {};
  options.over_relaxation = 2;
  testing::ExpectCheckRejects(options, "HeightFromNormalsOptions.over_relaxation");
  options.over_relaxation = 0;
  testing::ExpectCheckRejects(options, "HeightFromNormalsOptions.over_relaxation");
  options = {};
  options.dct_hole_iterations = -1;
  testing::ExpectCheckRejects(options, "HeightFromNormalsOptions.dct_hole_iterations");
  // HeightFromNormals checks before anything else.
  options = {};
  options.tolerance = -1;
  ImageF normals(4, 4, 3, 0.0f);
  EXPECT_THROW(HeightFromNormals(options, normals, nullptr, &output), std::invalid_argument);
}

TEST(HeightFromNormals, BadShapesThrowNamingThem) {
  ImageF output;
  const HeightFromNormalsOptions options;
  try {
    HeightFromNormals(options, ImageF(8, 6, 1), nullptr, &output);
    ADD_FAILURE() << "1-channel normals accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("normal_in_tangent is 8x6x1"));
  }
  EXPECT_THROW(HeightFromNormals(options, ImageF(), nullptr, &output), std::invalid_argument);
  const ImageU8 wrong_mask(7, 6, 1, 1);
  try {
    HeightFromNormals(options, ImageF(8, 6, 3, 0.0f), &wrong_mask, &output);
    ADD_FAILURE() << "mask of the wrong size accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("valid mask is 7x6x1"));
    EXPECT_THAT(e.what(), HasSubstr("8x6"));
  }
}

TEST(HeightFromNormals, NoValidPixelFailsWithZeroHeight) {
  ImageF normals(16, 12, 3, 0.0f);
  const ImageU8 nothing(16, 12, 1, 0);
  for (const Method method : {Method::kMultiresolutionRelaxation, Method::kDctPoisson}) {
    HeightFromNormalsSummary summary;
    ImageF height;
    summary = HeightFromNormals(Options(method, 0.1), normals, &nothing, &height);
    EXPECT_EQ(summary.termination, Termination::kFailure);
    EXPECT_THAT(summary.message, HasSubstr("no valid pixel"));
    ASSERT_TRUE(AllFinite(height));
    EXPECT_EQ(Rms(height), 0.0);
  }
}

TEST(HeightFromNormals, GrazingNormalsAreClampedNotInfinite) {
  ImageF normals(32, 32, 3, 0.0f);
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 32; ++x) {
      normals(x, y, 2) = 1.0f;
      if (x == 16) normals(x, y, 0) = 1.0f, normals(x, y, 2) = 0.0f;  // a vertical wall
    }
  }
  for (const Method method : {Method::kMultiresolutionRelaxation, Method::kDctPoisson}) {
    HeightFromNormalsOptions options = Options(method, 0.1);
    options.max_slope = 5;
    ImageF height;
    HeightFromNormals(options, normals, nullptr, &height);
    ASSERT_TRUE(AllFinite(height));
    // The wall steps down to the right by max_slope * mm_per_pixel over its
    // two trapezoid edges (half a step each).
    EXPECT_NEAR(height(10, 16) - height(22, 16), 0.5, 0.01) << HeightMethodName(method);
  }
}

TEST(HeightMethodNames, RoundTripAndRejectUnknown) {
  for (const Method method : {Method::kMultiresolutionRelaxation, Method::kDctPoisson}) {
    EXPECT_EQ(HeightMethodFromName(HeightMethodName(method)), method);
  }
  try {
    HeightMethodFromName("fft");
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("'fft'"));
  }
}

// The simulated rig's textile (weave, folds, edge ramp) seen orthographically:
// normals and heights straight from TextileScene on a regular table grid, y
// up towards row 0. What the integrator gets right without the camera.
TEST(HeightFromNormals, TextileSceneSeenOrthographicallyIsRecovered) {
  constexpr int kWidth = 360, kHeight = 240;
  constexpr double kPitchMm = 0.15;  // the central 54 x 36 mm of the sample, 16 px per warp thread
  const TextileScene scene;
  ImageF normals(kWidth, kHeight, 3), truth(kWidth, kHeight, 1);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const double x_mm = (x - kWidth / 2.0) * kPitchMm, y_mm = (kHeight / 2.0 - y) * kPitchMm;
      const Eigen::Vector3d n = scene.NormalInTable(x_mm, y_mm);
      for (int c = 0; c < 3; ++c) normals(x, y, c) = static_cast<float>(n[c]);
      truth(x, y) = static_cast<float>(scene.HeightMm(x_mm, y_mm));
    }
  }
  const double truth_rms = Rms(truth);
  for (const Method method : {Method::kMultiresolutionRelaxation, Method::kDctPoisson}) {
    HeightFromNormalsSummary summary;
    ImageF height;
    summary = HeightFromNormals(Options(method, kPitchMm), normals, nullptr, &height);
    const double error = RmsDifference(height, truth);
    std::printf("  [%s] textile scene, orthographic %dx%d at %.2f mm/px: RMS error %.4f mm of %.3f mm RMS; %s\n",
                HeightMethodName(method), kWidth, kHeight, kPitchMm, error, truth_rms, summary.message.c_str());
    EXPECT_LT(error, 0.003 * truth_rms);  // measured 0.11%
  }
}

// Against the simulated rig: integrate the ground-truth normals of the sample
// and compare with the ground-truth height (best plane removed: the camera's
// 1 degree tilt and the perspective make the pixel grid a slightly skewed,
// scaled view of the table, a few % of scale is physics, not the integrator).
TEST(HeightFromNormals, SimulatedRigGroundTruthHeightIsRecovered) {
  constexpr int kWidth = 400, kHeight = 264;
  SimulatedRigOptions rig_options;
  rig_options.width = kWidth;
  rig_options.height = kHeight;
  rig_options.num_threads = 2;
  const SimulatedRig rig(rig_options, TextileScene(), MakeDefaultSimulatedRig(kWidth, kHeight));
  const GroundTruthMaps truth = rig.RenderGroundTruth();
  ImageU8 sample = truth.sample_mask;
  // Only the sample: its blended edge down to the table is part of it.
  size_t on_sample = 0;
  for (size_t i = 0; i < sample.size(); ++i) on_sample += sample.data()[i] != 0;
  ASSERT_GT(on_sample, sample.num_pixels() / 4);
  const double truth_rms = RmsDifference(truth.height_mm, ImageF(kWidth, kHeight, 1, 0.0f), &sample, true);
  // The sample without its 5 mm edge ramp (and a margin), from where each pixel meets the surface.
  ImageU8 interior(kWidth, kHeight, 1, 0);
  const TextileSceneOptions scene_options;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      interior(x, y) = std::abs(truth.point_in_table(x, y, 0)) < scene_options.sample_width_mm / 2 - 7 &&
                       std::abs(truth.point_in_table(x, y, 1)) < scene_options.sample_height_mm / 2 - 7;
    }
  }
  for (const Method method : {Method::kMultiresolutionRelaxation, Method::kDctPoisson}) {
    HeightFromNormalsSummary summary;
    ImageF height;
    summary = HeightFromNormals(Options(method, truth.mm_per_pixel), truth.normal_in_table, &sample, &height);
    EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
    ASSERT_TRUE(AllFinite(height));
    const double error = RmsDifference(height, truth.height_mm, &sample, true);
    double error_after_scale = 0;
    const double scale = FitScale(height, truth.height_mm, sample, &error_after_scale);
    const double interior_error = RmsDifference(height, truth.height_mm, &interior, true);
    std::printf(
        "  [%s] simulated rig %dx%d (%.3f mm/px): RMS error %.4f mm of %.3f mm RMS relief; best scale %.4f"
        " leaves %.4f mm; %.4f mm away from the edge ramp; %s\n",
        HeightMethodName(method), kWidth, kHeight, truth.mm_per_pixel, error, truth_rms, scale, error_after_scale,
        interior_error, summary.message.c_str());
    // Measured 0.085 mm for both methods, 7% of the relief, of which a 4.3%
    // scale, and 0.029 mm away from the steep edge ramp: rays up to ~6 deg
    // off vertical at the sample's edge make the pixel footprint on a slope
    // differ from mm_per_pixel by slope * tan(ray). The orthographic test
    // above shows the integrator itself at 0.1%.
    EXPECT_LT(error, 0.1);
    EXPECT_LT(error, 0.09 * truth_rms);
    EXPECT_LT(interior_error, 0.04);  // measured 0.0285 mm
  }
}

TEST(HeightFromNormals, NullOutputThrowsNamingIt) {
  try {
    HeightFromNormals({}, ImageF(8, 6, 3, 0.0f), nullptr, nullptr);
    ADD_FAILURE() << "null output accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("height_mm"));
  }
}

TEST_P(HeightMethods, BriefReportGivesTheMethodOutcomeAndResidual) {
  const Scene scene = Render(SumOfSines(), 64, 48, 0.1);
  ImageF height;
  const HeightFromNormalsSummary done = HeightFromNormals(Options(GetParam(), 0.1), scene.normal_in_tangent, nullptr,
                                                          &height);
  ASSERT_EQ(done.termination, Termination::kSuccess) << done.message;
  EXPECT_THAT(done.BriefReport(), HasSubstr("(" + done.method + "): success"));
  EXPECT_THAT(done.BriefReport(), HasSubstr("RMS slope residual " + Fixed(done.rms_slope_residual, 3)));
  const HeightFromNormalsSummary stopped =
      HeightFromNormals(Options(GetParam(), 0.1), scene.normal_in_tangent, nullptr, &height,
                        [](double) { return false; });
  EXPECT_THAT(stopped.BriefReport(), HasSubstr("cancelled"));
}

}  // namespace
}  // namespace scanbench
