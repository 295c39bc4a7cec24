#include "app/io/image_io.h"
#include "app/io/file_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <random>

#include <Imath/half.h>
#include <OpenImageIO/imageio.h>

#include "tests/app/io/test_dng_util.h"

namespace scanbench {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using testing::TempDir;

template <typename T>
Image<T> RandomImage(int width, int height, int channels, uint32_t seed) {
  std::mt19937 rng(seed);
  Image<T> image(width, height, channels);
  for (size_t i = 0; i < image.size(); ++i) {
    if constexpr (std::is_floating_point_v<T>) {
      image.data()[i] = std::uniform_real_distribution<float>(-10.f, 10.f)(rng);
    } else {
      image.data()[i] = static_cast<T>(rng());
    }
  }
  return image;
}

template <typename T>
void ExpectSameImage(const Image<T>& expected, const Image<T>& actual) {
  ASSERT_EQ(actual.width(), expected.width());
  ASSERT_EQ(actual.height(), expected.height());
  ASSERT_EQ(actual.channels(), expected.channels());
  size_t mismatches = 0;
  for (size_t i = 0; i < expected.size(); ++i) {
    // Bitwise for floats: exact storage, not approximate.
    if (std::memcmp(&expected.data()[i], &actual.data()[i], sizeof(T)) != 0 && ++mismatches <= 5) {
      ADD_FAILURE() << "sample " << i << ": " << +actual.data()[i] << " != " << +expected.data()[i];
    }
  }
  EXPECT_EQ(mismatches, 0u);
}

std::string ErrorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "<no error>";
}

TEST(ImageIoTest, ExrFloatRoundTripIsExact) {
  TempDir dir;
  for (int channels : {1, 3, 4}) {
    SCOPED_TRACE(channels);
    ImageF image = RandomImage<float>(37, 21, channels, 10 + channels);
    image(0, 0, 0) = 1e-30f;  // tiny, huge and negative values stay as they are
    image(1, 0, 0) = 3.4e38f;
    image(2, 0, 0) = -0.0f;
    const auto path = dir / ("normals_" + std::to_string(channels) + ".exr");
    WriteExr(path, image, OverwritePolicy::kRefuse);
    ExpectSameImage(image, ReadImageFloat(path));
  }
}

// Rows read band by band are the rows of the whole image, for float and half
// EXR (whose chunks the bands cut through) and PNG.
TEST(ImageIoTest, RowsReadBandByBandEqualTheWholeImage) {
  TempDir dir;
  const ImageF image = RandomImage<float>(23, 71, 3, 5);
  const auto float_path = dir / "float.exr", half_path = dir / "half.exr", png_path = dir / "rows.png";
  WriteExr(float_path, image, OverwritePolicy::kRefuse);
  WriteExr(half_path, image, OverwritePolicy::kRefuse, {}, {}, {ExrSampleType::kHalf, ExrCompression::kPiz});
  WritePng(png_path, RandomImage<uint8_t>(23, 71, 3, 6), OverwritePolicy::kRefuse);
  for (const auto& path : {float_path, half_path, png_path}) {
    SCOPED_TRACE(path.filename().string());
    const ImageF whole = ReadImageFloat(path);
    ImageF banded(whole.width(), whole.height(), whole.channels());
    for (int y0 = 0; y0 < whole.height(); y0 += 20) {
      const int y1 = std::min(whole.height(), y0 + 20);
      const ImageF rows = ReadImageFloatRows(path, y0, y1);
      ASSERT_EQ(rows.height(), y1 - y0);
      std::copy(rows.data(), rows.data() + rows.size(), banded.row(y0));
    }
    ExpectSameImage(whole, banded);
    // The same through one opened reader (for an EXR the OpenEXR core
    // library's), its buffer reused from band to band.
    ImageRowReader reader(path);
    ASSERT_EQ(reader.width(), whole.width());
    ASSERT_EQ(reader.height(), whole.height());
    ASSERT_EQ(reader.channels(), whole.channels());
    ImageF read_rows(1, 1, 1), by_reader(whole.width(), whole.height(), whole.channels());
    for (int y0 = 0; y0 < whole.height(); y0 += 20) {
      const int y1 = std::min(whole.height(), y0 + 20);
      reader.ReadRows(y0, y1, &read_rows);
      ASSERT_EQ(read_rows.height(), y1 - y0);
      std::copy(read_rows.data(), read_rows.data() + read_rows.size(), by_reader.row(y0));
    }
    ExpectSameImage(whole, by_reader);
    EXPECT_THAT(ErrorOf([&] { reader.ReadRows(60, 72, &read_rows); }), HasSubstr("must lie within its 71 rows"));
  }
  // Uncompressed float, as the simulator writes the ground truth.
  const auto raw_path = dir / "raw.exr";
  WriteExr(raw_path, image, OverwritePolicy::kRefuse, {}, {}, {ExrSampleType::kFloat32, ExrCompression::kNone});
  ImageRowReader reader(raw_path);
  ImageF read_rows, by_reader(image.width(), image.height(), image.channels());
  for (int y0 = 0; y0 < image.height(); y0 += 16) {
    const int y1 = std::min(image.height(), y0 + 16);
    reader.ReadRows(y0, y1, &read_rows);
    std::copy(read_rows.data(), read_rows.data() + read_rows.size(), by_reader.row(y0));
  }
  ExpectSameImage(image, by_reader);
  EXPECT_THAT(ErrorOf([&] { ReadImageFloatRows(float_path, 60, 72); }), HasSubstr("must lie within its 71 rows"));
  EXPECT_THAT(ErrorOf([&] { ReadImageFloatRows(float_path, 5, 5); }), HasSubstr("not be empty"));
}

