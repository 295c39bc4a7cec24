#include "app/io/file_util.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "tests/app/io/test_dng_util.h"

namespace scanbench {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::StartsWith;
using testing::TempDir;

std::string ReadText(const std::filesystem::path& path) {
  const std::vector<uint8_t> bytes = ReadFileBytes(path);
  return std::string(bytes.begin(), bytes.end());
}

TEST(FileUtilTest, WriteFileAtomicCreatesFile) {
  TempDir dir;
  WriteFileAtomic(dir / "session.json", std::string_view("{\"a\": 1}\n"), OverwritePolicy::kRefuse);
  EXPECT_EQ(ReadText(dir / "session.json"), "{\"a\": 1}\n");
  EXPECT_THAT(dir.List(), ElementsAre("session.json"));
}

TEST(FileUtilTest, RefuseKeepsExistingFile) {
  TempDir dir;
  WriteFileAtomic(dir / "frame.raw", std::string_view("first"), OverwritePolicy::kRefuse);
  try {
    WriteFileAtomic(dir / "frame.raw", std::string_view("second"), OverwritePolicy::kRefuse);
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), StartsWith((dir / "frame.raw").string() + ": "));
    EXPECT_THAT(e.what(), HasSubstr("already exists and is never overwritten"));
  }
  EXPECT_EQ(ReadText(dir / "frame.raw"), "first");
  EXPECT_THAT(dir.List(), ElementsAre("frame.raw"));
}

TEST(FileUtilTest, ReplaceOverwritesAtomically) {
  TempDir dir;
  WriteFileAtomic(dir / "manifest.json", std::string_view("old contents, longer"), OverwritePolicy::kReplace);
  WriteFileAtomic(dir / "manifest.json", std::string_view("new"), OverwritePolicy::kReplace);
  EXPECT_EQ(ReadText(dir / "manifest.json"), "new");
  EXPECT_THAT(dir.List(), ElementsAre("manifest.json"));
}

TEST(FileUtilTest, BinaryBytesRoundTrip) {
  TempDir dir;
  std::vector<uint8_t> bytes(1000);
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<uint8_t>(i * 37);
  bytes[10] = 0;
  WriteFileAtomic(dir / "blob.bin", bytes, OverwritePolicy::kRefuse);
  EXPECT_EQ(ReadFileBytes(dir / "blob.bin"), bytes);
}

TEST(FileUtilTest, EmptyFileRoundTrips) {
  TempDir dir;
  WriteFileAtomic(dir / "empty", std::string_view(), OverwritePolicy::kRefuse);
  EXPECT_TRUE(ReadFileBytes(dir / "empty").empty());
}

TEST(FileUtilTest, WriteIntoMissingFolderFailsWithoutLeftovers) {
  TempDir dir;
  EXPECT_THROW(WriteFileAtomic(dir / "no" / "such" / "file", std::string_view("x"), OverwritePolicy::kReplace),
               std::runtime_error);
  EXPECT_TRUE(dir.List().empty());
}

TEST(FileUtilTest, TemporarySiblingPathIsBesideAndFree) {
  TempDir dir;
  const auto path = dir / "image.exr";
  const auto temporary = TemporarySiblingPath(path);
  EXPECT_EQ(temporary.parent_path(), path.parent_path());
  EXPECT_THAT(temporary.filename().string(), StartsWith("image.exr.tmp-"));
  EXPECT_FALSE(std::filesystem::exists(temporary));
}

TEST(FileUtilTest, CommitTemporaryFileRefusalRemovesTemporary) {
  TempDir dir;
  WriteFileAtomic(dir / "a.txt", std::string_view("kept"), OverwritePolicy::kRefuse);
  const auto temporary = TemporarySiblingPath(dir / "a.txt");
  WriteFileAtomic(temporary, std::string_view("new"), OverwritePolicy::kRefuse);
  EXPECT_THROW(CommitTemporaryFile(temporary, dir / "a.txt", OverwritePolicy::kRefuse), std::runtime_error);
  EXPECT_EQ(ReadText(dir / "a.txt"), "kept");
  EXPECT_THAT(dir.List(), ElementsAre("a.txt"));
}

TEST(FileUtilTest, EveryWriteHelperFsyncsTheFolderOnce) {
  TempDir dir;
  uint64_t before = DirectoryFsyncCount();
  WriteFileAtomic(dir / "frame.raw", std::string_view("frame"), OverwritePolicy::kRefuse);
  EXPECT_EQ(DirectoryFsyncCount(), before + 1);

  before = DirectoryFsyncCount();
  WriteFileAtomic(dir / "session.json", std::string_view("{}"), OverwritePolicy::kReplace);
  EXPECT_EQ(DirectoryFsyncCount(), before + 1);

  const auto temporary = TemporarySiblingPath(dir / "image.exr");
  { std::ofstream(temporary) << "pixels"; }
  before = DirectoryFsyncCount();
  CommitTemporaryFile(temporary, dir / "image.exr", OverwritePolicy::kRefuse);
  EXPECT_EQ(DirectoryFsyncCount(), before + 1);
  EXPECT_EQ(ReadText(dir / "image.exr"), "pixels");
}

