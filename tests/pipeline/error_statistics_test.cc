// The evaluation's statistics held as floats.
#include "pipeline/error_statistics.h"

#include <algorithm>
#include <cstring>
#include <random>
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

}  // namespace
}  // namespace scanbench