// Half float: read back as float within half a mantissa step (2^-12 of the
// octave, so at most |v| 2^-11), identical under every lossless compression,
// reported as 16-bit float; values beyond half's range are clamped to 65504,
// never an infinity.
TEST(ImageIoTest, ExrHalfRoundTripIsWithinHalfPrecisionUnderEveryCompression) {
  TempDir dir;
  ImageF image = RandomImage<float>(61, 33, 3, 7);
  image(0, 0, 0) = 1e6f;
  image(1, 0, 0) = -1e9f;
  image(2, 0, 0) = 65504.0f;
  image(3, 0, 0) = 0.0f;
  image(4, 0, 0) = 10.0f;  // exactly representable
  std::optional<ImageF> first;
  for (ExrCompression compression : {ExrCompression::kNone, ExrCompression::kRle, ExrCompression::kZips,
                                     ExrCompression::kZip, ExrCompression::kPiz, ExrCompression::kPxr24}) {
    SCOPED_TRACE(ExrCompressionName(compression));
    const auto path = dir / (std::string("half_") + ExrCompressionName(compression) + ".exr");
    WriteExr(path, image, OverwritePolicy::kRefuse, {}, {}, {ExrSampleType::kHalf, compression});
    const ImageFileInfo info = ReadImageFileInfo(path);
    EXPECT_TRUE(info.is_float);
    EXPECT_EQ(info.bits_per_sample, 16);
    EXPECT_EQ(info.compression, ExrCompressionName(compression));
    const ImageF read = ReadImageFloat(path);
    ASSERT_EQ(read.size(), image.size());
    EXPECT_EQ(read(0, 0, 0), 65504.0f);
    EXPECT_EQ(read(1, 0, 0), -65504.0f);
    EXPECT_EQ(read(2, 0, 0), 65504.0f);
    EXPECT_EQ(read(3, 0, 0), 0.0f);
    EXPECT_EQ(read(4, 0, 0), 10.0f);
    for (size_t i = 0; i < image.size(); ++i) {
      if (i < 15 && i % 3 == 0) continue;  // the special values above
      ASSERT_TRUE(std::isfinite(read.data()[i])) << i;
      ASSERT_LE(std::abs(read.data()[i] - image.data()[i]), std::abs(image.data()[i]) / 2048 + 1e-7f) << i;
    }
    if (!first) {
      first = read;
    } else {
      ExpectSameImage(*first, read);  // lossless: the same halves whatever the compression
    }
  }
}

TEST(ImageIoTest, ExrHalfKeepsChannelNamesAndMetadata) {
  TempDir dir;
  ImageMetadata metadata;
  metadata.mm_per_pixel = 0.05;
  metadata.color_space = "Linear";
  metadata.attributes["scanbench:kind"] = "confidence";
  WriteExr(dir / "c.exr", RandomImage<float>(8, 8, 3, 4), OverwritePolicy::kRefuse,
           {"lights_used", "condition_number", "residual"}, metadata, {ExrSampleType::kHalf, ExrCompression::kPiz});
  std::vector<std::string> names;
  ReadImageFloat(dir / "c.exr", &names);
  EXPECT_THAT(names, ::testing::UnorderedElementsAre("lights_used", "condition_number", "residual"));
  const ImageMetadata read = ReadImageMetadata(dir / "c.exr");
  EXPECT_EQ(read.mm_per_pixel, 0.05);
  EXPECT_EQ(read.color_space, "Linear");
  EXPECT_EQ(read.attributes.at("scanbench:kind"), "confidence");
}

TEST(ImageIoTest, ExrPxr24IsRefusedForFloat32) {
  TempDir dir;
  EXPECT_THAT(ErrorOf([&] {
                WriteExr(dir / "lossy.exr", RandomImage<float>(4, 4, 1, 1), OverwritePolicy::kRefuse, {}, {},
                         {ExrSampleType::kFloat32, ExrCompression::kPxr24});
              }),
              HasSubstr("lossy.exr: ExrEncoding.compression = pxr24 is lossy on float32 samples"));
  EXPECT_FALSE(std::filesystem::exists(dir / "lossy.exr"));
}

// half_absolute_step 2^-12: values below 1024 steps (0.25) land on the grid
// (within step / 2), larger ones are half's own rounding; the file holds no
// more distinct small values than the grid has.
TEST(ImageIoTest, ExrHalfAbsoluteStepRoundsSmallValuesToTheGrid) {
  TempDir dir;
  const double step = std::ldexp(1.0, -12);
  ImageF image = RandomImage<float>(64, 32, 3, 12);
  for (size_t i = 0; i < image.size(); ++i) image.data()[i] /= 10.0f;  // [-1, 1]
  image.data()[0] = 70000.0f;                                         // clamped, as without a step
  WriteExr(dir / "q.exr", image, OverwritePolicy::kRefuse, {}, {},
           {ExrSampleType::kHalf, ExrCompression::kZips, step});
  const ImageF read = ReadImageFloat(dir / "q.exr");
  EXPECT_EQ(read.data()[0], 65504.0f);
  size_t small = 0;
  for (size_t i = 1; i < image.size(); ++i) {
    const double v = image.data()[i], r = read.data()[i];
    if (std::abs(v) < 0.25) {
      ++small;
      EXPECT_LE(std::abs(r - v), step / 2 + 1e-9) << i;
      EXPECT_EQ(std::fmod(r, step), 0.0) << i;
    } else {
      EXPECT_LE(std::abs(r - v), std::abs(v) / 2048 + 1e-9) << i;  // half's own rounding
    }
  }
  EXPECT_GT(small, 1000u);

  for (double bad : {3.0 * step, -step, 2.0, std::ldexp(1.0, -25)}) {
    EXPECT_THAT(ErrorOf([&] {
                  WriteExr(dir / "bad.exr", image, OverwritePolicy::kRefuse, {}, {},
                           {ExrSampleType::kHalf, ExrCompression::kZips, bad});
                }),
                HasSubstr("ExrEncoding.half_absolute_step"));
  }
  EXPECT_THAT(ErrorOf([&] {
                WriteExr(dir / "bad.exr", image, OverwritePolicy::kRefuse, {}, {},
                         {ExrSampleType::kFloat32, ExrCompression::kZip, step});
              }),
              HasSubstr("with half samples"));
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.exr"));
}

