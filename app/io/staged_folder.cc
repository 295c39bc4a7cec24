#include "app/io/staged_folder.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "app/io/file_util.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// .<name>.partial (appended: `"." + string` draws GCC 12's false -Wrestrict).
fs::path StagingFolderOf(const fs::path& final_dir) {
  std::string name = ".";
  name += final_dir.filename().string();
  name += ".partial";
  return final_dir.parent_path() / name;
}

}  // namespace

StagedFolder StagedFolder::OntoReserved(fs::path reserved_dir) {
  return StagedFolder(std::move(reserved_dir), /*reserved=*/true, /*made_parent=*/false);
}

StagedFolder StagedFolder::ReserveNumbered(const fs::path& parent, const std::string& base_name) {
  std::error_code error;
  bool made_parent = false;
  if (!fs::is_directory(parent, error)) {
    fs::create_directories(parent, error);
    if (error) throw std::runtime_error(parent.string() + ": cannot be created: " + error.message());
    made_parent = true;
  }
  constexpr int kMaxAttempts = 10000;
  for (int attempt = 1; attempt <= kMaxAttempts; ++attempt) {
    const fs::path folder = parent / (attempt == 1 ? base_name : base_name + "-" + std::to_string(attempt));
    if (::mkdir(folder.c_str(), 0777) == 0) return StagedFolder(folder, /*reserved=*/true, made_parent);
    if (errno != EEXIST) {
      const std::string problem = folder.string() + ": cannot be created: " + std::strerror(errno);
      if (made_parent) fs::remove(parent, error);
      throw std::runtime_error(problem);
    }
  }
  if (made_parent) fs::remove(parent, error);
  throw std::runtime_error(parent.string() + ": " + std::to_string(kMaxAttempts) + " folders named " + base_name +
                           "* exist already");
}

StagedFolder StagedFolder::OntoAbsent(fs::path final_dir) {
  return StagedFolder(std::move(final_dir), /*reserved=*/false, /*made_parent=*/false);
}

StagedFolder::StagedFolder(fs::path final_dir, bool reserved, bool made_parent)
    : final_dir_(std::move(final_dir)),
      staging_dir_(StagingFolderOf(final_dir_)),
      reserved_(reserved),
      made_parent_(made_parent) {
  std::error_code error;
  fs::remove_all(staging_dir_, error);  // a killed run's, never committed
  if (!error) fs::create_directories(staging_dir_, error);
  if (error) {
    Discard();
    throw std::runtime_error(staging_dir_.string() + ": cannot be created: " + error.message());
  }
}

StagedFolder::StagedFolder(StagedFolder&& other) noexcept
    : final_dir_(std::move(other.final_dir_)),
      staging_dir_(std::move(other.staging_dir_)),
      reserved_(other.reserved_),
      made_parent_(other.made_parent_),
      done_(other.done_) {
  other.done_ = true;
}

StagedFolder::~StagedFolder() {
  if (!done_) Discard();
}

void StagedFolder::Commit() {
  if (done_) throw std::logic_error("StagedFolder::Commit: " + final_dir_.string() + " committed already");
  RenameDurably(staging_dir_, final_dir_);  // replaces an empty reservation
  done_ = true;
}

void StagedFolder::Discard() noexcept {
  std::error_code ignored;
  fs::remove_all(staging_dir_, ignored);
  if (reserved_) fs::remove(final_dir_, ignored);                  // still the empty reservation
  if (made_parent_) fs::remove(final_dir_.parent_path(), ignored);  // only if empty
}

}  // namespace scanbench
