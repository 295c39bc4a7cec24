#include "app/io/staged_folder.h"

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

// The solve's way: the result folder reserved beforehand (CreateResultFolder),
// the files written beside it in .<name>.partial, which replaces it on Commit.
TEST(StagedFolderTest, OntoReservedReplacesTheReservationOnCommit) {
  TemporaryFolder folder;
  fs::create_directory(folder / "run");
  StagedFolder staged = StagedFolder::OntoReserved(folder / "run");
  EXPECT_EQ(staged.final_dir(), folder / "run");
  EXPECT_EQ(staged.staging(), folder / ".run.partial");
  EXPECT_THAT(folder.List(), ElementsAre(".run.partial", "run"));
  WriteText(staged.staging() / "report.json", "{}\n");
  EXPECT_TRUE(fs::is_empty(folder / "run")) << "nothing appears before Commit";
  const uint64_t fsyncs = DirectoryFsyncCount();
  staged.Commit();
  EXPECT_GT(DirectoryFsyncCount(), fsyncs) << "the rename is made durable";
  EXPECT_THAT(folder.List(), ElementsAre("run"));
  EXPECT_EQ(ReadText(folder / "run" / "report.json"), "{}\n");
  EXPECT_THROW(staged.Commit(), std::logic_error);
}

TEST(StagedFolderTest, DiscardRemovesTheStagingFolderAndTheReservation) {
  TemporaryFolder folder;
  fs::create_directory(folder / "run");
  {
    StagedFolder staged = StagedFolder::OntoReserved(folder / "run");
    fs::create_directory(staged.staging() / "sub");
    WriteText(staged.staging() / "sub" / "a.txt", "a");
  }
  EXPECT_THAT(folder.List(), IsEmpty());
}

// A staging folder a killed run left is not taken into the new result.
TEST(StagedFolderTest, AStaleStagingFolderIsClearedFirst) {
  TemporaryFolder folder;
  fs::create_directories(folder / ".run.partial");
  WriteText(folder / ".run.partial" / "stale.txt", "old");
  fs::create_directory(folder / "run");
  StagedFolder staged = StagedFolder::OntoReserved(folder / "run");
  EXPECT_TRUE(fs::is_empty(staged.staging()));
  staged.Commit();
  EXPECT_TRUE(fs::is_empty(folder / "run"));
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
  EXPECT_TRUE(fs::is_directory(second.final_dir())) << "reserved at once";
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

// A moved-from object discards nothing: the new owner commits.
TEST(StagedFolderTest, MovedFromDiscardsNothing) {
  TemporaryFolder folder;
  fs::create_directory(folder / "run");
  std::optional<StagedFolder> owner;
  {
    StagedFolder staged = StagedFolder::OntoReserved(folder / "run");
    owner.emplace(std::move(staged));
  }
  EXPECT_THAT(folder.List(), ElementsAre(".run.partial", "run"));
  owner->Commit();
  EXPECT_THAT(folder.List(), ElementsAre("run"));
}

}  // namespace
}  // namespace scanbench
