#include "app/controllers/exact_statistics.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

namespace scanbench {
namespace fs = std::filesystem;
namespace {

constexpr size_t kSpillBufferBytes = 1 << 20;
// At most this many values are read back for one selection (8 MB).
constexpr size_t kMaxSelected = 1 << 20;

std::runtime_error SpillError(const fs::path& folder, const std::string& what) {
  return std::runtime_error("temporary spill file in " + folder.string() + ": " + what + " (" +
                            std::strerror(errno) + ")");
}

}  // namespace

SpillFile::SpillFile(const fs::path& folder) : folder_(folder.empty() ? fs::temp_directory_path() : folder) {
#ifdef O_TMPFILE
  fd_ = ::open(folder_.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
#endif
  if (fd_ < 0) {
    // A file system without O_TMPFILE: a named file, unlinked at once.
    std::string name = (folder_ / ".scanbench-spill-XXXXXX").string();
    fd_ = ::mkstemp(name.data());
    if (fd_ < 0) throw SpillError(folder_, "cannot be created");
    ::unlink(name.c_str());
  }
  buffer_.reserve(kSpillBufferBytes);
}

SpillFile::SpillFile(SpillFile&& other) noexcept
    : folder_(std::move(other.folder_)), fd_(other.fd_), size_(other.size_), buffer_(std::move(other.buffer_)) {
  other.fd_ = -1;
}

SpillFile& SpillFile::operator=(SpillFile&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    folder_ = std::move(other.folder_);
    fd_ = other.fd_;
    size_ = other.size_;
    buffer_ = std::move(other.buffer_);
    other.fd_ = -1;
  }
  return *this;
}

SpillFile::~SpillFile() {
  if (fd_ >= 0) ::close(fd_);
}

void SpillFile::Flush() {
  if (buffer_.empty()) return;
  const uint8_t* data = buffer_.data();
  size_t left = buffer_.size();
  while (left > 0) {
    const ssize_t written = ::write(fd_, data, left);
    if (written < 0) {
      if (errno == EINTR) continue;
      throw SpillError(folder_, "write failed");
    }
    data += written;
    left -= static_cast<size_t>(written);
  }
  buffer_.clear();
}

void SpillFile::Append(const void* bytes, size_t size) {
  const uint8_t* data = static_cast<const uint8_t*>(bytes);
  size_ += size;
  while (size > 0) {
    const size_t take = std::min(size, kSpillBufferBytes - buffer_.size());
    buffer_.insert(buffer_.end(), data, data + take);
    data += take;
    size -= take;
    if (buffer_.size() == kSpillBufferBytes) Flush();
  }
}

void SpillFile::ReadAt(size_t offset, void* bytes, size_t size) {
  if (offset > size_ || size > size_ - offset) {
    throw std::invalid_argument("SpillFile::ReadAt: bytes [" + std::to_string(offset) + ", " +
                                std::to_string(offset + size) + ") of " + std::to_string(size_));
  }
  Flush();
  uint8_t* out = static_cast<uint8_t*>(bytes);
  for (size_t got = 0; got < size;) {
    const ssize_t read = ::pread(fd_, out + got, size - got, static_cast<off_t>(offset + got));
    if (read < 0 && errno == EINTR) continue;
    if (read <= 0) throw SpillError(folder_, "read failed");
    got += static_cast<size_t>(read);
  }
}

void SpillFile::ForEachRecord(size_t record_bytes,
                              const std::function<void(const uint8_t* records, size_t count)>& visit) {
  if (record_bytes == 0 || size_ % record_bytes != 0) {
    throw std::invalid_argument("SpillFile::ForEachRecord: records of " + std::to_string(record_bytes) +
                                " bytes do not divide its " + std::to_string(size_) + " bytes");
  }
  Flush();
  std::vector<uint8_t> chunk(std::max<size_t>(1, kSpillBufferBytes / record_bytes) * record_bytes);
  for (size_t offset = 0; offset < size_;) {
    const size_t want = std::min(chunk.size(), size_ - offset);
    size_t got = 0;
    while (got < want) {
      const ssize_t read = ::pread(fd_, chunk.data() + got, want - got, static_cast<off_t>(offset + got));
      if (read < 0 && errno == EINTR) continue;
      if (read <= 0) throw SpillError(folder_, "read failed");
      got += static_cast<size_t>(read);
    }
    visit(chunk.data(), want / record_bytes);
    offset += want;
  }
}

ExactErrorStatistics::ExactErrorStatistics(const fs::path& spill_folder)
    : histogram_(size_t{1} << kBucketBits, 0), spill_(std::make_unique<SpillFile>(spill_folder)) {}

ExactErrorStatistics::ExactErrorStatistics(Replay replay)
    : histogram_(size_t{1} << kBucketBits, 0), replay_(std::move(replay)) {
  if (!replay_) throw std::invalid_argument("ExactErrorStatistics: an empty replay");
}

ExactErrorStatistics::ExactErrorStatistics(ExactErrorStatistics&&) noexcept = default;
ExactErrorStatistics& ExactErrorStatistics::operator=(ExactErrorStatistics&&) noexcept = default;
ExactErrorStatistics::~ExactErrorStatistics() = default;

void ExactErrorStatistics::Add(std::span<const double> values) {
  for (const double value : values) Count(value);
  if (spill_) spill_->Append(values.data(), values.size_bytes());
}

void ExactErrorStatistics::ForEachValue(const std::function<void(std::span<const double>)>& visit) {
  if (!spill_) {
    replay_(visit);
    return;
  }
  spill_->ForEachRecord(sizeof(double), [&](const uint8_t* records, size_t count) {
    // The spill's chunks are whole doubles, copied into an aligned buffer.
    double values[4096];
    for (size_t i = 0; i < count; i += std::size(values)) {
      const size_t n = std::min(std::size(values), count - i);
      std::memcpy(values, records + i * sizeof(double), n * sizeof(double));
      visit(std::span<const double>(values, n));
    }
  });
}

double ExactErrorStatistics::ValueOfRank(size_t rank) { return ValuesOfRanks(std::span<const size_t>(&rank, 1))[0]; }

std::vector<double> ExactErrorStatistics::ValuesOfRanks(std::span<const size_t> ranks) {
  // Per rank: the bucket of leading bits that holds it; while that holds too
  // many values, a histogram of the next bits among them. The ranks share
  // every pass over the values.
  struct Search {
    size_t rank = 0;  // within the bucket
    int prefix_bits = kBucketBits;
    uint64_t prefix = 0;
    size_t in_bucket = 0;
    std::vector<uint64_t> finer;
    int next_bits = 0;
    std::vector<double> selected;
    bool Matches(uint64_t key) const { return (key >> (64 - prefix_bits)) == prefix; }
    bool Refines() const { return in_bucket > kMaxSelected && prefix_bits < 64; }
  };
  std::vector<Search> searches(ranks.size());
  for (size_t i = 0; i < ranks.size(); ++i) {
    if (ranks[i] >= count_) {
      throw std::invalid_argument("ExactErrorStatistics::ValueOfRank: rank " + std::to_string(ranks[i]) + " of " +
                                  std::to_string(count_) + " values");
    }
    Search& search = searches[i];
    search.rank = ranks[i];
    for (size_t b = 0, before = 0; b < histogram_.size(); ++b) {
      if (search.rank < before + histogram_[b]) {
        search.prefix = b;
        search.in_bucket = histogram_[b];
        search.rank -= before;
        break;
      }
      before += histogram_[b];
    }
  }
  while (std::any_of(searches.begin(), searches.end(), [](const Search& s) { return s.Refines(); })) {
    for (Search& search : searches) {
      search.next_bits = search.Refines() ? std::min(kRefineBits, 64 - search.prefix_bits) : 0;
      search.finer.assign(search.next_bits > 0 ? size_t{1} << search.next_bits : 0, 0);
    }
    ForEachValue([&](std::span<const double> values) {
      for (const double value : values) {
        const uint64_t key = OrderKey(value);
        for (Search& search : searches) {
          if (search.next_bits > 0 && search.Matches(key)) {
            ++search.finer[(key >> (64 - search.prefix_bits - search.next_bits)) &
                           ((uint64_t{1} << search.next_bits) - 1)];
          }
        }
      }
    });
    for (Search& search : searches) {
      if (search.next_bits == 0) continue;
      for (size_t b = 0, before = 0; b < search.finer.size(); ++b) {
        if (search.rank < before + search.finer[b]) {
          search.prefix = (search.prefix << search.next_bits) | b;
          search.in_bucket = search.finer[b];
          search.rank -= before;
          break;
        }
        before += search.finer[b];
      }
      search.prefix_bits += search.next_bits;
      search.finer = {};
    }
  }
  for (Search& search : searches) search.selected.reserve(std::min(search.in_bucket, kMaxSelected));
  ForEachValue([&](std::span<const double> values) {
    for (const double value : values) {
      const uint64_t key = OrderKey(value);
      for (Search& search : searches) {
        // All 64 bits fixed: every value in the bucket is this one; one suffices.
        if (search.Matches(key) && (search.prefix_bits < 64 || search.selected.empty())) {
          search.selected.push_back(value);
        }
      }
    }
  });
  std::vector<double> result;
  for (Search& search : searches) {
    if (search.prefix_bits >= 64) {
      result.push_back(search.selected.front());
      continue;
    }
    std::nth_element(search.selected.begin(), search.selected.begin() + search.rank, search.selected.end());
    result.push_back(search.selected[search.rank]);
  }
  return result;
}

ErrorStatistics ExactErrorStatistics::Finish() {
  ErrorStatistics stats;
  stats.num_pixels = count_;
  if (count_ == 0) return stats;
  stats.mean = sum_ / count_;
  // SummarizeErrors' ranks, both found in the same passes.
  const auto rank_of = [&](double fraction) {
    return std::min(count_ - 1, static_cast<size_t>(fraction * (count_ - 1) + 0.5));
  };
  const size_t ranks[] = {rank_of(0.5), rank_of(0.95)};
  const std::vector<double> values = ValuesOfRanks(ranks);
  stats.median = values[0];
  stats.percentile_95 = values[1];
  stats.max = max_;
  return stats;
}

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
