#include "app/io/raw_decoder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <random>
#include <tuple>

#include "app/io/dng_writer.h"
#include "app/io/file_util.h"
#include "tests/app/io/test_dng_util.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;
using testing::MakeTestDng;
using testing::TempDir;
using testing::TestDngOptions;

constexpr uint16_t kStripOffsets = 273;
constexpr uint16_t kStripByteCounts = 279;

RawImage RandomRaw(int width, int height, CfaPattern cfa, uint32_t seed) {
  std::mt19937 rng(seed);
  RawImage raw;
  raw.cfa = cfa;
  raw.white_level = 16383;  // 14-bit sensor
  std::uniform_int_distribution<int> black(0, 2047);
  for (uint16_t& b : raw.black_level) b = static_cast<uint16_t>(black(rng));
  raw.mosaic = ImageU16(width, height, 1);
  std::uniform_int_distribution<int> value(0, raw.white_level);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) raw.mosaic(x, y) = static_cast<uint16_t>(value(rng));
  }
  // The extremes must survive too.
  raw.mosaic(0, 0) = 0;
  raw.mosaic(width - 1, height - 1) = raw.white_level;
  return raw;
}

void ExpectSameRaw(const RawImage& expected, const RawImage& actual) {
  EXPECT_EQ(CfaPatternName(actual.cfa), CfaPatternName(expected.cfa));
  EXPECT_EQ(actual.black_level, expected.black_level);
  EXPECT_EQ(actual.white_level, expected.white_level);
  ASSERT_EQ(actual.width(), expected.width());
  ASSERT_EQ(actual.height(), expected.height());
  ASSERT_EQ(actual.mosaic.channels(), 1);
  int mismatches = 0;
  for (int y = 0; y < expected.height(); ++y) {
    for (int x = 0; x < expected.width(); ++x) {
      if (actual.mosaic(x, y) != expected.mosaic(x, y) && ++mismatches <= 5) {
        ADD_FAILURE() << "pixel (" << x << ", " << y << "): " << actual.mosaic(x, y) << " != "
                      << expected.mosaic(x, y);
      }
    }
  }
  EXPECT_EQ(mismatches, 0);
}

// ---- round trip through LibRaw ---------------------------------------------

class DngRoundTripTest : public ::testing::TestWithParam<std::tuple<CfaPattern, int, int>> {};

TEST_P(DngRoundTripTest, BitExactThroughLibRaw) {
  const auto [cfa, width, height] = GetParam();
  const RawImage raw = RandomRaw(width, height, cfa, 1234u + width * 7u + height + static_cast<uint32_t>(cfa));
  const std::vector<uint8_t> dng = EncodeDng(raw);
  const RawImage decoded = DecodeRaw(dng, "frame.dng");
  ExpectSameRaw(raw, decoded);
}

std::string RoundTripName(const ::testing::TestParamInfo<std::tuple<CfaPattern, int, int>>& test) {
  const auto& [cfa, width, height] = test.param;
  return CfaPatternName(cfa) + "_" + std::to_string(width) + "x" + std::to_string(height);
}

INSTANTIATE_TEST_SUITE_P(
    AllLayoutsOddAndEvenSizes, DngRoundTripTest,
    ::testing::Combine(::testing::Values(CfaPattern::kRGGB, CfaPattern::kBGGR, CfaPattern::kGRBG, CfaPattern::kGBRG),
                       ::testing::Values(22, 41, 64), ::testing::Values(22, 33, 48)),
    RoundTripName);

TEST(RawDecoderTest, LargerFrameRoundTripsThroughFile) {
  TempDir dir;
  const RawImage raw = RandomRaw(1232, 816, CfaPattern::kGRBG, 99);
  WriteDng(dir / "led_03.dng", raw, {});
  ExpectSameRaw(raw, DecodeRawFile(dir / "led_03.dng"));
}

