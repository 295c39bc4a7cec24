// "Write into a staging folder, then rename it into place": a result, export
// or data-set folder appears complete or not at all. Everything is written
// into the hidden sibling <parent>/.<name>.partial of the final folder
// <parent>/<name>, which Commit renames into place (RenameDurably); an object
// destroyed without Commit (a failure, a cancel) removes the staging folder.
//
// A run killed outright (kill -9, power loss) leaves nothing under the final
// name: the name is reserved by the lock file <parent>/.<name>.partial.lock,
// made with O_EXCL and held with an open-file-description lock
// (F_OFD_SETLK) for the object's life. The kernel drops the lock when its
// holder dies, so a later reservation in the same parent knows a dead run's
// staging folder and lock file from a live one's (in this or any process on
// the machine; on NFS as far as its byte-range locks go) and removes them.
#pragma once

#include <filesystem>
#include <string>

namespace scanbench {

class StagedFolder {
 public:
  // Onto a new <parent>/<base_name>[-N], the first N (from 1, unnumbered)
  // whose name is free and not reserved by another live StagedFolder; dead
  // runs' staging folders in `parent` are removed first. Nothing appears
  // under the final name before Commit. `parent` is made when missing, and
  // removed again by a discard when it is left empty.
  static StagedFolder ReserveNumbered(const std::filesystem::path& parent, const std::string& base_name);
  // Onto `final_dir`, which must not exist (the caller removed an earlier one):
  // it appears on Commit. Missing parents are made. A staging folder a killed
  // run left for the same name is cleared; a live one's is refused.
  static StagedFolder OntoAbsent(std::filesystem::path final_dir);

  // Removes the staging folders (and lock files) of dead runs in `parent`:
  // those whose lock no process holds, and staging folders without a lock
  // file (left by a version before the locks). Returns how many it removed.
  static int RemoveStale(const std::filesystem::path& parent);

  StagedFolder(StagedFolder&& other) noexcept;
  StagedFolder& operator=(StagedFolder&&) = delete;
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;
  ~StagedFolder();

  const std::filesystem::path& final_dir() const { return final_dir_; }
  const std::filesystem::path& staging() const { return staging_dir_; }
  // Renames the staging folder onto final_dir() (refusing an entry that took
  // the name meanwhile), fsyncs the folder holding it and releases the
  // reservation. Once.
  void Commit();

 private:
  // Takes over the held reservation `lock_fd` of `final_dir` and makes the
  // staging folder; a failure discards both and throws std::runtime_error
  // naming the staging folder.
  StagedFolder(std::filesystem::path final_dir, int lock_fd, bool made_parent);
  void Discard() noexcept;
  void Release() noexcept;  // the lock file and its descriptor

  std::filesystem::path final_dir_, staging_dir_, lock_path_;
  int lock_fd_ = -1;          // the held reservation
  bool made_parent_ = false;  // final_dir_'s parent was made here: removed on a discard when empty
  bool done_ = false;         // committed, or moved from: nothing to discard
};

}  // namespace scanbench
