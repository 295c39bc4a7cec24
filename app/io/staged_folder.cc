#include "app/io/staged_folder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>
#include <stdexcept>
#include <utility>

#include "app/io/file_util.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

constexpr std::string_view kStagingSuffix = ".partial";
constexpr std::string_view kLockSuffix = ".partial.lock";
constexpr std::string_view kLockTemporaryInfix = ".partial.lock.tmp-";

// .<name><suffix> beside `final_dir` (appended: `"." + string` draws GCC 12's false -Wrestrict).
fs::path HiddenSibling(const fs::path& final_dir, std::string_view suffix) {
  std::string name = ".";
  name += final_dir.filename().string();
  name += suffix;
  return final_dir.parent_path() / name;
}

std::string ErrnoText() { return std::strerror(errno); }

// The exclusive lock of `fd` without waiting: false when another open file
// description holds it (flock, as FolderLock: two holders conflict even in one process).
bool TryLock(int fd) { return ::flock(fd, LOCK_EX | LOCK_NB) == 0; }

bool SameFile(int fd, const fs::path& path) {
  struct stat opened {}, named {};
  return ::fstat(fd, &opened) == 0 && ::lstat(path.c_str(), &named) == 0 && opened.st_dev == named.st_dev &&
         opened.st_ino == named.st_ino;
}

// Reserves `final_dir`: its lock file appears already locked (made and locked
// under a temporary name, then linked, which fails on an existing name), so a
// lock file without a holder is always a dead run's. The held descriptor, or
// -1 when the name is reserved already (errno EEXIST).
int TryReserve(const fs::path& final_dir) {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  const fs::path lock_path = HiddenSibling(final_dir, kLockSuffix);
  char suffix[24];
  std::snprintf(suffix, sizeof(suffix), "%016llx", static_cast<unsigned long long>(rng()));
  const fs::path temporary = HiddenSibling(final_dir, std::string(kLockTemporaryInfix) + suffix);
  const int fd = ::open(temporary.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) throw std::runtime_error(temporary.string() + ": cannot be created: " + ErrnoText());
  if (!TryLock(fd)) {
    const std::string problem = temporary.string() + ": cannot be locked: " + ErrnoText();
    ::unlink(temporary.c_str());
    ::close(fd);
    throw std::runtime_error(problem);
  }
  const int linked = ::link(temporary.c_str(), lock_path.c_str());
  const int link_errno = errno;
  ::unlink(temporary.c_str());
  if (linked == 0) return fd;
  ::close(fd);
  if (link_errno == EEXIST) {
    errno = EEXIST;
    return -1;
  }
  throw std::runtime_error(lock_path.string() + ": cannot be created: " + std::strerror(link_errno));
}

// The lock file `lock_path` if its holder is dead: the staging folder it
// reserved and the file itself removed. True when removed.
bool RemoveIfDead(const fs::path& lock_path, const fs::path& staging) {
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) return false;  // gone meanwhile
  bool removed = false;
  // Locked by us and still the file under that name (not one a new run
  // linked after another cleaner unlinked the old): its holder is dead.
  if (TryLock(fd) && SameFile(fd, lock_path)) {
    std::error_code ignored;
    if (!staging.empty()) fs::remove_all(staging, ignored);
    removed = ::unlink(lock_path.c_str()) == 0;
  }
  ::close(fd);
  return removed;
}