TEST(RawDecoderTest, MetadataSurvives) {
  const RawImage raw = RandomRaw(40, 30, CfaPattern::kBGGR, 7);
  DngMetadata metadata;
  metadata.make = "scanbench";
  metadata.model = "Simulated D5100";
  metadata.serial = "SIM-000042";
  metadata.software = "scanbench sim 0.1";
  metadata.exposure_time_s = 1.0 / 125.0;
  metadata.iso = 200;
  metadata.f_number = 8;
  metadata.capture_time = "2024:03:05 14:07:09";
  const DecodedRaw decoded = DecodeRawWithInfo(EncodeDng(raw, metadata), "frame.dng");
  EXPECT_EQ(decoded.make, "scanbench");
  EXPECT_EQ(decoded.model, "Simulated D5100");
  EXPECT_EQ(decoded.serial, "SIM-000042");
  EXPECT_EQ(decoded.software, "scanbench sim 0.1");
  EXPECT_NEAR(decoded.exposure_time_s, 1.0 / 125.0, 1e-7);
  EXPECT_DOUBLE_EQ(decoded.iso, 200);
  EXPECT_NEAR(decoded.f_number, 8, 1e-6);
  EXPECT_EQ(decoded.capture_time, "2024:03:05 14:07:09");
  ExpectSameRaw(raw, decoded.image);
}

TEST(RawDecoderTest, UnsetMetadataReadsBackAsUnknown) {
  const DecodedRaw decoded = DecodeRawWithInfo(EncodeDng(RandomRaw(30, 30, CfaPattern::kRGGB, 3)), "frame.dng");
  EXPECT_EQ(decoded.serial, "");
  EXPECT_EQ(decoded.capture_time, "");
  EXPECT_EQ(decoded.exposure_time_s, 0);
  EXPECT_EQ(decoded.iso, 0);
  EXPECT_EQ(decoded.f_number, 0);
}

TEST(RawDecoderTest, ZeroBlackLevelAndFullSixteenBitWhite) {
  RawImage raw = RandomRaw(24, 24, CfaPattern::kRGGB, 5);
  raw.black_level = {0, 0, 0, 0};
  raw.white_level = 65535;
  raw.mosaic(3, 3) = 65535;
  ExpectSameRaw(raw, DecodeRaw(EncodeDng(raw), "frame.dng"));
}

// A DNG written by another tool, with a single black level: must read as the
// same level at every tile position.
TEST(RawDecoderTest, ReadsSingleBlackLevelDng) {
  TestDngOptions options;
  options.cfa_pattern = {1, 2, 0, 1};  // GBRG
  options.black_levels = {200};
  options.white_level = 4000;
  const RawImage decoded = DecodeRaw(MakeTestDng(options), "other.dng");
  EXPECT_EQ(CfaPatternName(decoded.cfa), "GBRG");
  EXPECT_EQ(decoded.black_level, (std::array<uint16_t, 4>{200, 200, 200, 200}));
  EXPECT_EQ(decoded.white_level, 4000);
  EXPECT_EQ(decoded.width(), 40);
  EXPECT_EQ(decoded.height(), 30);
  EXPECT_EQ(decoded.mosaic(5, 7), 12);
}

// ---- validation --------------------------------------------------------------

void ExpectDecodeError(const std::vector<uint8_t>& bytes, const std::string& name, const std::string& problem) {
  try {
    DecodeRaw(bytes, name);
    ADD_FAILURE() << "expected an error containing '" << problem << "'";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(name + ": "));
    EXPECT_THAT(e.what(), HasSubstr(problem));
  }
}

TEST(RawDecoderTest, RejectsLinearRawDng) {
  TestDngOptions options;
  options.photometric = 34892;
  options.samples_per_pixel = 3;
  options.cfa_pattern.clear();
  ExpectDecodeError(MakeTestDng(options), "frames/linear.dng", "3-channel image");
  ExpectDecodeError(MakeTestDng(options), "frames/linear.dng", "not a Bayer CFA mosaic");
}

TEST(RawDecoderTest, RejectsXTransDng) {
  TestDngOptions options;
  options.width = options.height = 36;
  options.cfa_rows = options.cfa_cols = 6;
  options.cfa_pattern = {1, 1, 0, 1, 1, 2, 1, 1, 2, 1, 1, 0, 2, 0, 1, 0, 2, 1,
                         1, 1, 2, 1, 1, 0, 1, 1, 0, 1, 1, 2, 0, 2, 1, 2, 0, 1};
  ExpectDecodeError(MakeTestDng(options), "frames/xtrans.dng", "X-Trans");
}

