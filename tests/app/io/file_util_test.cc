#include "app/io/file_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

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
