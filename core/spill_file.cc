#include "core/spill_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

namespace scanbench {
namespace fs = std::filesystem;
namespace {

constexpr size_t kSpillBufferBytes = 1 << 20;

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

void SpillFile::WriteAll(const uint8_t* data, size_t left) {
  while (left > 0) {
    const ssize_t written = ::write(fd_, data, left);
    if (written < 0) {
      if (errno == EINTR) continue;
      throw SpillError(folder_, "write failed");
    }
    data += written;
    left -= static_cast<size_t>(written);
  }
}

void SpillFile::Flush() {
  if (buffer_.empty()) return;
  WriteAll(buffer_.data(), buffer_.size());
  buffer_.clear();
}

void SpillFile::Append(const void* bytes, size_t size) {
  const uint8_t* data = static_cast<const uint8_t*>(bytes);
  size_ += size;
  if (size >= kSpillBufferBytes) {
    // A band's worth at once (the first pass's maps): written from the
    // caller's memory, not copied through the buffer first.
    Flush();
    WriteAll(data, size);
    return;
  }
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

}  // namespace scanbench