TEST(RawDecoderTest, RejectsCfaThatIsNotTwoByTwo) {
  TestDngOptions options;
  options.cfa_rows = 4;
  options.cfa_cols = 2;
  options.cfa_pattern = {0, 1, 1, 2, 2, 1, 1, 0};  // RGGB over BGGR
  ExpectDecodeError(MakeTestDng(options), "frames/odd_cfa.dng", "does not repeat every 2x2 pixels");
}

TEST(RawDecoderTest, RejectsBlackPatternThatIsNotTwoByTwo) {
  TestDngOptions options;
  options.black_rows = 1;
  options.black_cols = 4;
  options.black_levels = {100, 110, 120, 130};
  ExpectDecodeError(MakeTestDng(options), "frames/black.dng", "black level pattern that does not repeat");
}

TEST(RawDecoderTest, RejectsWhiteNotAboveBlack) {
  TestDngOptions options;
  options.black_levels = {300};
  options.white_level = 300;
  ExpectDecodeError(MakeTestDng(options), "frames/white.dng", "white level 300 is not above the black level 300");
}

TEST(RawDecoderTest, RejectsGarbage) {
  std::mt19937 rng(17);
  std::vector<uint8_t> garbage(12345);
  for (uint8_t& b : garbage) b = static_cast<uint8_t>(rng());
  ExpectDecodeError(garbage, "frames/garbage.nef", "is not a RAW file LibRaw recognises");
  const std::string text = "this is a text file, not a photograph\n";
  ExpectDecodeError(std::vector<uint8_t>(text.begin(), text.end()), "notes.txt", "is not a RAW file");
  ExpectDecodeError({}, "empty.nef", "is empty");
}

TEST(RawDecoderTest, RejectsTruncatedFileAtEveryKindOfCutPoint) {
  const std::vector<uint8_t> full = EncodeDng(RandomRaw(64, 48, CfaPattern::kRGGB, 11));
  const size_t data_offset = testing::ReadIfd0Value(full, kStripOffsets);
  ASSERT_GT(data_offset, 100u);
  ASSERT_EQ(data_offset + 64 * 48 * 2, full.size()) << "the image directory must precede the pixel data";
  // One byte short is the case LibRaw itself decodes without complaint.
  for (size_t cut : {full.size() - 1, full.size() - 2, full.size() - 64 * 2 * 10, data_offset + 1,
                     data_offset + 64 * 2 * 20 + 3, data_offset / 2, size_t{40}, size_t{9}, size_t{6}}) {
    SCOPED_TRACE("cut at " + std::to_string(cut) + " of " + std::to_string(full.size()));
    ExpectDecodeError(std::vector<uint8_t>(full.begin(), full.begin() + static_cast<long>(cut)),
                      "frames/led_07.dng", "truncated");
  }
}

// The TIFF directory agrees with the short file, so only the size an
// uncompressed strip must have (which LibRaw does not check) reveals the cut.
TEST(RawDecoderTest, RejectsTruncationHiddenByMatchingByteCount) {
  std::vector<uint8_t> bytes = EncodeDng(RandomRaw(64, 48, CfaPattern::kBGGR, 21));
  const size_t data_offset = testing::ReadIfd0Value(bytes, kStripOffsets);
  for (size_t missing : {size_t{1}, size_t{2}, size_t{64 * 2 * 5 + 1}}) {
    SCOPED_TRACE("missing " + std::to_string(missing) + " bytes");
    std::vector<uint8_t> cut(bytes.begin(), bytes.end() - static_cast<long>(missing));
    testing::PatchIfd0Value(cut, kStripByteCounts, static_cast<uint32_t>(cut.size() - data_offset));
    ExpectDecodeError(cut, "frames/led_08.dng", "is truncated: its 64x48 16-bit pixel data needs bytes");
  }
}

