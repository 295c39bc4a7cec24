// The evaluation's statistics held as floats; the export's figures against the ground truth.
#include "pipeline/error_statistics.h"

#include <algorithm>
#include <cstring>
#include <optional>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

namespace scanbench {
namespace {

void ExpectBitEqual(double actual, double expected, const char* what) {
  EXPECT_EQ(std::memcmp(&actual, &expected, sizeof(double)), 0) << what << ": " << actual << " != " << expected;
}

// Held as floats: count, mean and maximum SummarizeErrors' bit for bit, the
// median and p95 SummarizeErrors' rounded to float (ties, tiny values that
// round to 0, huge and negative ones; with and without room reserved).
TEST(FloatErrorStatisticsTest, FloatStatisticsAreSummarizeErrorsWithQuantilesRoundedToFloat) {
  std::mt19937_64 random(7);
  for (const size_t size : std::vector<size_t>{0, 1, 2, 3, 20, 1001, 65536, 300001}) {
    SCOPED_TRACE("size " + std::to_string(size));
    std::vector<double> values(size);
    std::uniform_real_distribution<double> angle(0.0, 2.0);
    std::uniform_int_distribution<int> pick(0, 9);
    for (double& v : values) {
      const int kind = pick(random);
      v = kind == 0 ? 0.25 * pick(random) : kind == 1 ? angle(random) * 1e-300 : kind == 2 ? 1e30 : angle(random);
      if (kind == 3) v = -v;
    }
    const ErrorStatistics expected = SummarizeErrors(values);
    for (const size_t band : {size_t{1}, size_t{4096}}) {
      FloatErrorStatistics statistics;
      if (band == 1) statistics.Reserve(size);
      for (size_t i = 0; i < values.size(); i += band) {
        statistics.Add(std::span(values).subspan(i, std::min(band, values.size() - i)));
      }
      EXPECT_EQ(statistics.count(), size);
      const ErrorStatistics actual = statistics.Finish();
      EXPECT_EQ(actual.num_pixels, expected.num_pixels);
      ExpectBitEqual(actual.mean, expected.mean, "mean");
      ExpectBitEqual(actual.max, expected.max, "max");
      ExpectBitEqual(actual.median, static_cast<float>(expected.median), "median");
      ExpectBitEqual(actual.percentile_95, static_cast<float>(expected.percentile_95), "p95");
    }
  }
}

// A pattern of +-1 orthogonal to any plane over aligned 4 x 4 blocks: in each
// block of four along a row or a column its values (+, -, -, +) sum to 0 and
// so do their products with x or y.
double PlaneFreeSign(int x, int y) {
  auto p = [](int i) { return (i % 4 == 0 || i % 4 == 3) ? 1.0 : -1.0; };
  return p(x) * p(y);
}

TEST(RmsAfterBestFitPlaneTest, TakesOutAnOffsetAndATiltOnTheMaskOnly) {
  constexpr int kWidth = 64, kHeight = 48;
  constexpr double kResidual = 0.01;  // mm
  std::mt19937_64 random(11);
  std::uniform_real_distribution<float> height(0.0f, 2.0f);
  ImageF reference(kWidth, kHeight, 1), estimate(kWidth, kHeight, 1), tilted(kWidth, kHeight, 1);
  ImageU8 left(kWidth, kHeight, 1, uint8_t{0});
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      reference(x, y) = height(random);
      const double plane = 0.5 + 0.002 * x - 0.003 * y;
      tilted(x, y) = static_cast<float>(reference(x, y) + plane);
      // The right half, off the mask, far off.
      estimate(x, y) = x < kWidth / 2 ? static_cast<float>(reference(x, y) + plane + kResidual * PlaneFreeSign(x, y))
                                      : 1e3f;
      left(x, y) = x < kWidth / 2;
    }
  }
  const std::optional<double> rms = RmsAfterBestFitPlane(estimate, reference, left);
  ASSERT_TRUE(rms.has_value());
  EXPECT_NEAR(*rms, kResidual, 1e-4 * kResidual);
  const std::optional<double> plane_only = RmsAfterBestFitPlane(tilted, reference, ImageU8(kWidth, kHeight, 1, uint8_t{1}));
  ASSERT_TRUE(plane_only.has_value());
  EXPECT_LT(*plane_only, 1e-6);

  ImageU8 two(kWidth, kHeight, 1, uint8_t{0});
  two(3, 4) = two(10, 20) = 1;
  EXPECT_FALSE(RmsAfterBestFitPlane(estimate, reference, two).has_value()) << "a plane needs 3 pixels";
  EXPECT_THROW(RmsAfterBestFitPlane(estimate, ImageF(kWidth, kHeight + 1, 1), left), std::invalid_argument);
}

TEST(MeanAngularErrorDegreesTest, IsAngularErrorDegreesMeanBitForBitWithoutItsList) {
  constexpr int kWidth = 50, kHeight = 150;  // three bands of rows
  std::mt19937_64 random(5);
  std::normal_distribution<float> component(0.0f, 1.0f);
  std::uniform_int_distribution<int> coin(0, 3);
  ImageF estimate(kWidth, kHeight, 3), truth(kWidth, kHeight, 3);
  ImageU8 mask(kWidth, kHeight, 1);
  for (size_t i = 0; i < estimate.num_pixels(); ++i) {
    for (int c = 0; c < 3; ++c) {
      truth.data()[3 * i + c] = component(random);
      estimate.data()[3 * i + c] = truth.data()[3 * i + c] + 0.2f * component(random);
    }
    mask.data()[i] = coin(random) != 0;
  }
  const std::optional<double> mean = MeanAngularErrorDegrees(estimate, truth, mask);
  ASSERT_TRUE(mean.has_value());
  ExpectBitEqual(*mean, AngularErrorDegrees(estimate, truth, mask).mean, "mean");
  EXPECT_GT(*mean, 1.0);
  EXPECT_FALSE(MeanAngularErrorDegrees(estimate, truth, ImageU8(kWidth, kHeight, 1, uint8_t{0})).has_value());
  EXPECT_THROW(MeanAngularErrorDegrees(estimate, ImageF(kWidth, kHeight, 1), mask), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
