#include "app/io/dng_writer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/io/file_util.h"
#include "app/io/raw_decoder.h"
#include "tests/app/io/test_dng_util.h"

namespace scanbench {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using testing::TempDir;

RawImage SmallRaw() {
  RawImage raw;
  raw.cfa = CfaPattern::kRGGB;
  raw.black_level = {100, 101, 102, 103};
  raw.white_level = 4095;
  raw.mosaic = ImageU16(24, 22, 1, 500);
  return raw;
}

void ExpectInvalid(const RawImage& raw, const DngMetadata& metadata, const std::string& problem) {
  try {
    EncodeDng(raw, metadata);
    ADD_FAILURE() << "expected std::invalid_argument containing '" << problem << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr(problem));
  }
}

TEST(DngWriterTest, StartsWithLittleEndianTiffHeader) {
  const std::vector<uint8_t> bytes = EncodeDng(SmallRaw());
  ASSERT_GT(bytes.size(), 24u * 22u * 2u);
  EXPECT_THAT(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 4), ElementsAre('I', 'I', 42, 0));
}

TEST(DngWriterTest, EncodingIsDeterministic) {
  EXPECT_EQ(EncodeDng(SmallRaw()), EncodeDng(SmallRaw()));
}

TEST(DngWriterTest, RejectsInvalidInput) {
  RawImage empty = SmallRaw();
  empty.mosaic = ImageU16();
  ExpectInvalid(empty, {}, "mosaic is empty");

  RawImage three_channels = SmallRaw();
  three_channels.mosaic = ImageU16(24, 22, 3);
  ExpectInvalid(three_channels, {}, "has 3 channels");

  RawImage tiny = SmallRaw();
  tiny.mosaic = ImageU16(21, 30, 1);
  ExpectInvalid(tiny, {}, "mosaic is 21x30");

  RawImage white_at_black = SmallRaw();
  white_at_black.white_level = 103;
  ExpectInvalid(white_at_black, {}, "white_level 103 must exceed black_level[3] = 103");

  RawImage too_bright = SmallRaw();
  too_bright.mosaic(5, 6) = 4096;
  ExpectInvalid(too_bright, {}, "pixel (5, 6) = 4096 exceeds white_level 4095");

  DngMetadata bad_time;
  bad_time.capture_time = "2024-03-05T14:07:09";
  ExpectInvalid(SmallRaw(), bad_time, "capture_time '2024-03-05T14:07:09'");

  DngMetadata bad_iso;
  bad_iso.iso = 100000;
  ExpectInvalid(SmallRaw(), bad_iso, "metadata.iso");

  DngMetadata negative_exposure;
  negative_exposure.exposure_time_s = -1;
  ExpectInvalid(SmallRaw(), negative_exposure, "metadata.exposure_time_s");
}

TEST(DngWriterTest, WriteDngRefusesToOverwriteAndLeavesNoTemporary) {
  TempDir dir;
  const auto path = dir / "led_00.dng";
  WriteDng(path, SmallRaw(), {});
  const std::string first_hash = Sha256HexOfFile(path);

  RawImage other = SmallRaw();
  other.mosaic(0, 0) = 7;
  try {
    WriteDng(path, other, {});
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(path.string()));
    EXPECT_THAT(e.what(), HasSubstr("already exists"));
  }
  EXPECT_EQ(Sha256HexOfFile(path), first_hash);
  EXPECT_THAT(dir.List(), ElementsAre("led_00.dng"));
  EXPECT_EQ(DecodeRawFile(path).mosaic(0, 0), 500);
}

TEST(DngWriterTest, WriteDngNamesThePathForInvalidInput) {
  TempDir dir;
  RawImage empty = SmallRaw();
  empty.mosaic = ImageU16();
  try {
    WriteDng(dir / "bad.dng", empty, {});
    ADD_FAILURE() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("bad.dng: "));
    EXPECT_THAT(e.what(), HasSubstr("mosaic is empty"));
  }
  EXPECT_TRUE(dir.List().empty());
}

TEST(DngWriterTest, WriteDngIntoMissingFolderFailsCleanly) {
  TempDir dir;
  EXPECT_THROW(WriteDng(dir / "missing" / "led_00.dng", SmallRaw(), {}), std::runtime_error);
  EXPECT_TRUE(dir.List().empty());
}

}  // namespace
}  // namespace scanbench
