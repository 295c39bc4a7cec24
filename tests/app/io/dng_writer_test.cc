#include "app/io/dng_writer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

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

// ---- colour tags, read back through LibRaw -----------------------------------

// A D5100-like XYZ -> camera matrix: far from sRGB primaries, rows not summing to 1.
Eigen::Matrix3d CameraFromXyz() {
  return (Eigen::Matrix3d() << 0.8198, -0.2239, -0.0724, -0.4871, 1.2389, 0.2798, -0.1043, 0.2050, 0.7181)
      .finished();
}

void ExpectNear(const Eigen::Matrix3d& actual, const Eigen::Matrix3d& expected, double tolerance) {
  EXPECT_LT((actual - expected).cwiseAbs().maxCoeff(), tolerance) << "actual\n" << actual << "\nexpected\n"
                                                                  << expected;
}

TEST(DngWriterTest, ColorMatrixNeutralAndForwardMatrixReadBack) {
  DngMetadata metadata;
  metadata.camera_from_xyz_d65 = CameraFromXyz();
  metadata.as_shot_neutral = Eigen::Vector3d(0.4791, 1.0, 0.6523);
  const Eigen::Matrix3d forward =
      (Eigen::Matrix3d() << 0.7, 0.2, 0.0643, 0.25, 0.8, -0.05, 0.01, -0.1, 0.9149).finished();
  metadata.forward_matrix_d50 = forward;
  const DecodedRaw decoded = DecodeRawWithInfo(EncodeDng(SmallRaw(), metadata), "colour.dng");

  ASSERT_TRUE(decoded.camera_from_xyz.has_value());
  // SRATIONAL storage and LibRaw's float copy: a few 1e-7.
  ExpectNear(*decoded.camera_from_xyz, CameraFromXyz(), 1e-6);
  EXPECT_EQ(decoded.camera_from_xyz_illuminant, 21);
  EXPECT_LT((decoded.as_shot_neutral - Eigen::Vector3d(0.4791, 1.0, 0.6523)).cwiseAbs().maxCoeff(), 1e-6)
      << decoded.as_shot_neutral.transpose();
  ASSERT_TRUE(decoded.forward_matrix_d50.has_value());
  ExpectNear(*decoded.forward_matrix_d50, forward, 1e-6);

  // pre_mul is what LibRaw derives from the matrix: 1 / row sums of camera_from_linear_srgb,
  // relative to green, so a neutral lit by D65 (XYZ = the D65 white) becomes (1, 1, 1).
  const Eigen::Vector3d d65_white(0.95047, 1.0, 1.08883);
  const Eigen::Vector3d camera_of_white = CameraFromXyz() * d65_white;
  const Eigen::Vector3d balanced = decoded.daylight_multipliers.cwiseProduct(camera_of_white);
  EXPECT_NEAR(balanced[0] / balanced[1], 1.0, 2e-3) << decoded.daylight_multipliers.transpose();
  EXPECT_NEAR(balanced[2] / balanced[1], 1.0, 2e-3) << decoded.daylight_multipliers.transpose();
  EXPECT_DOUBLE_EQ(decoded.daylight_multipliers[1], 1.0);
}

TEST(DngWriterTest, WithoutColorMetadataTheSrgbPrimariesCameraIsWritten) {
  const DecodedRaw decoded = DecodeRawWithInfo(EncodeDng(SmallRaw()), "plain.dng");
  ASSERT_TRUE(decoded.camera_from_xyz.has_value());
  const Eigen::Matrix3d srgb_from_xyz =
      (Eigen::Matrix3d() << 3.2406, -1.5372, -0.4986, -0.9689, 1.8758, 0.0415, 0.0557, -0.2040, 1.0570).finished();
  ExpectNear(*decoded.camera_from_xyz, srgb_from_xyz, 1e-6);
  EXPECT_EQ(decoded.camera_from_xyz_illuminant, 21);
  EXPECT_LT((decoded.as_shot_neutral - Eigen::Vector3d::Ones()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_FALSE(decoded.forward_matrix_d50.has_value());
  // sRGB primaries: the daylight multipliers are all about 1.
  EXPECT_LT((decoded.daylight_multipliers - Eigen::Vector3d::Ones()).cwiseAbs().maxCoeff(), 2e-3)
      << decoded.daylight_multipliers.transpose();
}

TEST(DngWriterTest, ColorMetadataDoesNotChangeThePixels) {
  DngMetadata metadata;
  metadata.camera_from_xyz_d65 = CameraFromXyz();
  metadata.as_shot_neutral = Eigen::Vector3d(0.5, 1.0, 0.7);
  const RawImage decoded = DecodeRaw(EncodeDng(SmallRaw(), metadata), "colour.dng");
  EXPECT_EQ(decoded.black_level, SmallRaw().black_level);
  EXPECT_EQ(decoded.white_level, 4095);
  EXPECT_EQ(decoded.mosaic(3, 4), 500);
}

TEST(DngWriterTest, RejectsInvalidColorMetadata) {
  DngMetadata nan_matrix;
  nan_matrix.camera_from_xyz_d65 = CameraFromXyz();
  (*nan_matrix.camera_from_xyz_d65)(1, 2) = std::nan("");
  ExpectInvalid(SmallRaw(), nan_matrix, "metadata.camera_from_xyz_d65 = [");
  ExpectInvalid(SmallRaw(), nan_matrix, "must be finite");

  DngMetadata zero_matrix;
  zero_matrix.camera_from_xyz_d65 = Eigen::Matrix3d::Zero();
  ExpectInvalid(SmallRaw(), zero_matrix, "metadata.camera_from_xyz_d65 is all zeros");

  DngMetadata zero_forward;
  zero_forward.forward_matrix_d50 = Eigen::Matrix3d::Zero();
  ExpectInvalid(SmallRaw(), zero_forward, "metadata.forward_matrix_d50 is all zeros");

  DngMetadata bad_neutral;
  bad_neutral.as_shot_neutral = Eigen::Vector3d(0.5, 1.0, 0.0);
  ExpectInvalid(SmallRaw(), bad_neutral, "metadata.as_shot_neutral[2] = 0.000000 must be finite and > 0");
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