TEST(ImageIoTest, ExrKeepsChannelNames) {
  TempDir dir;
  const ImageF image = RandomImage<float>(8, 8, 3, 3);
  WriteExr(dir / "n.exr", image, OverwritePolicy::kRefuse, {"N.x", "N.y", "N.z"});
  std::vector<std::string> names;
  ExpectSameImage(image, ReadImageFloat(dir / "n.exr", &names));
  EXPECT_THAT(names, ElementsAre("N.x", "N.y", "N.z"));

  std::vector<std::string> default_names;
  WriteExr(dir / "gray.exr", RandomImage<float>(4, 4, 1, 1), OverwritePolicy::kRefuse);
  ReadImageFloat(dir / "gray.exr", &default_names);
  EXPECT_THAT(default_names, ElementsAre("Y"));

  EXPECT_THAT(ErrorOf([&] { WriteExr(dir / "bad.exr", image, OverwritePolicy::kRefuse, {"R", "G"}); }),
              HasSubstr("2 channel names given for an image with 3 channels"));
}

TEST(ImageIoTest, Png16RoundTripIsExact) {
  TempDir dir;
  for (int channels : {1, 2, 3, 4}) {
    SCOPED_TRACE(channels);
    ImageU16 image = RandomImage<uint16_t>(33, 17, channels, 20 + channels);
    image(0, 0, 0) = 0;
    image(1, 0, 0) = 65535;
    if (channels == 4) image(2, 0, 3) = 0;  // colour under zero alpha survives
    const auto path = dir / ("mask_" + std::to_string(channels) + ".png");
    WritePng(path, image, OverwritePolicy::kRefuse);
    ExpectSameImage(image, ReadImageU16(path));
  }
}

// Every zlib level and row filter is lossless; a bad level is refused.
TEST(ImageIoTest, PngEncodingsRoundTripExactly) {
  TempDir dir;
  const ImageU16 image = RandomImage<uint16_t>(41, 13, 3, 77);
  for (PngFilter filter : {PngFilter::kAdaptive, PngFilter::kNone, PngFilter::kSub, PngFilter::kUp,
                           PngFilter::kAverage, PngFilter::kPaeth}) {
    for (int level : {0, 1, 9}) {
      SCOPED_TRACE(std::string(PngFilterName(filter)) + " " + std::to_string(level));
      const auto path = dir / (std::string(PngFilterName(filter)) + std::to_string(level) + ".png");
      WritePng(path, image, OverwritePolicy::kRefuse, {}, {level, filter});
      ExpectSameImage(image, ReadImageU16(path));
    }
  }
  EXPECT_THAT(ErrorOf([&] { WritePng(dir / "bad.png", image, OverwritePolicy::kRefuse, {}, {10}); }),
              HasSubstr("PngEncoding.zlib_level = 10 must be in [0, 9]"));
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.png"));
}

// Every zlib strategy is lossless and reaches libpng: on a smooth image,
// Huffman coding alone (no matches) and run-length matches only give files of
// other sizes than the default's string matching.
TEST(ImageIoTest, PngStrategiesRoundTripExactlyAndTakeEffect) {
  TempDir dir;
  ImageU16 image(96, 64, 3);
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      for (int c = 0; c < 3; ++c) image(x, y, c) = static_cast<uint16_t>(300 * x + 700 * y + 5000 * c + (x * y) % 7);
    }
  }
  std::map<PngStrategy, uintmax_t> bytes;
  for (PngStrategy strategy : {PngStrategy::kDefault, PngStrategy::kFiltered, PngStrategy::kHuffmanOnly,
                               PngStrategy::kRle, PngStrategy::kFixed}) {
    for (PngFilter filter : {PngFilter::kAdaptive, PngFilter::kUp}) {
      SCOPED_TRACE(std::string(PngStrategyName(strategy)) + " " + PngFilterName(filter));
      const auto path = dir / (std::string(PngStrategyName(strategy)) + PngFilterName(filter) + ".png");
      PngEncoding encoding{1, filter};
      encoding.strategy = strategy;
      WritePng(path, image, OverwritePolicy::kRefuse, {}, encoding);
      ExpectSameImage(image, ReadImageU16(path));
      if (filter == PngFilter::kUp) bytes[strategy] = std::filesystem::file_size(path);
    }
  }
  EXPECT_GT(bytes[PngStrategy::kHuffmanOnly], bytes[PngStrategy::kDefault]);
  EXPECT_NE(bytes[PngStrategy::kRle], bytes[PngStrategy::kDefault]);
  EXPECT_NE(bytes[PngStrategy::kFixed], bytes[PngStrategy::kDefault]);
}

