// "Write into a staging folder, then rename it into place": a result, export
// or data-set folder appears complete or not at all. Everything is written
// into the hidden sibling <parent>/.<name>.partial of the final folder
// <parent>/<name>, which Commit renames into place (RenameDurably); an object
// destroyed without Commit (a failure, a cancel) removes the staging folder
// and whatever it reserved.
#pragma once

#include <filesystem>
#include <string>

namespace scanbench {

class StagedFolder {
 public:
  // Onto `reserved_dir`, an empty folder the caller reserved (CreateResultFolder:
  // two runs never share a name): Commit replaces it; a discard removes it.
  static StagedFolder OntoReserved(std::filesystem::path reserved_dir);
  // Onto a new <parent>/<base_name>[-N] reserved here (mkdir fails on any
  // existing entry, so two writers, even in two processes, never share one),
  // then as OntoReserved. `parent` is made when missing, and removed again by
  // a discard when it is left empty.
  static StagedFolder ReserveNumbered(const std::filesystem::path& parent, const std::string& base_name);
  // Onto `final_dir`, which must not exist (the caller removed an earlier one):
  // it appears on Commit. Missing parents are made.
  static StagedFolder OntoAbsent(std::filesystem::path final_dir);

  StagedFolder(StagedFolder&& other) noexcept;
  StagedFolder& operator=(StagedFolder&&) = delete;
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;
  ~StagedFolder();

  const std::filesystem::path& final_dir() const { return final_dir_; }
  const std::filesystem::path& staging() const { return staging_dir_; }
  // Renames the staging folder onto final_dir() (replacing the empty
  // reservation) and fsyncs the folder holding it. Once.
  void Commit();

 private:
  // Makes the staging folder beside `final_dir` (clearing a stale one a killed
  // run left) and owns what `reserved` and `made_parent` say; a failure
  // discards that and throws std::runtime_error naming the staging folder.
  StagedFolder(std::filesystem::path final_dir, bool reserved, bool made_parent);
  void Discard() noexcept;

  std::filesystem::path final_dir_, staging_dir_;
  bool reserved_ = false;     // final_dir_ is an empty reservation this object removes on a discard
  bool made_parent_ = false;  // final_dir_'s parent was made here: removed on a discard when empty
  bool done_ = false;         // committed, or moved from: nothing to discard
};

}  // namespace scanbench