TEST(FileUtilTest, RenameDurablyFsyncsBothFolders) {
  TempDir dir;
  std::filesystem::create_directories(dir / "staging" / "run");
  std::filesystem::create_directories(dir / "results");
  WriteFileAtomic(dir / "staging" / "run" / "report.json", std::string_view("{}"), OverwritePolicy::kRefuse);
  uint64_t before = DirectoryFsyncCount();
  RenameDurably(dir / "staging" / "run", dir / "results" / "run");
  EXPECT_EQ(DirectoryFsyncCount(), before + 2);  // the name left one folder and entered another
  EXPECT_EQ(ReadText(dir / "results" / "run" / "report.json"), "{}");

  before = DirectoryFsyncCount();
  RenameDurably(dir / "results" / "run", dir / "results" / "run2");
  EXPECT_EQ(DirectoryFsyncCount(), before + 1);  // one folder holds both names
  EXPECT_TRUE(std::filesystem::exists(dir / "results" / "run2" / "report.json"));
}

TEST(FileUtilTest, RenameDurablyFailureNamesBothPaths) {
  TempDir dir;
  try {
    RenameDurably(dir / "missing", dir / "target");
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), StartsWith((dir / "target").string() + ": cannot be renamed from " +
                                     (dir / "missing").string()));
  }
}

TEST(FileUtilTest, FsyncDirectoryFailureNamesTheFolder) {
  TempDir dir;
  const uint64_t before = DirectoryFsyncCount();
  try {
    FsyncDirectory(dir / "gone");
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              (dir / "gone").string() + ": folder cannot be opened to fsync it: No such file or directory");
  }
  // A file where the folder should be: open(O_DIRECTORY) refuses it.
  WriteFileAtomic(dir / "plain", std::string_view("x"), OverwritePolicy::kRefuse);
  try {
    FsyncDirectory(dir / "plain");
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), StartsWith((dir / "plain").string() + ": folder cannot be opened to fsync it: "));
  }
  EXPECT_EQ(DirectoryFsyncCount(), before + 1);  // the write's only
  FsyncDirectory(dir.path());
  EXPECT_EQ(DirectoryFsyncCount(), before + 2);
}

TEST(FileUtilTest, FolderLockRefusesASecondHolderNamingFolderAndPid) {
  TempDir dir;
  const auto session = dir / "session";
  std::optional<FolderLock> first(std::in_place, session);  // creates the folder
  EXPECT_TRUE(std::filesystem::is_directory(session));
  try {
    FolderLock second(session);
    ADD_FAILURE() << "expected the folder to be busy";
  } catch (const FolderBusyError& e) {
    EXPECT_EQ(e.holder_pid(), static_cast<long>(::getpid()));
    EXPECT_THAT(e.what(), StartsWith(session.string() + ": in use by another process (pid " +
                                     std::to_string(::getpid()) + ")"));
  }
  first.reset();
  FolderLock again(session);  // released with its descriptor
  EXPECT_THAT(dir.List(), ElementsAre("session"));
}

TEST(FileUtilTest, FolderLockOfAKilledProcessIsReleased) {
  TempDir dir;
  const auto session = dir / "session";
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(ready[0]);
    try {
      FolderLock held(session);
      const char byte = 1;
      if (::write(ready[1], &byte, 1) != 1) ::_exit(2);
      ::pause();  // until killed
    } catch (...) {
      ::_exit(3);
    }
    ::_exit(0);
  }
  ::close(ready[1]);
  char byte = 0;
  ASSERT_EQ(::read(ready[0], &byte, 1), 1) << "the child did not take the lock";
  ::close(ready[0]);
  try {
    FolderLock refused(session);
    ADD_FAILURE() << "expected the child's lock to hold";
  } catch (const FolderBusyError& e) {
    EXPECT_EQ(e.holder_pid(), static_cast<long>(child));
    EXPECT_THAT(e.what(), HasSubstr("(pid " + std::to_string(child) + ")"));
  }
  ::kill(child, SIGKILL);  // a crash: no destructor runs
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  FolderLock after_crash(session);
  EXPECT_EQ(after_crash.folder(), session);
}

TEST(FileUtilTest, Sha256KnownVectors) {
  const std::string abc = "abc";
  EXPECT_EQ(Sha256Hex(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(abc.data()), abc.size())),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(Sha256Hex({}), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
}

TEST(FileUtilTest, Sha256OfFileMatchesBytes) {
  TempDir dir;
  WriteFileAtomic(dir / "abc.txt", std::string_view("abc"), OverwritePolicy::kRefuse);
  EXPECT_EQ(Sha256HexOfFile(dir / "abc.txt"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(FileUtilTest, Sha256OfFileLargerThanItsReadChunkMatchesTheBytes) {
  // 3 MiB and a tail: the file is hashed through a 1 MiB buffer.
  TempDir dir;
  std::vector<uint8_t> bytes((size_t{3} << 20) + 17);
  std::mt19937 random(7);
  for (uint8_t& byte : bytes) byte = static_cast<uint8_t>(random());
  WriteFileAtomic(dir / "frame.dng", std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                  OverwritePolicy::kRefuse);
  EXPECT_EQ(Sha256HexOfFile(dir / "frame.dng"), Sha256Hex(bytes));
  bytes.back() ^= 1;
  EXPECT_NE(Sha256HexOfFile(dir / "frame.dng"), Sha256Hex(bytes));
}

TEST(FileUtilTest, Sha256OfMissingFileNamesIt) {
  TempDir dir;
  try {
    Sha256HexOfFile(dir / "led_03.dng");
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("led_03.dng: does not exist"), std::string::npos) << e.what();
  }
}

TEST(FileUtilTest, ReadFileBytesMissingFileNamesIt) {
  TempDir dir;
  const auto path = dir / "missing.dng";
  try {
    ReadFileBytes(path);
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ": does not exist");
  }
}

}  // namespace
}  // namespace scanbench
