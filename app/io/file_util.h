// Safe file writes and checksums. Nothing is lost: every write goes to a
// temporary name in the same folder, is fsynced, renamed into place, and the
// folder is fsynced, so a file reported written survives a power cut (the
// rename itself lives in the folder's metadata, not in the file).
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace scanbench {

enum class OverwritePolicy {
  kRefuse,   // an existing file is an error (RAW frames, results)
  kReplace,  // atomically replace (manifests)
};

// Writes bytes to `path` via `path.tmp-<random>` + fsync + rename.
// Throws std::runtime_error naming the path and the problem.
void WriteFileAtomic(const std::filesystem::path& path, std::span<const uint8_t> bytes,
                     OverwritePolicy policy);
void WriteFileAtomic(const std::filesystem::path& path, std::string_view text,
                     OverwritePolicy policy);

// A temporary sibling name for `path` that does not exist yet, for writers
// (libtiff, OpenImageIO) that must be handed a file name. Pair with
// CommitTemporaryFile.
std::filesystem::path TemporarySiblingPath(const std::filesystem::path& path);
// Renames `temporary` onto `path` under the policy; removes `temporary` on failure.
// fsyncs `temporary` first and the containing folder after (FsyncDirectory).
void CommitTemporaryFile(const std::filesystem::path& temporary, const std::filesystem::path& path,
                         OverwritePolicy policy);

// Renames a file or folder and fsyncs the folder(s) holding both names. Throws
// std::runtime_error naming `from`, `to` and the problem. The one way the
// project renames anything.
void RenameDurably(const std::filesystem::path& from, const std::filesystem::path& to);
// The same, but `to` must not exist: an entry that has the name (even an
// empty folder) is never replaced (renameat2's RENAME_NOREPLACE; on a file
// system without it, a check before the rename).
void RenameDurablyOntoAbsent(const std::filesystem::path& from, const std::filesystem::path& to);

// Opens `folder` and fsyncs it, so that renames, links and unlinks in it are
// on disk. Throws std::runtime_error naming the folder when it cannot be
// opened or fsync reports an I/O error; a file system that does not support
// fsync on folders (EINVAL) counts as success.
void FsyncDirectory(const std::filesystem::path& folder);
// How many FsyncDirectory calls succeeded in this process (diagnostics and
// tests: each write helper adds exactly one).
uint64_t DirectoryFsyncCount();

// An exclusive advisory lock (flock) on `folder`/.scanbench.lock, held by an
// open descriptor: the kernel releases it when the process exits or crashes,
// so a stale lock never needs clearing. Two FolderLocks on the same folder
// conflict even within one process. The lock file holds the holder's pid (for
// the message) and is left in place: removing it would let a third process
// lock a fresh file while the second still holds the old one.
class FolderLock {
 public:
  // Creates `folder` if missing. Throws FolderBusyError naming the folder (and
  // the holder's pid when the file records one) if another holder has it, and
  // std::runtime_error naming the lock file on any other failure.
  explicit FolderLock(const std::filesystem::path& folder);
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  const std::filesystem::path& folder() const { return folder_; }

 private:
  std::filesystem::path folder_;
  int fd_ = -1;
};
inline constexpr const char* kFolderLockFileName = ".scanbench.lock";

class FolderBusyError : public std::runtime_error {
 public:
  FolderBusyError(const std::string& message, long holder_pid)
      : std::runtime_error(message), holder_pid_(holder_pid) {}
  long holder_pid() const { return holder_pid_; }  // 0 = unknown

 private:
  long holder_pid_;
};

// Whole file into memory; throws naming the path if it cannot be read.
std::vector<uint8_t> ReadFileBytes(const std::filesystem::path& path);

// Lower-case hex SHA-256.
std::string Sha256Hex(std::span<const uint8_t> bytes);
std::string Sha256HexOfFile(const std::filesystem::path& path);

}  // namespace scanbench
