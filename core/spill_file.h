// SpillFile: records kept out of memory in an unlinked temporary file (the
// solve's first-pass bands until the depth refinement decides, the colour
// comparison's pixels of possible uniform regions).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

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
  void WriteAll(const uint8_t* data, size_t size);

  std::filesystem::path folder_;
  int fd_ = -1;
  size_t size_ = 0;
  std::vector<uint8_t> buffer_;
};

}  // namespace scanbench