bool EndsWith(const std::string& text, std::string_view suffix) {
  return text.size() > suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

int StagedFolder::RemoveStale(const fs::path& parent) {
  int removed = 0;
  std::error_code error;
  std::vector<fs::path> locks, temporaries, stagings;
  for (const auto& entry : fs::directory_iterator(parent, error)) {
    const std::string name = entry.path().filename().string();
    if (!name.starts_with(".")) continue;
    if (EndsWith(name, kLockSuffix)) {
      locks.push_back(entry.path());
    } else if (name.find(kLockTemporaryInfix) != std::string::npos) {
      temporaries.push_back(entry.path());
    } else if (EndsWith(name, kStagingSuffix)) {
      stagings.push_back(entry.path());
    }
  }
  for (const fs::path& lock : locks) {
    const std::string name = lock.filename().string();
    const fs::path staging = parent / name.substr(0, name.size() - std::string_view(".lock").size());
    removed += RemoveIfDead(lock, staging) ? 1 : 0;
  }
  // A temporary lock file is held from its creation to its unlink: unheld, it is a dead run's.
  for (const fs::path& temporary : temporaries) RemoveIfDead(temporary, {});
  // A live run makes its lock file before its staging folder and removes it
  // after: a staging folder without one is a dead run's (or an older version's).
  for (const fs::path& staging : stagings) {
    fs::path lock = staging;
    lock += ".lock";
    if (fs::exists(lock, error) || !fs::is_directory(staging, error)) continue;
    fs::remove_all(staging, error);
    removed += error ? 0 : 1;
  }
  return removed;
}

StagedFolder StagedFolder::ReserveNumbered(const fs::path& given_parent, const std::string& base_name) {
  const fs::path parent = given_parent.empty() ? fs::path(".") : given_parent;
  std::error_code error;
  bool made_parent = false;
  if (!fs::is_directory(parent, error)) {
    fs::create_directories(parent, error);
    if (error) throw std::runtime_error(parent.string() + ": cannot be created: " + error.message());
    made_parent = true;
  }
  RemoveStale(parent);
  constexpr int kMaxAttempts = 10000;
  for (int attempt = 1; attempt <= kMaxAttempts; ++attempt) {
    const fs::path folder = parent / (attempt == 1 ? base_name : base_name + "-" + std::to_string(attempt));
    if (fs::exists(fs::symlink_status(folder, error))) continue;
    int fd = -1;
    try {
      fd = TryReserve(folder);
    } catch (...) {
      if (made_parent) fs::remove(parent, error);
      throw;
    }
    if (fd < 0) continue;  // another live run's
    // The name may have been taken (committed) between the check and the reservation.
    if (fs::exists(fs::symlink_status(folder, error))) {
      ::unlink(HiddenSibling(folder, kLockSuffix).c_str());
      ::close(fd);
      continue;
    }
    return StagedFolder(folder, fd, made_parent);
  }
  if (made_parent) fs::remove(parent, error);
  throw std::runtime_error(parent.string() + ": " + std::to_string(kMaxAttempts) + " folders named " + base_name +
                           "* exist already");
}

StagedFolder StagedFolder::OntoAbsent(fs::path final_dir) {
  std::error_code error;
  const fs::path parent = final_dir.parent_path();  // empty for a bare name: the working folder
  if (!parent.empty()) fs::create_directories(parent, error);
  if (error) throw std::runtime_error(parent.string() + ": cannot be created: " + error.message());
  int fd = TryReserve(final_dir);
  if (fd < 0 && RemoveIfDead(HiddenSibling(final_dir, kLockSuffix), HiddenSibling(final_dir, kStagingSuffix))) {
    fd = TryReserve(final_dir);  // a killed run's, cleared
  }
  if (fd < 0) {
    throw std::runtime_error(HiddenSibling(final_dir, kStagingSuffix).string() +
                             ": is being written by another run (its lock " +
                             HiddenSibling(final_dir, kLockSuffix).filename().string() + " is held)");
  }
  return StagedFolder(std::move(final_dir), fd, /*made_parent=*/false);
}

StagedFolder::StagedFolder(fs::path final_dir, int lock_fd, bool made_parent)
    : final_dir_(std::move(final_dir)),
      staging_dir_(HiddenSibling(final_dir_, kStagingSuffix)),
      lock_path_(HiddenSibling(final_dir_, kLockSuffix)),
      lock_fd_(lock_fd),
      made_parent_(made_parent) {
  std::error_code error;
  fs::remove_all(staging_dir_, error);  // a killed run's without its lock file (an older version's)
  if (!error) fs::create_directories(staging_dir_, error);
  if (error) {
    Discard();
    throw std::runtime_error(staging_dir_.string() + ": cannot be created: " + error.message());
  }
}

StagedFolder::StagedFolder(StagedFolder&& other) noexcept
    : final_dir_(std::move(other.final_dir_)),
      staging_dir_(std::move(other.staging_dir_)),
      lock_path_(std::move(other.lock_path_)),
      lock_fd_(std::exchange(other.lock_fd_, -1)),
      made_parent_(other.made_parent_),
      done_(other.done_) {
  other.done_ = true;
}

StagedFolder::~StagedFolder() {
  if (!done_) Discard();
}

void StagedFolder::Commit() {
  if (done_) throw std::logic_error("StagedFolder::Commit: " + final_dir_.string() + " committed already");
  RenameDurablyOntoAbsent(staging_dir_, final_dir_);
  done_ = true;
  Release();
}

void StagedFolder::Release() noexcept {
  if (lock_fd_ < 0) return;
  ::unlink(lock_path_.c_str());  // still ours: held all along
  ::close(lock_fd_);
  lock_fd_ = -1;
}

void StagedFolder::Discard() noexcept {
  std::error_code ignored;
  fs::remove_all(staging_dir_, ignored);
  Release();  // after the staging folder: a live staging folder always has its lock file
  if (made_parent_) fs::remove(final_dir_.parent_path(), ignored);  // only if empty
}

}  // namespace scanbench
