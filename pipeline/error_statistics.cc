#include "pipeline/error_statistics.h"

#include <algorithm>
#include <bit>
#include <cstring>

namespace scanbench {

void FloatErrorStatistics::Add(std::span<const double> values) {
  if (values.empty()) return;
  if (values_.empty()) max_ = values[0];
  for (const double value : values) {
    sum_ += value;
    if (max_ < value) max_ = value;
  }
  // The rounding in a loop of its own (vectorised), into room made at once.
  const size_t first = values_.size();
  values_.resize(first + values.size());
  float* out = values_.data() + first;
  for (size_t i = 0; i < values.size(); ++i) out[i] = static_cast<float>(values[i]);
}

namespace {

// Non-NaN floats to unsigned integers in the same order.
uint32_t FloatOrderKey(float value) {
  const uint32_t bits = std::bit_cast<uint32_t>(value);
  return (bits >> 31) ? ~bits : bits | (uint32_t{1} << 31);
}

}  // namespace

ErrorStatistics FloatErrorStatistics::Finish() {
  ErrorStatistics stats;
  const size_t count = values_.size();
  stats.num_pixels = count;
  if (count == 0) return stats;
  stats.mean = sum_ / count;
  stats.max = max_;
  // SummarizeErrors' ranks, selected by a histogram of the order keys' top 16
  // bits (one pass), then std::nth_element among the values of the rank's
  // bucket only (a second pass gathers them): a few times faster than
  // nth_element over every value.
  const auto rank_of = [&](double fraction) {
    return std::min(count - 1, static_cast<size_t>(fraction * (count - 1) + 0.5));
  };
  constexpr int kShift = 16;
  std::vector<uint32_t> histogram(size_t{1} << (32 - kShift), 0);
  for (const float value : values_) ++histogram[FloatOrderKey(value) >> kShift];
  const auto value_of_rank = [&](size_t rank) {
    size_t bucket = 0, before = 0;
    while (rank >= before + histogram[bucket]) before += histogram[bucket++];
    std::vector<float> selected;
    selected.reserve(histogram[bucket]);
    for (const float value : values_) {
      if ((FloatOrderKey(value) >> kShift) == bucket) selected.push_back(value);
    }
    std::nth_element(selected.begin(), selected.begin() + (rank - before), selected.end());
    return static_cast<double>(selected[rank - before]);
  };
  stats.median = value_of_rank(rank_of(0.5));
  stats.percentile_95 = value_of_rank(rank_of(0.95));
  values_ = {};
  return stats;
}

}  // namespace scanbench
