#include "app/io/file_util.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <random>
#include <stdexcept>

#include <openssl/evp.h>

namespace scanbench {
namespace fs = std::filesystem;

namespace {

std::runtime_error PathError(const fs::path& path, const std::string& problem) {
  return std::runtime_error(path.string() + ": " + problem);
}

std::atomic<uint64_t> directory_fsyncs{0};

// The file's bytes on disk before its name points at them.
void FsyncFile(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw PathError(path, std::string("cannot be opened to fsync: ") + std::strerror(errno));
  const int result = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (result != 0) throw PathError(path, std::string("fsync failed: ") + std::strerror(err));
}

fs::path FolderOf(const fs::path& path) { return path.has_parent_path() ? path.parent_path() : fs::path("."); }

std::string HexOf(const unsigned char* digest, unsigned int length) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  hex.reserve(length * 2);
  for (unsigned int i = 0; i < length; ++i) {
    hex.push_back(kHex[digest[i] >> 4]);
    hex.push_back(kHex[digest[i] & 15]);
  }
  return hex;
}

}  // namespace

void FsyncDirectory(const fs::path& folder) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) {
    throw PathError(folder, std::string("folder cannot be opened to fsync it: ") + std::strerror(errno));
  }
  const int result = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  // EINVAL: the file system cannot fsync folders (nothing more can be done).
  if (result != 0 && err != EINVAL) {
    throw PathError(folder, std::string("fsync of the folder failed: ") + std::strerror(err));
  }
  directory_fsyncs.fetch_add(1, std::memory_order_relaxed);
}

uint64_t DirectoryFsyncCount() { return directory_fsyncs.load(std::memory_order_relaxed); }

void RenameDurably(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec) throw PathError(to, "cannot be renamed from " + from.string() + ": " + ec.message());
  const fs::path to_folder = FolderOf(to), from_folder = FolderOf(from);
  FsyncDirectory(to_folder);
  std::error_code ignored;
  if (!fs::equivalent(from_folder, to_folder, ignored)) FsyncDirectory(from_folder);
}

void RenameDurablyOntoAbsent(const fs::path& from, const fs::path& to) {
  if (::renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), RENAME_NOREPLACE) != 0) {
    const int error = errno;
    if (error == EEXIST) throw PathError(to, "exists already; " + from.string() + " is not renamed onto it");
    if (error != EINVAL && error != ENOSYS) {
      throw PathError(to, "cannot be renamed from " + from.string() + ": " + std::strerror(error));
    }
    std::error_code ignored;
    if (fs::exists(fs::symlink_status(to, ignored))) {
      throw PathError(to, "exists already; " + from.string() + " is not renamed onto it");
    }
    RenameDurably(from, to);
    return;
  }
  const fs::path to_folder = FolderOf(to), from_folder = FolderOf(from);
  FsyncDirectory(to_folder);
  std::error_code ignored;
  if (!fs::equivalent(from_folder, to_folder, ignored)) FsyncDirectory(from_folder);
}

fs::path TemporarySiblingPath(const fs::path& path) {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  for (int attempt = 0; attempt < 100; ++attempt) {
    char suffix[32];
    std::snprintf(suffix, sizeof(suffix), ".tmp-%08llx",
                  static_cast<unsigned long long>(rng() & 0xffffffffULL));
    fs::path candidate = path;
    candidate += suffix;
    if (!fs::exists(candidate)) return candidate;
  }
  throw PathError(path, "could not find a free temporary name beside it");
}

void CommitTemporaryFile(const fs::path& temporary, const fs::path& path, OverwritePolicy policy) {
  try {
    FsyncFile(temporary);
  } catch (...) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw;
  }
  if (policy == OverwritePolicy::kRefuse) {
    // link() fails if the target exists, so an existing file is never replaced
    // even when two writers race.
    if (::link(temporary.c_str(), path.c_str()) != 0) {
      const int err = errno;
      std::error_code ignored;
      fs::remove(temporary, ignored);
      if (err == EEXIST) throw PathError(path, "already exists and is never overwritten");
      throw PathError(path, std::string("cannot be created: ") + std::strerror(err));
    }
    std::error_code ignored;
    fs::remove(temporary, ignored);
  } else {
    std::error_code ec;
    fs::rename(temporary, path, ec);
    if (ec) {
      fs::remove(temporary, ec);
      throw PathError(path, "cannot be replaced: " + ec.message());
    }
  }
  FsyncDirectory(FolderOf(path));
}