// WritePngRows: every filter, level, channel count and depth reads back
// exactly, over several bands of rows, and the file is WritePng's of the
// same pixels, metadata and encoding, byte for byte.
TEST(ImageIoTest, PngRowsRoundTripExactlyWithWritePngsMetadata) {
  TempDir dir;
  ImageMetadata metadata;
  metadata.mm_per_pixel = 0.029;
  metadata.description = "scanbench normal map";
  metadata.color_space = "sRGB";
  metadata.attributes["scanbench:map"] = "normal";
  for (int channels : {1, 2, 3, 4}) {
    const ImageU16 image16 = RandomImage<uint16_t>(37, 141, channels, 50 + channels);  // 141 rows: 3 bands
    const ImageU8 image8 = RandomImage<uint8_t>(37, 141, channels, 60 + channels);
    const PngRowSource rows16{image16.width(), image16.height(), channels, 16, [&](int y, void* row) {
                                std::memcpy(row, image16.row(y), 37 * channels * sizeof(uint16_t));
                              }};
    const PngRowSource rows8{image8.width(), image8.height(), channels, 8,
                             [&](int y, void* row) { std::memcpy(row, image8.row(y), 37 * channels); }};
    for (PngFilter filter : {PngFilter::kAdaptive, PngFilter::kNone, PngFilter::kSub, PngFilter::kUp,
                             PngFilter::kAverage, PngFilter::kPaeth}) {
      for (int level : {0, 1, 9}) {
        const std::string name = std::to_string(channels) + PngFilterName(filter) + std::to_string(level);
        SCOPED_TRACE(name);
        WritePngRows(dir / (name + "_16.png"), rows16, OverwritePolicy::kRefuse, metadata, {level, filter});
        WritePngRows(dir / (name + "_8.png"), rows8, OverwritePolicy::kRefuse, metadata, {level, filter});
        ExpectSameImage(image16, ReadImageU16(dir / (name + "_16.png")));
        ExpectSameImage(image8, ReadImageU8(dir / (name + "_8.png")));
      }
    }
    WritePng(dir / (std::to_string(channels) + "_reference.png"), image16, OverwritePolicy::kRefuse, metadata);
    const ImageFileInfo reference = ReadImageFileInfo(dir / (std::to_string(channels) + "_reference.png"));
    const ImageFileInfo rows = ReadImageFileInfo(dir / (std::to_string(channels) + "adaptive1_16.png"));
    EXPECT_EQ(ReadFileBytes(dir / (std::to_string(channels) + "adaptive1_16.png")),
              ReadFileBytes(dir / (std::to_string(channels) + "_reference.png")));
    EXPECT_EQ(rows.width, reference.width);
    EXPECT_EQ(rows.height, reference.height);
    EXPECT_EQ(rows.channels, reference.channels);
    EXPECT_EQ(rows.bits_per_sample, 16);
    EXPECT_EQ(rows.channel_names, reference.channel_names);
    EXPECT_EQ(rows.resolution_mm_per_pixel, reference.resolution_mm_per_pixel);
    EXPECT_EQ(rows.metadata.mm_per_pixel, reference.metadata.mm_per_pixel);
    EXPECT_EQ(rows.metadata.description, reference.metadata.description);
    EXPECT_EQ(rows.metadata.color_space, reference.metadata.color_space);
    EXPECT_EQ(rows.metadata.attributes, reference.metadata.attributes);
  }
  const PngRowSource bad{4, 4, 5, 16, [](int, void*) {}};
  EXPECT_THAT(ErrorOf([&] { WritePngRows(dir / "bad.png", bad, OverwritePolicy::kRefuse); }),
              HasSubstr("4x4x5 16-bit PNG"));
  const PngRowSource ok{4, 4, 1, 8, [](int, void* row) { std::memset(row, 7, 4); }};
  EXPECT_THAT(ErrorOf([&] { WritePngRows(dir / "bad.png", ok, OverwritePolicy::kRefuse, {}, {10}); }),
              HasSubstr("PngEncoding.zlib_level = 10 must be in [0, 9]"));
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.png"));
  WritePngRows(dir / "ok.png", ok, OverwritePolicy::kRefuse);
  EXPECT_THAT(ErrorOf([&] { WritePngRows(dir / "ok.png", ok, OverwritePolicy::kRefuse); }),
              HasSubstr("already exists"));
}

// A file's bytes with an EXR header's capDate (the second it was written,
// OpenImageIO's DateTime) blanked, so that writes a second apart compare equal.
std::vector<uint8_t> BytesWithoutCapDate(const std::filesystem::path& path) {
  std::vector<uint8_t> bytes = ReadFileBytes(path);
  const std::string attribute("capDate\0string\0", 15);
  const auto at = std::search(bytes.begin(), bytes.end(), attribute.begin(), attribute.end());
  if (at != bytes.end() && at + 19 <= bytes.end()) {
    uint32_t length = 0;
    std::memcpy(&length, &*(at + 15), 4);  // little-endian, as OpenEXR stores it
    if (at + 19 + length <= bytes.end()) std::fill_n(at + 19, length, uint8_t{0});
  }
  return bytes;
}

// Rows [first, first + count) of an image.
template <typename T>
Image<T> RowsOf(const Image<T>& image, int first, int count) {
  Image<T> rows(image.width(), count, image.channels());
  std::copy(image.row(first), image.row(first) + rows.size(), rows.data());
  return rows;
}

template <typename T>
void WriteInBands(ImageRowWriter& writer, const Image<T>& image, int band_rows) {
  for (int y = 0; y < image.height(); y += band_rows) {
    writer.WriteRows(RowsOf(image, y, std::min(band_rows, image.height() - y)));
  }
  writer.Commit();
}

