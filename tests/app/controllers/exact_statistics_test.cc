// Exact order statistics from a spill file: bit-equal to SummarizeErrors; and
// the same held as floats.
#include "app/controllers/exact_statistics.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

using testing::TemporaryFolder;

void ExpectBitEqual(double actual, double expected, const char* what) {
  EXPECT_EQ(std::memcmp(&actual, &expected, sizeof(double)), 0) << what << ": " << actual << " != " << expected;
}

void ExpectSameSummary(const ErrorStatistics& actual, const ErrorStatistics& expected) {
  EXPECT_EQ(actual.num_pixels, expected.num_pixels);
  ExpectBitEqual(actual.mean, expected.mean, "mean");
  ExpectBitEqual(actual.median, expected.median, "median");
  ExpectBitEqual(actual.percentile_95, expected.percentile_95, "p95");
  ExpectBitEqual(actual.max, expected.max, "max");
}

// Values added in bands of `band` each; the summary must be SummarizeErrors'.
// The same with no spill: added one at a time, replayed in reverse order in
// chunks of 1000 (a replay may give them in any order).
void ExpectSummaryOf(const std::vector<double>& values, size_t band, const std::filesystem::path& folder = {}) {
  ExactErrorStatistics exact(folder);
  for (size_t i = 0; i < values.size(); i += band) {
    exact.Add(std::span(values).subspan(i, std::min(band, values.size() - i)));
  }
  const ErrorStatistics expected = SummarizeErrors(values);
  {
    SCOPED_TRACE("spilled");
    ExpectSameSummary(exact.Finish(), expected);
  }
  int replays = 0;
  ExactErrorStatistics replayed([&](const std::function<void(std::span<const double>)>& visit) {
    ++replays;
    const std::vector<double> reversed(values.rbegin(), values.rend());
    for (size_t i = 0; i < reversed.size(); i += 1000) {
      visit(std::span(reversed).subspan(i, std::min<size_t>(1000, reversed.size() - i)));
    }
  });
  for (const double value : values) replayed.Add(value);
  EXPECT_THROW(exact.Add(1.0), std::logic_error) << "a spilled statistic takes spans only";
  SCOPED_TRACE("replayed");
  ExpectSameSummary(replayed.Finish(), expected);
  if (!values.empty()) {
    EXPECT_GE(replays, 1) << "the order statistics read the values again";
  }
}

TEST(ExactStatisticsTest, EqualsSummarizeErrorsOnRandomValuesWithTies) {
  std::mt19937_64 random(5);
  for (const size_t size : std::vector<size_t>{0, 1, 2, 3, 20, 1001, 65536, 300001}) {
    SCOPED_TRACE("size " + std::to_string(size));
    std::vector<double> values(size);
    std::uniform_real_distribution<double> angle(0.0, 2.0);
    std::uniform_int_distribution<int> pick(0, 9);
    for (double& v : values) {
      // A tenth repeat a few values (ties); some tiny, some huge, some negative.
      const int kind = pick(random);
      v = kind == 0 ? 0.25 * pick(random) : kind == 1 ? angle(random) * 1e-300 : kind == 2 ? 1e30 : angle(random);
      if (kind == 3) v = -v;
    }
    for (size_t band : {size_t{1}, size_t{7}, size_t{4096}, std::max<size_t>(size, 1)}) ExpectSummaryOf(values, band);
  }
}

// More values in one bucket of leading bits than one selection reads at once:
// finer histograms narrow it down; all equal: the leading bits are all of them.
TEST(ExactStatisticsTest, EqualsSummarizeErrorsWhenOneBucketHoldsMillions) {
  std::mt19937_64 random(6);
  // Within one bucket of the first histogram (1/256 of an octave).
  std::uniform_real_distribution<double> narrow(1.0, 1.0 + 1.0 / 1024);
  std::vector<double> values(2'500'000);
  for (double& v : values) v = narrow(random);
  for (size_t i = 0; i < values.size(); i += 3) values[i] = 1.00048828125;  // a third tied, in the middle
  ExpectSummaryOf(values, 100'000);
  std::fill(values.begin(), values.end(), 0.229);
  ExpectSummaryOf(values, 1'000'000);
}

// Held as floats: count, mean and maximum SummarizeErrors' bit for bit, the
// median and p95 SummarizeErrors' rounded to float (ties, tiny values that
// round to 0, huge and negative ones; with and without room reserved).
TEST(ExactStatisticsTest, FloatStatisticsAreSummarizeErrorsWithQuantilesRoundedToFloat) {
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

// The spill file has no name: the folder stays empty.
TEST(ExactStatisticsTest, SpillFileLeavesNothingInItsFolder) {
  TemporaryFolder folder;
  {
    SpillFile spill(folder.path());
    const std::vector<uint32_t> records = {1, 2, 3, 4, 5, 6};
    for (int i = 0; i < 100'000; ++i) spill.Append(records.data(), records.size() * sizeof(uint32_t));
    EXPECT_TRUE(std::filesystem::is_empty(folder.path()));
    size_t seen = 0;
    uint64_t sum = 0;
    spill.ForEachRecord(3 * sizeof(uint32_t), [&](const uint8_t* bytes, size_t count) {
      for (size_t i = 0; i < count; ++i) {
        uint32_t record[3];
        std::memcpy(record, bytes + i * sizeof(record), sizeof(record));
        sum += record[0] + record[1] + record[2];
      }
      seen += count;
    });
    EXPECT_EQ(seen, 200'000u);
    EXPECT_EQ(sum, 100'000u * 21);
    EXPECT_THROW(spill.ForEachRecord(7, [](const uint8_t*, size_t) {}), std::invalid_argument);
  }
  std::vector<double> values = {3, 1, 2, 2, 5};
  ExpectSummaryOf(values, 2, folder.path());
  EXPECT_TRUE(std::filesystem::is_empty(folder.path()));
}

}  // namespace
}  // namespace scanbench
