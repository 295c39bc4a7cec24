// Exact summaries of values that arrive band by band (the solve's ground-truth
// evaluation, issue #14), without holding them in memory: the values go to an
// unlinked temporary file (SpillFile), or are made again by their owner from
// what it spilled anyway, and a histogram over their leading bits says which
// few of them an order statistic lies among, so only those are read back and
// selected. At 16 MP the albedo's 34 M error values are 270 MB a std::vector
// would hold; here the histogram (512 KB) and a selection buffer.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <stdexcept>
#include <vector>

#include "solver/angular_error.h"

namespace scanbench {

// An anonymous temporary file (O_TMPFILE, else created and unlinked at once):
// it has no name, so nothing is left behind whatever happens to the process;
// its pages are the file system's cache, not the process's memory. Appends
// are buffered; ForEachRecord reads everything back in order.
class SpillFile {
 public:
  // In `folder` (must exist); empty = std::filesystem::temp_directory_path().
  // Throws std::runtime_error naming the folder when no file can be made.
  explicit SpillFile(const std::filesystem::path& folder = {});
  SpillFile(SpillFile&& other) noexcept;
  SpillFile& operator=(SpillFile&& other) noexcept;
  SpillFile(const SpillFile&) = delete;
  SpillFile& operator=(const SpillFile&) = delete;
  ~SpillFile();

  void Append(const void* bytes, size_t size);
  size_t size() const { return size_; }  // bytes appended
  // `size` bytes from byte `offset` of what was appended (within size()).
  void ReadAt(size_t offset, void* bytes, size_t size);
  // visit(records, count) over everything appended, in order, in chunks of
  // whole records of record_bytes (> 0, dividing size()).
  void ForEachRecord(size_t record_bytes, const std::function<void(const uint8_t* records, size_t count)>& visit);
  // Writes what Append buffered. After it, and until the next Append, ReadAt
  // and ForEachRecord only read (pread), so several threads may read at once.
  void Flush();

 private:
  std::filesystem::path folder_;
  int fd_ = -1;
  size_t size_ = 0;
  std::vector<uint8_t> buffer_;
};

// SummarizeErrors (solver/angular_error.h) of the values given to Add in
// turn, bit for bit: the mean is the same sum in the same order, the median,
// 95th percentile and maximum the same order statistics (values NaN-free).
// The values are either kept in its own spill file or, where its owner can
// give them again (AlbedoColorComparison's spilled pixels hold what the
// albedo's errors are made of), not kept at all: then a replay hands them
// over again for the few passes Finish makes.
class ExactErrorStatistics {
 public:
  // replay(visit) calls visit with every value added (in chunks, in any order).
  using Replay = std::function<void(const std::function<void(std::span<const double>)>& visit)>;

  // Keeps the values in a spill file in `spill_folder` (SpillFile).
  explicit ExactErrorStatistics(const std::filesystem::path& spill_folder = {});
  // Keeps no values: Finish asks `replay` for them.
  explicit ExactErrorStatistics(Replay replay);
  ExactErrorStatistics(ExactErrorStatistics&&) noexcept;
  ExactErrorStatistics& operator=(ExactErrorStatistics&&) noexcept;
  ~ExactErrorStatistics();

  void Add(std::span<const double> values);
  // One value, only with a replay (there is nothing to spill): the per-pixel form.
  void Add(double value) {
    if (spill_) throw std::logic_error("ExactErrorStatistics::Add(double): its values are spilled; add a span");
    Count(value);
  }
  size_t count() const { return count_; }
  // May be called once; reads the values back (a few passes).
  ErrorStatistics Finish();

  // The value of rank `rank` (0-based, as std::nth_element) among those added.
  double ValueOfRank(size_t rank);
  // The values of several ranks, found in the same passes over the values.
  std::vector<double> ValuesOfRanks(std::span<const size_t> ranks);

 private:
  // The first histogram's leading bits: sign, exponent and 8 mantissa bits,
  // 1/256 of an octave a bucket, so the bucket of a median or p95 of 10 to
  // 50 M smooth values holds well under kMaxSelected and one pass selects
  // (with 16 bits the albedo's errors needed a pass more to split their
  // bucket); 8 MB of counts.
  static constexpr int kBucketBits = 20;
  // A bucket still too full is split by this many more bits per pass.
  static constexpr int kRefineBits = 16;
  // Non-NaN doubles to unsigned integers in the same order (negative values'
  // bits reversed below the positive ones').
  static uint64_t OrderKey(double value) {
    const uint64_t bits = std::bit_cast<uint64_t>(value);
    return (bits >> 63) ? ~bits : bits | (uint64_t{1} << 63);
  }
  static size_t Bucket(double value) { return OrderKey(value) >> (64 - kBucketBits); }
  // SummarizeErrors: std::accumulate from 0.0 in order; the largest by operator<.
  void Count(double value) {
    sum_ += value;
    if (count_ == 0 || max_ < value) max_ = value;
    ++count_;
    ++histogram_[Bucket(value)];
  }
  void ForEachValue(const std::function<void(std::span<const double>)>& visit);

  size_t count_ = 0;
  double sum_ = 0;
  double max_ = 0;
  std::vector<uint64_t> histogram_;  // 2^kBucketBits counts over the leading bits of the order key
  std::unique_ptr<SpillFile> spill_;  // null with a replay
  Replay replay_;
};

// SummarizeErrors of the values given to Add in turn, held in memory as
// floats (4 bytes a value, no spill file: writing one costs more CPU time on
// this kind of machine than the values' selection, docs/solver.md): the count,
// mean and maximum are SummarizeErrors' bit for bit (the same double sum in
// the same order, the same largest value); the median and 95th percentile are
// the order statistics of the values rounded to float, which are
// SummarizeErrors' rounded to float (rounding keeps the order): within 6e-8
// relative. 46 MB for the 11.4 M angles of a 16 MP solve.
class FloatErrorStatistics {
 public:
  // Room for this many values, so that growing never holds two copies.
  void Reserve(size_t count) { values_.reserve(count); }
  void Add(std::span<const double> values);
  size_t count() const { return values_.size(); }
  // Once (the values are reordered, then freed).
  ErrorStatistics Finish();

 private:
  double sum_ = 0;
  double max_ = 0;
  std::vector<float> values_;
};

}  // namespace scanbench