// Band by band, whatever the band height (1 row, bands that do not divide
// the height, OpenEXR's 32-row piz chunks split), the file of the whole-image
// writer, byte for byte (but for the EXR's capDate).
TEST(ImageIoTest, RowWriterWritesTheWholeImageWritersFiles) {
  TempDir dir;
  ImageMetadata metadata;
  metadata.mm_per_pixel = 0.029;
  metadata.description = "scanbench map";
  metadata.attributes["scanbench:map"] = "test";
  ImageF image = RandomImage<float>(53, 101, 3, 91);
  for (int i = 0; i < 200; ++i) image.data()[i * 7] *= 1e-3f;  // some small values for the half grid
  const std::vector<ExrEncoding> encodings = {{ExrSampleType::kFloat32, ExrCompression::kZip},
                                              {ExrSampleType::kHalf, ExrCompression::kPiz},
                                              {ExrSampleType::kHalf, ExrCompression::kPiz, 1.0 / 4096},
                                              {ExrSampleType::kHalf, ExrCompression::kZip}};
  const ImageU16 image16 = RandomImage<uint16_t>(53, 101, 3, 92);
  const ImageU8 image8 = RandomImage<uint8_t>(53, 101, 1, 93);
  for (size_t e = 0; e < encodings.size(); ++e) {
    const std::string whole = "whole" + std::to_string(e) + ".exr";
    WriteExr(dir / whole, image, OverwritePolicy::kRefuse, {"x", "y", "z"}, metadata, encodings[e]);
    for (int band_rows : {1, 7, 32, 64, 101}) {
      SCOPED_TRACE("encoding " + std::to_string(e) + ", bands of " + std::to_string(band_rows));
      const std::string name = "rows" + std::to_string(e) + "_" + std::to_string(band_rows) + ".exr";
      ImageRowWriter writer = ImageRowWriter::Exr(dir / name, 53, 101, 3, OverwritePolicy::kRefuse, {"x", "y", "z"},
                                                  metadata, encodings[e]);
      WriteInBands(writer, image, band_rows);
      EXPECT_EQ(BytesWithoutCapDate(dir / name), BytesWithoutCapDate(dir / whole));
    }
  }
  WritePng(dir / "whole16.png", image16, OverwritePolicy::kRefuse, metadata, {1, PngFilter::kPaeth});
  WritePng(dir / "whole8.png", image8, OverwritePolicy::kRefuse);
  for (int band_rows : {1, 7, 64, 101}) {
    SCOPED_TRACE("PNG bands of " + std::to_string(band_rows));
    const std::string suffix = std::to_string(band_rows) + ".png";
    ImageRowWriter png16 = ImageRowWriter::Png(dir / ("rows16_" + suffix), 53, 101, 3, 16, OverwritePolicy::kRefuse,
                                               metadata, {1, PngFilter::kPaeth});
    WriteInBands(png16, image16, band_rows);
    EXPECT_EQ(ReadFileBytes(dir / ("rows16_" + suffix)), ReadFileBytes(dir / "whole16.png"));
    ImageRowWriter png8 = ImageRowWriter::Png(dir / ("rows8_" + suffix), 53, 101, 1, 8, OverwritePolicy::kRefuse);
    WriteInBands(png8, image8, band_rows);
    EXPECT_EQ(ReadFileBytes(dir / ("rows8_" + suffix)), ReadFileBytes(dir / "whole8.png"));
  }
}

// Nothing appears under the name, and no temporary file is left, unless every
// row was written and the writer committed; rows that do not fit are refused.
TEST(ImageIoTest, RowWriterLeavesNoFileUncommitted) {
  TempDir dir;
  const ImageF image = RandomImage<float>(16, 40, 1, 94);
  const auto files_in = [&] {
    size_t count = 0;
    for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path())) ++count;
    return count;
  };
  {
    ImageRowWriter writer = ImageRowWriter::Exr(dir / "partial.exr", 16, 40, 1, OverwritePolicy::kRefuse);
    writer.WriteRows(RowsOf(image, 0, 16));
    EXPECT_EQ(files_in(), 1u);  // the temporary file
    EXPECT_FALSE(std::filesystem::exists(dir / "partial.exr"));
    EXPECT_THAT(ErrorOf([&] { writer.Commit(); }), HasSubstr("16 of its 40 rows"));
    EXPECT_THAT(ErrorOf([&] { writer.WriteRows(RowsOf(image, 0, 30)); }), HasSubstr("16 rows written"));
    EXPECT_THAT(ErrorOf([&] { writer.WriteRows(ImageU8(16, 4, 1)); }), HasSubstr("uint8 rows"));
  }
  EXPECT_EQ(files_in(), 0u);
  {
    ImageRowWriter writer = ImageRowWriter::Png(dir / "never.png", 16, 40, 1, 8, OverwritePolicy::kRefuse);
  }
  EXPECT_EQ(files_in(), 0u);
  ImageRowWriter done = ImageRowWriter::Exr(dir / "done.exr", 16, 40, 1, OverwritePolicy::kRefuse);
  done.WriteRows(image);
  done.Commit();
  EXPECT_EQ(files_in(), 1u);
  ExpectSameImage(image, ReadImageFloat(dir / "done.exr"));
  EXPECT_THAT(ErrorOf([&] { ImageRowWriter::Exr(dir / "done.exr", 16, 40, 1, OverwritePolicy::kRefuse); }),
              HasSubstr("already exists"));
  EXPECT_THAT(ErrorOf([&] { ImageRowWriter::Png(dir / "bad.png", 16, 40, 5, 8, OverwritePolicy::kRefuse); }),
              HasSubstr("16x40x5 8-bit PNG"));
  EXPECT_EQ(files_in(), 1u);
}

TEST(ImageIoTest, Png8RoundTripIsExact) {
  TempDir dir;
  for (int channels : {1, 3, 4}) {
    SCOPED_TRACE(channels);
    ImageU8 image = RandomImage<uint8_t>(19, 23, channels, 30 + channels);
    if (channels == 4) image(0, 0, 3) = 0;
    const auto path = dir / ("preview_" + std::to_string(channels) + ".png");
    WritePng(path, image, OverwritePolicy::kRefuse);
    ExpectSameImage(image, ReadImageU8(path));
  }
}