TEST(RawDecoderTest, RejectsFileWithoutPixelData) {
  std::vector<uint8_t> bytes = EncodeDng(RandomRaw(40, 30, CfaPattern::kRGGB, 13));
  const size_t data_offset = testing::ReadIfd0Value(bytes, kStripOffsets);
  // Only the header remains, and it says so: no strip offset, no bytes.
  bytes.resize(data_offset);
  testing::PatchIfd0Value(bytes, kStripOffsets, 0);
  testing::PatchIfd0Value(bytes, kStripByteCounts, 0);
  ExpectDecodeError(bytes, "frames/empty.dng", "no pixel data");

  // Byte count 0 but a plausible offset.
  std::vector<uint8_t> zero_count = EncodeDng(RandomRaw(40, 30, CfaPattern::kRGGB, 13));
  testing::PatchIfd0Value(zero_count, kStripByteCounts, 0);
  ExpectDecodeError(zero_count, "frames/zero.dng", "no pixel data");
}

TEST(RawDecoderTest, MissingFileNamesThePath) {
  TempDir dir;
  try {
    DecodeRawFile(dir / "frames" / "led_99.dng");
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("led_99.dng"));
    EXPECT_THAT(e.what(), HasSubstr("does not exist"));
  }
}

TEST(RawDecoderTest, FileErrorsStartWithThePath) {
  TempDir dir;
  std::vector<uint8_t> bytes = EncodeDng(RandomRaw(40, 30, CfaPattern::kRGGB, 2));
  bytes.resize(bytes.size() - 10);
  WriteFileAtomic(dir / "cut.dng", bytes, OverwritePolicy::kRefuse);
  try {
    DecodeRawFile(dir / "cut.dng");
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr((dir / "cut.dng").string() + ": is truncated"));
  }
}

TEST(RawDecoderTest, CheckRawSize) {
  const RawImage raw = RandomRaw(40, 30, CfaPattern::kRGGB, 1);
  EXPECT_NO_THROW(CheckRawSize(raw, 40, 30, "frames/led_03.dng"));
  try {
    CheckRawSize(raw, 1232, 816, "frames/led_03.dng");
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "frames/led_03.dng: image is 40x30 but the session records 1232x816");
  }
}

// ---- colour data ----------------------------------------------------------

Eigen::Matrix3d FromRowMajor(const std::vector<float>& v) {
  Eigen::Matrix3d m;
  for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = v[i];
  return m;
}

const std::vector<float> kMatrixA = {0.9, -0.3, -0.1, -0.5, 1.3, 0.2, -0.1, 0.3, 0.5};
const std::vector<float> kMatrixD65 = {0.8, -0.2, -0.07, -0.49, 1.24, 0.28, -0.1, 0.2, 0.72};

TEST(RawDecoderColorTest, DngWithoutColorMatrixHasNone) {
  const DecodedRaw decoded = DecodeRawWithInfo(MakeTestDng({}), "plain.dng");
  EXPECT_FALSE(decoded.camera_from_xyz.has_value());
  EXPECT_EQ(decoded.camera_from_xyz_illuminant, 0);
  EXPECT_FALSE(decoded.forward_matrix_d50.has_value());
  EXPECT_EQ(decoded.as_shot_neutral, Eigen::Vector3d::Ones());
}