void WriteFileAtomic(const fs::path& path, std::span<const uint8_t> bytes, OverwritePolicy policy) {
  if (policy == OverwritePolicy::kRefuse && fs::exists(path)) {
    throw PathError(path, "already exists and is never overwritten");
  }
  const fs::path temporary = TemporarySiblingPath(path);
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw PathError(temporary, "cannot be opened for writing");
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) {
      out.close();
      std::error_code ignored;
      fs::remove(temporary, ignored);
      throw PathError(path, "write failed (disk full or removed?)");
    }
  }
  CommitTemporaryFile(temporary, path, policy);
}

void WriteFileAtomic(const fs::path& path, std::string_view text, OverwritePolicy policy) {
  WriteFileAtomic(path, std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(text.data()), text.size()),
                  policy);
}

FolderLock::FolderLock(const fs::path& folder) : folder_(folder) {
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throw PathError(folder, "folder cannot be created to lock it: " + ec.message());
  const fs::path lock_file = folder / kFolderLockFileName;
  fd_ = ::open(lock_file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw PathError(lock_file, std::string("cannot be opened: ") + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    long holder = 0;
    char text[32] = {};
    if (err == EWOULDBLOCK && ::pread(fd_, text, sizeof(text) - 1, 0) > 0) holder = std::strtol(text, nullptr, 10);
    ::close(fd_);
    fd_ = -1;
    if (err != EWOULDBLOCK) throw PathError(lock_file, std::string("cannot be locked: ") + std::strerror(err));
    throw FolderBusyError(folder.string() + ": in use by another process" +
                              (holder > 0 ? " (pid " + std::to_string(holder) + ")" : std::string()) +
                              " that holds " + lock_file.string() + "; wait for it to finish or stop it",
                          holder);
  }
  // Best effort: the pid only improves the message of a refused second holder.
  const std::string pid = std::to_string(static_cast<long>(::getpid())) + "\n";
  if (::ftruncate(fd_, 0) == 0) {
    [[maybe_unused]] const ssize_t written = ::pwrite(fd_, pid.data(), pid.size(), 0);
  }
}

FolderLock::~FolderLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the descriptor releases the flock
}

std::vector<uint8_t> ReadFileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw PathError(path, fs::exists(path) ? "cannot be opened for reading" : "does not exist");
  }
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw PathError(path, "cannot determine its size");
  in.seekg(0, std::ios::beg);
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  in.read(reinterpret_cast<char*>(bytes.data()), size);
  if (!in) throw PathError(path, "read failed");
  return bytes;
}

std::string Sha256Hex(std::span<const uint8_t> bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &length, EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("SHA-256 computation failed in OpenSSL");
  }
  return HexOf(digest, length);
}

std::string Sha256HexOfFile(const fs::path& path) {
  // Streamed through one buffer: a session's checksums cover 0.8 GB at 16 MP,
  // and reading each file whole faulted in fresh pages for every byte.
  constexpr size_t kChunkBytes = size_t{1} << 20;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    throw PathError(path, fs::exists(path) ? "cannot be opened for reading" : "does not exist");
  }
  ::posix_fadvise(fd, 0, 0, POSIX_FADV_SEQUENTIAL);
  const std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context(EVP_MD_CTX_new(), &EVP_MD_CTX_free);
  bool ok = context && EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr) == 1;
  thread_local std::vector<uint8_t> chunk(kChunkBytes);
  std::string read_problem;
  while (ok) {
    const ssize_t got = ::read(fd, chunk.data(), chunk.size());
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) {
      read_problem = std::string("read failed: ") + std::strerror(errno);
      break;
    }
    if (got == 0) break;
    ok = EVP_DigestUpdate(context.get(), chunk.data(), static_cast<size_t>(got)) == 1;
  }
  ::close(fd);
  if (!read_problem.empty()) throw PathError(path, read_problem);
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (!ok || EVP_DigestFinal_ex(context.get(), digest, &length) != 1) {
    throw std::runtime_error("SHA-256 computation failed in OpenSSL for " + path.string());
  }
  return HexOf(digest, length);
}

}  // namespace scanbench