TEST(ImageIoTest, IntegerFilesReadAsNormalisedFloat) {
  TempDir dir;
  ImageU16 image(3, 1, 1);
  image(0, 0) = 0;
  image(1, 0) = 65535;
  image(2, 0) = 32768;
  WritePng(dir / "a.png", image, OverwritePolicy::kRefuse);
  const ImageF read = ReadImageFloat(dir / "a.png");
  EXPECT_EQ(read(0, 0), 0.0f);
  EXPECT_EQ(read(1, 0), 1.0f);
  EXPECT_NEAR(read(2, 0), 32768.0f / 65535.0f, 1e-6f);

  ImageU8 small(2, 1, 1);
  small(0, 0) = 255;
  small(1, 0) = 1;
  WritePng(dir / "b.png", small, OverwritePolicy::kRefuse);
  const ImageU16 widened = ReadImageU16(dir / "b.png");
  EXPECT_EQ(widened(0, 0), 65535);
  EXPECT_EQ(widened(1, 0), 257);
}

TEST(ImageIoTest, TiffRoundTripIsExact) {
  TempDir dir;
  const ImageU16 image16 = RandomImage<uint16_t>(41, 29, 3, 40);
  WriteTiff(dir / "frame16.tif", image16, OverwritePolicy::kRefuse);
  ExpectSameImage(image16, ReadImageU16(dir / "frame16.tif"));

  const ImageF image32 = RandomImage<float>(41, 29, 1, 41);
  WriteTiff(dir / "albedo.tiff", image32, OverwritePolicy::kRefuse);
  ExpectSameImage(image32, ReadImageFloat(dir / "albedo.tiff"));
}

TEST(ImageIoTest, RefuseAndReplacePolicies) {
  TempDir dir;
  const auto path = dir / "out.png";
  ImageU8 first(4, 4, 1, 10);
  ImageU8 second(4, 4, 1, 20);
  WritePng(path, first, OverwritePolicy::kRefuse);
  const std::string error = ErrorOf([&] { WritePng(path, second, OverwritePolicy::kRefuse); });
  EXPECT_THAT(error, HasSubstr(path.string()));
  EXPECT_THAT(error, HasSubstr("already exists"));
  EXPECT_EQ(ReadImageU8(path)(0, 0), 10);
  WritePng(path, second, OverwritePolicy::kReplace);
  EXPECT_EQ(ReadImageU8(path)(0, 0), 20);
  EXPECT_THAT(dir.List(), ElementsAre("out.png"));
}

TEST(ImageIoTest, UnreadableFileErrorNamesThePath) {
  TempDir dir;
  const auto garbage = dir / "broken.png";
  WriteFileAtomic(garbage, std::string_view("not an image at all"), OverwritePolicy::kRefuse);
  const std::string error = ErrorOf([&] { ReadImageFloat(garbage); });
  EXPECT_THAT(error, HasSubstr(garbage.string() + ": "));
  EXPECT_THAT(error, HasSubstr("cannot be read as an image"));

  const auto missing = dir / "missing.exr";
  EXPECT_EQ(ErrorOf([&] { ReadImageU16(missing); }), missing.string() + ": does not exist");
}

TEST(ImageIoTest, ReadersRejectLossyConversions) {
  TempDir dir;
  WriteExr(dir / "f.exr", RandomImage<float>(4, 4, 1, 5), OverwritePolicy::kRefuse);
  EXPECT_THAT(ErrorOf([&] { ReadImageU16(dir / "f.exr"); }), HasSubstr("holds float samples"));
  WritePng(dir / "deep.png", ImageU16(4, 4, 1, 7), OverwritePolicy::kRefuse);
  EXPECT_THAT(ErrorOf([&] { ReadImageU8(dir / "deep.png"); }), HasSubstr("holds uint16 samples"));
}

TEST(ImageIoTest, InvalidImagesAreRejectedBeforeWriting) {
  TempDir dir;
  EXPECT_THAT(ErrorOf([&] { WriteExr(dir / "e.exr", ImageF(), OverwritePolicy::kRefuse); }),
              HasSubstr("cannot write an empty"));
  EXPECT_THAT(ErrorOf([&] { WritePng(dir / "five.png", ImageU8(2, 2, 5), OverwritePolicy::kRefuse); }),
              HasSubstr("PNG holds at most 4 channels, the image has 5"));
  EXPECT_TRUE(dir.List().empty());
}

TEST(ImageIoTest, WriteIntoMissingFolderFailsCleanly) {
  TempDir dir;
  const std::string error =
      ErrorOf([&] { WriteExr(dir / "nope" / "x.exr", ImageF(2, 2, 1), OverwritePolicy::kReplace); });
  EXPECT_THAT(error, HasSubstr("x.exr"));
  EXPECT_TRUE(dir.List().empty());
}

