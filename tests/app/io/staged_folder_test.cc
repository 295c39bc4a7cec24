#include "app/io/staged_folder.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <optional>
#include <string>

#include "app/io/file_util.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using testing::TemporaryFolder;

void WriteText(const fs::path& path, const std::string& text) {
  WriteFileAtomic(path, std::string_view(text), OverwritePolicy::kRefuse);
}

std::string ReadText(const fs::path& path) {
  const std::vector<uint8_t> bytes = ReadFileBytes(path);
  return std::string(bytes.begin(), bytes.end());
}

// The files are written beside the final name in .<name>.partial, reserved
// by .<name>.partial.lock; only Commit makes the final name.
TEST(StagedFolderTest, NothingHasTheFinalNameBeforeCommit) {
  TemporaryFolder folder;
  StagedFolder staged = StagedFolder::ReserveNumbered(folder.path(), "run");
  EXPECT_EQ(staged.final_dir(), folder / "run");
  EXPECT_EQ(staged.staging(), folder / ".run.partial");
  EXPECT_THAT(folder.List(), ElementsAre(".run.partial", ".run.partial.lock"));
  WriteText(staged.staging() / "report.json", "{}\n");
  const uint64_t fsyncs = DirectoryFsyncCount();
  staged.Commit();
  EXPECT_GT(DirectoryFsyncCount(), fsyncs) << "the rename is made durable";
  EXPECT_THAT(folder.List(), ElementsAre("run"));
  EXPECT_EQ(ReadText(folder / "run" / "report.json"), "{}\n");
  EXPECT_THROW(staged.Commit(), std::logic_error);
}

TEST(StagedFolderTest, DiscardRemovesTheStagingFolderAndTheReservation) {
  TemporaryFolder folder;
  {
    StagedFolder staged = StagedFolder::ReserveNumbered(folder.path(), "run");
    fs::create_directory(staged.staging() / "sub");
    WriteText(staged.staging() / "sub" / "a.txt", "a");
  }
  EXPECT_THAT(folder.List(), IsEmpty());
}

// A staging folder without a lock file (a killed run of a version before
// the locks) is not taken into the new result, and is removed.
TEST(StagedFolderTest, AStagingFolderWithoutItsLockIsCleared) {
  TemporaryFolder folder;
  fs::create_directories(folder / ".run.partial");
  WriteText(folder / ".run.partial" / "stale.txt", "old");
  StagedFolder staged = StagedFolder::ReserveNumbered(folder.path(), "run");
  EXPECT_EQ(staged.final_dir(), folder / "run");
  EXPECT_TRUE(fs::is_empty(staged.staging()));
  staged.Commit();
  EXPECT_TRUE(fs::is_empty(folder / "run"));
}

// What a run in another process left or holds, by a child that reserves
// "run" and then either dies by SIGKILL half-way through its files, or
// stays alive until told.
pid_t ChildReserving(const fs::path& parent, bool die, int* ready_fd) {
  int pipe_fds[2];
  if (::pipe(pipe_fds) != 0) return -1;
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(pipe_fds[0]);
    StagedFolder staged = StagedFolder::ReserveNumbered(parent, "run");
    WriteText(staged.staging() / "normal.exr", "half of it");
    if (die) ::raise(SIGKILL);
    const char ready = 1;
    [[maybe_unused]] const ssize_t written = ::write(pipe_fds[1], &ready, 1);
    ::pause();  // until killed
    ::_exit(0);
  }
  ::close(pipe_fds[1]);
  *ready_fd = pipe_fds[0];
  return pid;
}

TEST(StagedFolderTest, AKilledRunLeavesNoResultAndItsStagingGoesAtTheNextReservation) {
  TemporaryFolder folder;
  int ready = -1;
  const pid_t pid = ChildReserving(folder.path(), /*die=*/true, &ready);
  ASSERT_GT(pid, 0);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
  ::close(ready);
  EXPECT_THAT(folder.List(), ElementsAre(".run.partial", ".run.partial.lock")) << "no folder under the final name";

  StagedFolder next = StagedFolder::ReserveNumbered(folder.path(), "run");
  EXPECT_EQ(next.final_dir(), folder / "run") << "the dead run's name is free again";
  EXPECT_TRUE(fs::is_empty(next.staging())) << "none of the dead run's files";
  next.Commit();
  EXPECT_THAT(folder.List(), ElementsAre("run"));
}