// Real camera DNGs carry illuminant A as matrix 1 and D65 as matrix 2; the D65 one is chosen,
// whichever slot it is in.
TEST(RawDecoderColorTest, DualIlluminantDngGivesTheD65Matrix) {
  TestDngOptions options;
  options.color_matrix1 = kMatrixA;
  options.illuminant1 = 17;  // A
  options.color_matrix2 = kMatrixD65;
  options.illuminant2 = 21;  // D65
  DecodedRaw decoded = DecodeRawWithInfo(MakeTestDng(options), "dual.dng");
  ASSERT_TRUE(decoded.camera_from_xyz.has_value());
  EXPECT_LT((*decoded.camera_from_xyz - FromRowMajor(kMatrixD65)).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_EQ(decoded.camera_from_xyz_illuminant, 21);

  std::swap(options.color_matrix1, options.color_matrix2);
  std::swap(options.illuminant1, options.illuminant2);
  decoded = DecodeRawWithInfo(MakeTestDng(options), "swapped.dng");
  ASSERT_TRUE(decoded.camera_from_xyz.has_value());
  EXPECT_LT((*decoded.camera_from_xyz - FromRowMajor(kMatrixD65)).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_EQ(decoded.camera_from_xyz_illuminant, 21);
}

TEST(RawDecoderColorTest, OnlyAnIlluminantAMatrixIsReportedAsSuch) {
  TestDngOptions options;
  options.color_matrix1 = kMatrixA;
  options.illuminant1 = 17;
  const DecodedRaw decoded = DecodeRawWithInfo(MakeTestDng(options), "tungsten.dng");
  ASSERT_TRUE(decoded.camera_from_xyz.has_value());
  EXPECT_LT((*decoded.camera_from_xyz - FromRowMajor(kMatrixA)).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_EQ(decoded.camera_from_xyz_illuminant, 17);
}

TEST(RawDecoderColorTest, CameraCalibrationMultipliesTheColorMatrix) {
  TestDngOptions options;
  options.color_matrix1 = kMatrixA;
  options.illuminant1 = 17;
  options.color_matrix2 = kMatrixD65;
  options.illuminant2 = 21;
  options.camera_calibration2 = {1.05f, 0, 0, 0, 1, 0, 0, 0, 0.9f};
  options.as_shot_neutral = {0.5f, 1.0f, 0.8f};
  const DecodedRaw decoded = DecodeRawWithInfo(MakeTestDng(options), "calibrated.dng");
  ASSERT_TRUE(decoded.camera_from_xyz.has_value());
  const Eigen::Matrix3d expected = Eigen::Vector3d(1.05, 1.0, 0.9).asDiagonal() * FromRowMajor(kMatrixD65);
  EXPECT_LT((*decoded.camera_from_xyz - expected).cwiseAbs().maxCoeff(), 1e-6) << *decoded.camera_from_xyz;
  EXPECT_LT((decoded.as_shot_neutral - Eigen::Vector3d(0.5, 1.0, 0.8)).cwiseAbs().maxCoeff(), 1e-6)
      << decoded.as_shot_neutral.transpose();
}

// ---- a real camera file -----------------------------------------------------

// A real camera's RAW of a ColorChecker: ../shared/data/raw/colorchart.dng (a
// Canon EOS 550D photo saved as DNG; its README gives source and licence), or
// the file SCANBENCH_REAL_CHART_RAW names (e.g. a NEF of the bench's camera).
// Nothing is vendored (tests/data/raw/README.md).
std::filesystem::path RealChartRaw() {
  const char* given = std::getenv("SCANBENCH_REAL_CHART_RAW");
  if (given != nullptr && *given != '\0') return given;
  return std::filesystem::path(SCANBENCH_SOURCE_DIR) / ".." / "shared" / "data" / "raw" / "colorchart.dng";
}

TEST(RawDecoderRealFileTest, RealCameraRawHasBayerDataAndAColorMatrix) {
  const std::filesystem::path path = RealChartRaw();
  if (!std::filesystem::exists(path)) {
    GTEST_SKIP() << path << " is not there and SCANBENCH_REAL_CHART_RAW is not set: no real camera RAW is "
                    "vendored (see tests/data/raw/README.md)";
  }
  const DecodedRaw decoded = DecodeRawFileWithInfo(path);
  EXPECT_FALSE(decoded.make.empty());
  EXPECT_FALSE(decoded.model.empty());
  EXPECT_GE(decoded.image.width(), 640);
  EXPECT_GE(decoded.image.height(), 480);
  ASSERT_TRUE(decoded.camera_from_xyz.has_value()) << decoded.make << " " << decoded.model;
  // A real sensor answers a white in every channel.
  const Eigen::Vector3d camera_of_d65_white = *decoded.camera_from_xyz * Eigen::Vector3d(0.95047, 1.0, 1.08883);
  EXPECT_TRUE((camera_of_d65_white.array() > 0).all()) << camera_of_d65_white.transpose();
  EXPECT_TRUE(decoded.as_shot_neutral.allFinite());
  EXPECT_TRUE((decoded.as_shot_neutral.array() > 0).all());
  EXPECT_DOUBLE_EQ(decoded.as_shot_neutral[1], 1.0);
  EXPECT_DOUBLE_EQ(decoded.daylight_multipliers[1], 1.0);
}

}  // namespace
}  // namespace scanbench