// Physical scale and meaning travel inside the file: read back through
// OpenImageIO for each format the export writes.
TEST(ImageIoTest, MetadataRoundTripsInExrPngAndTiff) {
  TempDir dir;
  ImageMetadata metadata;
  metadata.mm_per_pixel = 0.116218;  // the demo rig's scale
  metadata.description = "scanbench height map, mm";
  metadata.color_space = "Raw";
  metadata.attributes["scanbench:normal_convention"] = "directx";
  metadata.attributes["scanbench:value_encoding"] = "(n + 1) / 2";
  const ImageU16 image16 = RandomImage<uint16_t>(9, 5, 3, 41);
  const ImageF image_float = RandomImage<float>(9, 5, 1, 42);
  WriteExr(dir / "m.exr", image_float, OverwritePolicy::kRefuse, {}, metadata);
  WritePng(dir / "m.png", image16, OverwritePolicy::kRefuse, metadata);
  WriteTiff(dir / "m.tif", image16, OverwritePolicy::kRefuse, metadata);
  WriteTiff(dir / "m_float.tif", image_float, OverwritePolicy::kRefuse, metadata);
  for (const char* name : {"m.exr", "m.png", "m.tif", "m_float.tif"}) {
    SCOPED_TRACE(name);
    const ImageFileInfo info = ReadImageFileInfo(dir / name);
    EXPECT_EQ(info.width, 9);
    EXPECT_EQ(info.height, 5);
    EXPECT_DOUBLE_EQ(info.metadata.mm_per_pixel, 0.116218) << "full precision from scanbench:mm_per_pixel";
    // The standard resolution tags alone, as other tools read them: PNG
    // rounds to whole pixels per metre (8605 px/m), the others are floats.
    EXPECT_NEAR(info.resolution_mm_per_pixel, 0.116218, 0.116218 * 1e-4);
    EXPECT_EQ(info.metadata.description, "scanbench height map, mm");
    EXPECT_EQ(info.metadata.color_space, "Raw");
    EXPECT_THAT(info.metadata.attributes,
                ElementsAre(std::pair<const std::string, std::string>("scanbench:normal_convention", "directx"),
                            std::pair<const std::string, std::string>("scanbench:value_encoding", "(n + 1) / 2")));
  }
  EXPECT_EQ(ReadImageFileInfo(dir / "m.png").bits_per_sample, 16);
  EXPECT_FALSE(ReadImageFileInfo(dir / "m.tif").is_float);
  EXPECT_TRUE(ReadImageFileInfo(dir / "m_float.tif").is_float);
  EXPECT_EQ(ReadImageFileInfo(dir / "m.exr").bits_per_sample, 32);
  // Pixels are unchanged by the metadata.
  ExpectSameImage(image16, ReadImageU16(dir / "m.png"));
  ExpectSameImage(image16, ReadImageU16(dir / "m.tif"));
  ExpectSameImage(image_float, ReadImageFloat(dir / "m.exr"));
}

TEST(ImageIoTest, FilesWithoutMetadataReportNone) {
  TempDir dir;
  WritePng(dir / "plain.png", ImageU8(3, 2, 1, 7), OverwritePolicy::kRefuse);
  const ImageFileInfo info = ReadImageFileInfo(dir / "plain.png");
  EXPECT_EQ(info.metadata.mm_per_pixel, 0);
  EXPECT_EQ(info.resolution_mm_per_pixel, 0);
  EXPECT_TRUE(info.metadata.attributes.empty());
  EXPECT_EQ(info.bits_per_sample, 8);
  EXPECT_EQ(info.channels, 1);
}

TEST(ImageIoTest, BadMetadataIsRejectedBeforeWriting) {
  TempDir dir;
  ImageMetadata negative;
  negative.mm_per_pixel = -0.1;
  EXPECT_THAT(ErrorOf([&] { WritePng(dir / "n.png", ImageU8(2, 2, 1), OverwritePolicy::kRefuse, negative); }),
              HasSubstr("ImageMetadata.mm_per_pixel = -0.1 must be finite and >= 0"));
  ImageMetadata bad_name;
  bad_name.attributes["Software"] = "x";
  EXPECT_THAT(ErrorOf([&] { WriteTiff(dir / "b.tif", ImageU16(2, 2, 1), OverwritePolicy::kRefuse, bad_name); }),
              HasSubstr("'Software' must be scanbench:"));
  EXPECT_TRUE(dir.List().empty());
}

// ---- chromaticities ---------------------------------------------------------

ImageChromaticities Rec709() { return {0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290}; }
ImageChromaticities Acescg() { return {0.713, 0.293, 0.165, 0.830, 0.128, 0.044, 0.32168, 0.33767}; }

void ExpectSameChromaticities(const std::optional<ImageChromaticities>& actual, const ImageChromaticities& expected,
                              double tolerance) {
  ASSERT_TRUE(actual.has_value());
  EXPECT_NEAR(actual->red_x, expected.red_x, tolerance);
  EXPECT_NEAR(actual->red_y, expected.red_y, tolerance);
  EXPECT_NEAR(actual->green_x, expected.green_x, tolerance);
  EXPECT_NEAR(actual->green_y, expected.green_y, tolerance);
  EXPECT_NEAR(actual->blue_x, expected.blue_x, tolerance);
  EXPECT_NEAR(actual->blue_y, expected.blue_y, tolerance);
  EXPECT_NEAR(actual->white_x, expected.white_x, tolerance);
  EXPECT_NEAR(actual->white_y, expected.white_y, tolerance);
}

TEST(ImageIoChromaticitiesTest, RoundTripInExrPngAndTiff) {
  TempDir dir;
  ImageMetadata metadata;
  metadata.color_space = "Linear";
  metadata.chromaticities = Acescg();
  WriteExr(dir / "a.exr", RandomImage<float>(9, 7, 3, 1), OverwritePolicy::kRefuse, {}, metadata);
  WritePng(dir / "a.png", RandomImage<uint16_t>(9, 7, 3, 2), OverwritePolicy::kRefuse, metadata);
  WriteTiff(dir / "a.tif", RandomImage<float>(9, 7, 3, 3), OverwritePolicy::kRefuse, metadata);
  for (const char* name : {"a.exr", "a.png", "a.tif"}) {
    SCOPED_TRACE(name);
    const ImageMetadata read = ReadImageMetadata(dir / name);
    ExpectSameChromaticities(read.chromaticities, Acescg(), 0);
    EXPECT_EQ(read.color_space, "Linear");
    EXPECT_EQ(read.attributes.count("scanbench:chromaticities"), 0u);  // consumed, not left as a string
  }
}

