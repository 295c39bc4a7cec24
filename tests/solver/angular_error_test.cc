#include "solver/angular_error.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace scanbench {
namespace {

TEST(AngularErrorTest, KnownAnglesAndMask) {
  ImageF truth(3, 1, 3, 0.0f), estimate(3, 1, 3, 0.0f);
  for (int x = 0; x < 3; ++x) truth(x, 0, 2) = 1;
  estimate(0, 0, 2) = 1;                                  // 0 degrees
  estimate(1, 0, 0) = 1;                                  // 90 degrees
  estimate(2, 0, 0) = 1;
  estimate(2, 0, 2) = 1;                                  // 45 degrees, not unit
  const ErrorStatistics all = AngularErrorDegrees(estimate, truth, ImageU8());
  EXPECT_EQ(all.num_pixels, 3u);
  EXPECT_NEAR(all.mean, 45.0, 1e-9);
  EXPECT_NEAR(all.median, 45.0, 1e-9);
  EXPECT_NEAR(all.max, 90.0, 1e-9);

  ImageU8 mask(3, 1, 1, 1);
  mask(1, 0) = 0;
  const ErrorStatistics masked = AngularErrorDegrees(estimate, truth, mask);
  EXPECT_EQ(masked.num_pixels, 2u);
  EXPECT_NEAR(masked.mean, 22.5, 1e-9);
  EXPECT_FLOAT_EQ(AngularErrorMapDegrees(estimate, truth, mask)(1, 0), 0.0f);
}

TEST(AngularErrorTest, NonFiniteEstimateCountsAsWorst) {
  ImageF truth(1, 1, 3, 0.0f), estimate(1, 1, 3, 0.0f);
  truth(0, 0, 2) = 1;
  estimate(0, 0, 2) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(AngularErrorDegrees(estimate, truth, ImageU8()).max, 180.0);
}

TEST(AngularErrorTest, PercentilesOfKnownList) {
  std::vector<double> values;
  for (int i = 0; i <= 100; ++i) values.push_back(i);
  const ErrorStatistics stats = SummarizeErrors(values);
  EXPECT_DOUBLE_EQ(stats.median, 50);
  EXPECT_DOUBLE_EQ(stats.percentile_95, 95);
  EXPECT_DOUBLE_EQ(stats.mean, 50);
  EXPECT_THROW(AngularErrorDegrees(ImageF(2, 2, 3), ImageF(2, 3, 3), ImageU8()), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