TEST(StagedFolderTest, ALiveRunInAnotherProcessKeepsItsNameAndItsFiles) {
  TemporaryFolder folder;
  int ready = -1;
  const pid_t pid = ChildReserving(folder.path(), /*die=*/false, &ready);
  ASSERT_GT(pid, 0);
  char byte = 0;
  ASSERT_EQ(::read(ready, &byte, 1), 1);
  ::close(ready);

  EXPECT_EQ(StagedFolder::RemoveStale(folder.path()), 0);
  {
    StagedFolder beside = StagedFolder::ReserveNumbered(folder.path(), "run");
    EXPECT_EQ(beside.final_dir(), folder / "run-2");
    EXPECT_THAT([&] { StagedFolder::OntoAbsent(folder / "run"); },
                ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("is being written by another run")));
  }
  EXPECT_EQ(ReadText(folder / ".run.partial" / "normal.exr"), "half of it");

  ::kill(pid, SIGKILL);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  EXPECT_EQ(StagedFolder::RemoveStale(folder.path()), 1);
  EXPECT_THAT(folder.List(), IsEmpty());
}

// The export's way: <parent>/<base>[-N] reserved here, never an existing entry.
TEST(StagedFolderTest, ReserveNumberedTakesTheNextFreeName) {
  TemporaryFolder folder;
  const fs::path exports = folder / "exports";
  StagedFolder first = StagedFolder::ReserveNumbered(exports, "run-png16");
  EXPECT_EQ(first.final_dir(), exports / "run-png16");
  EXPECT_EQ(first.staging(), exports / ".run-png16.partial");
  WriteText(exports / "run-png16-2", "a file takes the name too");
  StagedFolder second = StagedFolder::ReserveNumbered(exports, "run-png16");
  EXPECT_EQ(second.final_dir(), exports / "run-png16-3");
  EXPECT_FALSE(fs::exists(second.final_dir())) << "reserved by its lock, not by the name";
  first.Commit();
  second.Commit();
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(exports)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_THAT(names, ElementsAre("run-png16", "run-png16-2", "run-png16-3"));
}

// A parent made for the folder goes again with it; one that existed stays.
TEST(StagedFolderTest, ReserveNumberedRemovesTheParentItMadeOnADiscard) {
  TemporaryFolder folder;
  { StagedFolder staged = StagedFolder::ReserveNumbered(folder / "exports" / "deep", "run"); }
  // Only the folder's own parent goes: the levels above it are not known to be empty.
  EXPECT_THAT(folder.List(), ElementsAre("exports"));
  EXPECT_TRUE(fs::is_empty(folder / "exports"));
  fs::create_directory(folder / "kept");
  { StagedFolder staged = StagedFolder::ReserveNumbered(folder / "kept", "run"); }
  EXPECT_THAT(folder.List(), ElementsAre("exports", "kept"));
  EXPECT_TRUE(fs::is_empty(folder / "kept"));
}

TEST(StagedFolderTest, ReserveNumberedNamesTheFolderItCannotMake) {
  TemporaryFolder folder;
  WriteText(folder / "file", "not a folder");
  EXPECT_THAT([&] { StagedFolder::ReserveNumbered(folder / "file", "run"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr((folder / "file").string() + ": cannot be created")));
}

// The data set solve's way: the output folder is absent until Commit, its
// parents made as needed.
TEST(StagedFolderTest, OntoAbsentAppearsOnlyOnCommit) {
  TemporaryFolder folder;
  const fs::path out = folder / "a" / "out";
  StagedFolder staged = StagedFolder::OntoAbsent(out);
  EXPECT_EQ(staged.staging(), folder / "a" / ".out.partial");
  EXPECT_FALSE(fs::exists(out));
  WriteText(staged.staging() / "normal.png", "png");
  staged.Commit();
  EXPECT_EQ(ReadText(out / "normal.png"), "png");
  EXPECT_FALSE(fs::exists(staged.staging()));
  {
    StagedFolder discarded = StagedFolder::OntoAbsent(folder / "a" / "other");
    WriteText(discarded.staging() / "normal.png", "png");
  }
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder / "a")) names.push_back(entry.path().filename().string());
  EXPECT_THAT(names, ElementsAre("out"));
}

// A bare name (`scanbench simulate-dataset out`) is in the working folder.
TEST(StagedFolderTest, OntoAbsentTakesABareNameInTheWorkingFolder) {
  TemporaryFolder folder;
  const fs::path before = fs::current_path();
  fs::current_path(folder.path());
  {
    StagedFolder staged = StagedFolder::OntoAbsent("out");
    WriteText(staged.staging() / "normal.png", "png");
    staged.Commit();
  }
  fs::current_path(before);
  EXPECT_EQ(ReadText(folder / "out" / "normal.png"), "png");
  EXPECT_THAT(folder.List(), ElementsAre("out"));
}

// A moved-from object discards nothing: the new owner commits.
TEST(StagedFolderTest, MovedFromDiscardsNothing) {
  TemporaryFolder folder;
  std::optional<StagedFolder> owner;
  {
    StagedFolder staged = StagedFolder::ReserveNumbered(folder.path(), "run");
    owner.emplace(std::move(staged));
  }
  EXPECT_THAT(folder.List(), ElementsAre(".run.partial", ".run.partial.lock"));
  owner->Commit();
  EXPECT_THAT(folder.List(), ElementsAre("run"));
}

}  // namespace
}  // namespace scanbench