// Other programs (OpenEXR viewers, Nuke, OCIO) read the standard attribute, so it must be there
// on its own; a file carrying only it (not written by scanbench) reads back too.
TEST(ImageIoChromaticitiesTest, ExrCarriesTheStandardAttribute) {
  TempDir dir;
  ImageMetadata metadata;
  metadata.chromaticities = Rec709();
  WriteExr(dir / "rec709.exr", RandomImage<float>(5, 4, 3, 4), OverwritePolicy::kRefuse, {}, metadata);
  std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open((dir / "rec709.exr").string());
  ASSERT_TRUE(input);
  const OIIO::ParamValue* standard = input->spec().find_attribute("chromaticities");
  ASSERT_NE(standard, nullptr);
  ASSERT_EQ(standard->type().basevalues(), 8u);
  const float* values = static_cast<const float*>(standard->data());
  EXPECT_FLOAT_EQ(values[0], 0.64f);
  EXPECT_FLOAT_EQ(values[3], 0.60f);
  EXPECT_FLOAT_EQ(values[7], 0.3290f);
  input->close();

  OIIO::ImageSpec spec(5, 4, 3, OIIO::TypeDesc::FLOAT);
  const float acescg[8] = {0.713f, 0.293f, 0.165f, 0.830f, 0.128f, 0.044f, 0.32168f, 0.33767f};
  spec.attribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), acescg);
  const std::vector<float> pixels(5 * 4 * 3, 0.5f);
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create("openexr");
  ASSERT_TRUE(out && out->open((dir / "foreign.exr").string(), spec));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()));
  out->close();
  ExpectSameChromaticities(ReadImageMetadata(dir / "foreign.exr").chromaticities, Acescg(), 1e-7);
}

TEST(ImageIoChromaticitiesTest, AbsentUnlessGiven) {
  TempDir dir;
  WriteExr(dir / "plain.exr", RandomImage<float>(5, 4, 3, 5), OverwritePolicy::kRefuse);
  WritePng(dir / "plain.png", RandomImage<uint8_t>(5, 4, 3, 6), OverwritePolicy::kRefuse);
  EXPECT_FALSE(ReadImageMetadata(dir / "plain.exr").chromaticities.has_value());
  EXPECT_FALSE(ReadImageMetadata(dir / "plain.png").chromaticities.has_value());
}

TEST(ImageIoChromaticitiesTest, InvalidChromaticitiesAreRejectedBeforeWriting) {
  TempDir dir;
  ImageMetadata nan_metadata;
  nan_metadata.chromaticities = Rec709();
  nan_metadata.chromaticities->green_y = std::numeric_limits<double>::quiet_NaN();
  try {
    WriteExr(dir / "nan.exr", RandomImage<float>(5, 4, 3, 7), OverwritePolicy::kRefuse, {}, nan_metadata);
    ADD_FAILURE() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("nan.exr: ImageMetadata.chromaticities.green_y = nan must be finite"));
  }
  ImageMetadata black_white;
  black_white.chromaticities = Rec709();
  black_white.chromaticities->white_y = 0;
  EXPECT_THROW(WritePng(dir / "w.png", RandomImage<uint8_t>(5, 4, 3, 8), OverwritePolicy::kRefuse, black_white),
               std::invalid_argument);
  EXPECT_TRUE(dir.List().empty());
}

TEST(ImageIoChromaticitiesTest, MalformedAttributeNamesTheFile) {
  TempDir dir;
  ImageMetadata metadata;
  metadata.attributes["scanbench:chromaticities"] = "0.64 0.33 oops";
  WritePng(dir / "bad.png", RandomImage<uint8_t>(5, 4, 3, 9), OverwritePolicy::kRefuse, metadata);
  try {
    ReadImageMetadata(dir / "bad.png");
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("bad.png: scanbench:chromaticities = '0.64 0.33 oops' is not 8 finite numbers"));
  }
}


// The half conversion (eight values at a time with F16C where the CPU has it)
// gives Imath::half's bits for every kind of value: random magnitudes from
// half's subnormals to beyond its range, exact ties between two halves (to
// even), signed zeros, and a count that leaves a remainder of 7; with and
// without the absolute grid.
TEST(ImageIoTest, ExrHalfSamplesAreImathsRoundingBitForBit) {
  TempDir dir;
  ImageF image(61, 9, 3);  // 1647 values
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> exponent(-30.0f, 18.0f);
  std::uniform_int_distribution<int> half_bits(0, 0x7bff);
  for (size_t i = 0; i < image.size(); ++i) {
    float v = std::exp2(exponent(rng));
    if (i % 5 == 1) {  // midway between two adjacent finite halves: a tie
      Imath::half a, b;
      a.setBits(static_cast<uint16_t>(half_bits(rng)));
      b.setBits(static_cast<uint16_t>(a.bits() + 1));
      v = (float(a) + float(b)) / 2;
    }
    image.data()[i] = (i % 2 ? -v : v);
  }
  image.data()[0] = 0.0f;
  image.data()[1] = -0.0f;
  image.data()[2] = 1e9f;
  for (const double step : {0.0, std::ldexp(1.0, -12)}) {
    SCOPED_TRACE("half_absolute_step " + std::to_string(step));
    WriteExr(dir / "h.exr", image, OverwritePolicy::kReplace, {}, {}, {ExrSampleType::kHalf, ExrCompression::kNone, step});
    const ImageF read = ReadImageFloat(dir / "h.exr");
    ASSERT_EQ(read.size(), image.size());
    const float limit = static_cast<float>(1024 * step);
    for (size_t i = 0; i < image.size(); ++i) {
      const float v = image.data()[i];
      const float expected = float(Imath::half(
          std::abs(v) < limit ? std::nearbyint(v / float(step)) * float(step) : std::clamp(v, -65504.0f, 65504.0f)));
      ASSERT_EQ(std::signbit(read.data()[i]), std::signbit(expected)) << i << ": " << v;
      ASSERT_EQ(read.data()[i], expected) << i << ": " << v;
    }
  }
}

}  // namespace
}  // namespace scanbench
