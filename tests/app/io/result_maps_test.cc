// The solution's files from a hand-made solution: the specular map (issue #13)
// and its mark in status.png, and that nothing changes without one.
#include "app/io/result_maps.h"
#include "pipeline/banded_solve.h"

#include <algorithm>
#include <cstring>
#include <bit>
#include <cmath>
#include <fstream>
#include <iterator>
#include <numbers>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/io/image_io.h"
#include "calibration/color_science.h"
#include "solver/angular_error.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::TemporaryFolder;

constexpr int kWidth = 24, kHeight = 16;

// Solved everywhere from 10 lights, grey albedo; normals 0 for the caller to set.
PhotometricSolution SolvedEverywhere(int width, int height) {
  PhotometricSolution s;
  s.normal_in_table = ImageF(width, height, 3);
  s.albedo = ImageF(width, height, 3, 0.5f);
  s.status = ImageU8(width, height, 1, static_cast<uint8_t>(PixelStatus::kSolved));
  s.lights_used = ImageU8(width, height, 1, 10);
  s.condition_number = ImageF(width, height, 1, 2.0f);
  s.residual = ImageF(width, height, 1, 0.01f);
  s.solve_path = ImageU8(width, height, 1, 1);
  return s;
}

// Solved everywhere but the last row (no signal); normals up, grey albedo.
PhotometricSolution PlainSolution() {
  PhotometricSolution s = SolvedEverywhere(kWidth, kHeight);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) s.normal_in_table(x, y, 2) = 1.0f;
  for (int x = 0; x < kWidth; ++x) s.status(x, kHeight - 1) = static_cast<uint8_t>(PixelStatus::kNoSignal);
  return s;
}

// The left half estimated (F0 0.04 + x / 100, alpha 0.1 + x / 50), the right
// half unsupported, the unsolved row not solved.
PhotometricSolution SolutionWithSpecular() {
  PhotometricSolution s = PlainSolution();
  s.specular = ImageF(kWidth, kHeight, 2);
  s.specular_status = ImageU8(kWidth, kHeight, 1, static_cast<uint8_t>(SpecularStatus::kUnsupported));
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      if (y == kHeight - 1) {
        s.specular_status(x, y) = static_cast<uint8_t>(SpecularStatus::kNotSolved);
      } else if (x < kWidth / 2) {
        s.specular_status(x, y) = static_cast<uint8_t>(SpecularStatus::kEstimated);
        s.specular(x, y, 0) = 0.04f + x / 100.0f;
        s.specular(x, y, 1) = 0.1f + x / 50.0f;
      }
    }
  }
  return s;
}

TEST(MapWriterTest, SpecularMapIsWrittenAndUnsupportedPixelsAreMarked) {
  TemporaryFolder folder;
  const PhotometricSolution solution = SolutionWithSpecular();
  const auto written = WriteSolutionMaps(folder.path(), solution);
  ASSERT_EQ(written.count("specular_exr"), 1u);
  EXPECT_EQ(written.at("specular_exr"), "specular.exr");

  std::vector<std::string> names;
  const ImageF specular = ReadImageFloat(folder / "specular.exr", &names);
  ASSERT_EQ(specular.channels(), 2);
  ASSERT_EQ(names.size(), 2u);
  const int f0 = names[0] == "specular_f0" ? 0 : 1;  // OpenEXR may store them sorted
  EXPECT_EQ(names[f0], "specular_f0");
  EXPECT_EQ(names[1 - f0], "roughness_alpha");
  // Half float by default: within half a unit of the 11-bit mantissa.
  EXPECT_NEAR(specular(3, 2, f0), 0.07f, 0.07f / 2048);
  EXPECT_NEAR(specular(3, 2, 1 - f0), 0.16f, 0.16f / 2048);
  EXPECT_EQ(specular(20, 2, 1 - f0), 0.0f);           // unsupported
  EXPECT_EQ(specular(3, kHeight - 1, 1 - f0), 0.0f);  // not solved

  const ImageU8 status = ReadImageU8(folder / "status.png");
  EXPECT_EQ(status(3, 2), static_cast<uint8_t>(PixelStatus::kSolved));
  EXPECT_EQ(status(20, 2), kStatusSolvedSpecularUnsupported);
  EXPECT_EQ(status(20, kHeight - 1), static_cast<uint8_t>(PixelStatus::kNoSignal));  // its own code stays
  // The unsupported pixels are solved all the same.
  const ImageU8 solved = ReadImageU8(folder / "solved_mask.png");
  EXPECT_EQ(solved(20, 2), 255);
  EXPECT_EQ(solved(20, kHeight - 1), 0);
}

TEST(MapWriterTest, SpecularStatisticsCountEveryStatusAndAverageTheEstimates) {
  const std::optional<SpecularMapStatistics> stats = SpecularMapStatisticsOf(SolutionWithSpecular());
  ASSERT_TRUE(stats.has_value());
  const size_t rows = kHeight - 1, half = kWidth / 2;
  EXPECT_EQ(stats->estimated(), rows * half);
  EXPECT_EQ(stats->pixels_by_status[int(SpecularStatus::kUnsupported)], rows * half);
  EXPECT_EQ(stats->pixels_by_status[int(SpecularStatus::kNotSolved)], size_t(kWidth));
  // Means of x = 0 .. 11 = 5.5.
  EXPECT_NEAR(stats->mean_specular_f0, 0.04 + 5.5 / 100, 1e-6);
  EXPECT_NEAR(stats->mean_roughness_alpha, 0.1 + 5.5 / 50, 1e-6);
  const nlohmann::json json = nlohmann::json::parse(stats->ReportJson());
  EXPECT_EQ(json["pixels_by_status"]["estimated"], rows * half);
  EXPECT_EQ(json["pixels_by_status"]["unsupported"], rows * half);
  EXPECT_EQ(json["pixels_by_status"]["not_solved"], kWidth);
  EXPECT_NEAR(json["mean_roughness_alpha"].get<double>(), 0.21, 1e-6);
  EXPECT_EQ(json["status_png_code_unsupported"], 7);
  EXPECT_THAT(stats->BriefReport(), HasSubstr("specular map: 180 estimated, 180 unsupported, 24 not solved"));
}

TEST(MapWriterTest, WithoutSpecularNothingChanges) {
  TemporaryFolder folder;
  const PhotometricSolution solution = PlainSolution();
  EXPECT_FALSE(SpecularMapStatisticsOf(solution).has_value());
  const auto written = WriteSolutionMaps(folder.path(), solution);
  EXPECT_EQ(written.count("specular_exr"), 0u);
  EXPECT_FALSE(fs::exists(folder / "specular.exr"));
  const ImageU8 status = ReadImageU8(folder / "status.png");
  EXPECT_EQ(std::vector<uint8_t>(status.data(), status.data() + status.size()),
            std::vector<uint8_t>(solution.status.data(), solution.status.data() + solution.status.size()));
}

// The learned network's expected error (issue #33) gets a file of its own
// only when the solution carries the map, on the error map's grid.
TEST(MapWriterTest, LearnedErrorMapIsWrittenOnlyWhereTheNetworkRan) {
  TemporaryFolder with, without, streamed;
  PhotometricSolution solution = PlainSolution();
  EXPECT_EQ(WriteSolutionMaps(without.path(), solution).count("learned_error_deg"), 0u);
  EXPECT_FALSE(fs::exists(without / "learned_error_deg.exr"));

  solution.learned_error_deg = ImageF(kWidth, kHeight, 1, 0.0f);
  for (int x = 0; x < kWidth / 2; ++x) solution.learned_error_deg(x, 3) = 1.5f + x / 8.0f;
  const auto written = WriteSolutionMaps(with.path(), solution);
  ASSERT_EQ(written.count("learned_error_deg"), 1u);
  EXPECT_EQ(written.at("learned_error_deg"), "learned_error_deg.exr");
  std::vector<std::string> names;
  const ImageF read = ReadImageFloat(with / "learned_error_deg.exr", &names);
  ASSERT_EQ(read.channels(), 1);
  EXPECT_EQ(names, std::vector<std::string>{"Y"});
  EXPECT_NEAR(read(0, 3), 1.5f, 1.0f / 1024);  // 2^-9 deg grid below 2 deg
  EXPECT_NEAR(read(11, 3), 1.5f + 11 / 8.0f, 2.875f / 2048);
  EXPECT_EQ(read(20, 3), 0.0f);  // not the network's normal
  // A band without the map for a stream opened with it is refused, naming both.
  SolutionMapStream stream(streamed.path(), kWidth, kHeight, false, false, true);
  PhotometricSolution band = PlainSolution();
  try {
    stream.AddBand(band);
    FAIL() << "a band without learned_error_deg was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("with learned_error_deg.exr"));
  }
}

// Unit normals in every direction of the upper hemisphere (and a few on the
// horizon), stored by default as half float with components below 0.25 on
// the 2^-12 grid: the largest change of direction that the quantisation
// makes, as read back, is the accuracy cost of the compact maps. Rounding
// moves each component by at most 2^-12 (half a step of the 11-bit mantissa
// in [0.5, 1); the grid's 2^-13 below 0.25), so the direction by at most
// sqrt(3) 2^-12 rad = 0.0242 deg; measured 0.0223 deg here (seed 14, 384 x 256
// normals; the same with half alone). The solver's own error at full size is
// 0.23 deg mean.
TEST(MapWriterTest, HalfFloatNormalsMoveByAtMostAFortiethOfADegree) {
  constexpr int width = 384, height = 256;
  PhotometricSolution solution = SolvedEverywhere(width, height);
  std::mt19937 rng(14);
  std::normal_distribution<double> gauss;
  for (size_t p = 0; p < solution.normal_in_table.num_pixels(); ++p) {
    double n[3] = {gauss(rng), gauss(rng), std::abs(gauss(rng))};
    if (p % 97 == 0) n[2] = 0;  // on the horizon
    const double norm = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int c = 0; c < 3; ++c) solution.normal_in_table.data()[3 * p + c] = static_cast<float>(n[c] / norm);
  }
  TemporaryFolder folder;
  WriteSolutionMaps(folder.path(), solution);
  const ImageFileInfo info = ReadImageFileInfo(folder / "normal.exr");
  EXPECT_TRUE(info.is_float);
  EXPECT_EQ(info.bits_per_sample, 16);
  const ImageF read = ReadImageFloat(folder / "normal.exr");
  double max_deg = 0;
  for (size_t p = 0; p < read.num_pixels(); ++p) {
    const float* a = solution.normal_in_table.data() + 3 * p;
    const float* b = read.data() + 3 * p;
    const double cross[3] = {double(a[1]) * b[2] - double(a[2]) * b[1], double(a[2]) * b[0] - double(a[0]) * b[2],
                             double(a[0]) * b[1] - double(a[1]) * b[0]};
    const double dot = double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2];
    const double angle = std::atan2(std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]), dot);
    max_deg = std::max(max_deg, angle * 180 / std::numbers::pi);
  }
  RecordProperty("max_normal_change_deg", std::to_string(max_deg));
  EXPECT_GT(max_deg, 0.001) << "half storage must quantise";
  EXPECT_GT(max_deg, 0.015) << "the sample reaches near the worst case";
  EXPECT_LT(max_deg, 0.0243);

  // --float32-maps: exactly the normals in memory.
  TemporaryFolder exact_folder;
  WriteSolutionMaps(exact_folder.path(), solution, {}, ResultMapExrEncoding(true));
  EXPECT_EQ(ReadImageFileInfo(exact_folder / "normal.exr").bits_per_sample, 32);
  const ImageF exact = ReadImageFloat(exact_folder / "normal.exr");
  EXPECT_EQ(std::vector<float>(exact.data(), exact.data() + exact.size()),
            std::vector<float>(solution.normal_in_table.data(),
                               solution.normal_in_table.data() + solution.normal_in_table.size()));
}

// The compact normal.exr (half, components below 0.25 on a 2^-12 grid) keeps
// the solve's accuracy: a solution off a smooth ground truth by the solver's
// typical error (about 0.23 deg mean) has, read back from the file, the same
// mean angular error against that truth within 0.001 deg.
TEST(MapWriterTest, CompactNormalsKeepTheMeanErrorAgainstGroundTruth) {
  constexpr int width = 512, height = 384;
  PhotometricSolution solution = SolvedEverywhere(width, height);
  ImageF truth(width, height, 3);
  std::mt19937 rng(2312);
  std::normal_distribution<double> noise(0.0, 0.0033);  // rad per tangent component
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      // A woven surface's tilts: up to about 30 deg, varying over a few pixels.
      const double t[3] = {0.45 * std::sin(x / 7.0) * std::cos(y / 11.0), 0.35 * std::sin(y / 5.0 + x / 13.0), 1.0};
      const double e[3] = {t[0] + noise(rng), t[1] + noise(rng), t[2] + noise(rng)};
      const double nt = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
      const double ne = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
      for (int c = 0; c < 3; ++c) {
        truth(x, y, c) = static_cast<float>(t[c] / nt);
        solution.normal_in_table(x, y, c) = static_cast<float>(e[c] / ne);
      }
    }
  }
  const ImageU8 all(width, height, 1, 1);
  const double in_memory = AngularErrorDegrees(solution.normal_in_table, truth, all).mean;
  EXPECT_GT(in_memory, 0.15);
  EXPECT_LT(in_memory, 0.35);
  TemporaryFolder folder;
  WriteSolutionMaps(folder.path(), solution);
  const double from_file = AngularErrorDegrees(ReadImageFloat(folder / "normal.exr"), truth, all).mean;
  RecordProperty("mean_error_in_memory_deg", std::to_string(in_memory));
  RecordProperty("mean_error_from_file_deg", std::to_string(from_file));
  EXPECT_NEAR(from_file, in_memory, 0.001);
}

// Every EXR of a result in half; confidence's integer light counts exact, its
// condition numbers within half's precision, its residuals on 8 significant
// bits (within 2^-8 relative).
TEST(MapWriterTest, ConfidenceAndAlbedoSurviveHalfStorage) {
  TemporaryFolder folder;
  PhotometricSolution solution = PlainSolution();
  solution.condition_number(5, 5) = 87.3f;
  solution.residual(5, 5) = 0.0123f;
  solution.albedo(5, 5, 1) = 0.731f;
  WriteSolutionMaps(folder.path(), solution);
  for (const char* name : {"normal.exr", "albedo.exr", "confidence.exr"}) {
    EXPECT_EQ(ReadImageFileInfo(folder / name).bits_per_sample, 16) << name;
  }
  std::vector<std::string> names;
  const ImageF confidence = ReadImageFloat(folder / "confidence.exr", &names);
  ASSERT_EQ(names.size(), 3u);
  auto channel = [&](const std::string& name) {
    return static_cast<int>(std::find(names.begin(), names.end(), name) - names.begin());
  };
  EXPECT_EQ(confidence(5, 5, channel("lights_used")), 10.0f);
  EXPECT_NEAR(confidence(5, 5, channel("condition_number")), 87.3f, 87.3f / 2048);
  const float residual = confidence(5, 5, channel("residual"));
  EXPECT_NEAR(residual, 0.0123f, 0.0123f / 256);
  int exponent = 0;
  const float mantissa = std::frexp(residual, &exponent);
  EXPECT_EQ(std::ldexp(mantissa, 8), std::round(std::ldexp(mantissa, 8))) << "not on 8 significant bits: " << residual;
  EXPECT_NEAR(ReadImageFloat(folder / "albedo.exr")(5, 5, 1), 0.731f, 0.731f / 2048);
}

// The residual's rounding to 8 significant bits (on the float's bits) is the
// libm form's (frexp, nearbyint, ldexp), ties to even included: every
// residual of a solution with random values over half's normal range, the
// ties on either side of an even and an odd last kept bit, and exact powers of
// two read back from confidence.exr as the libm form rounds them and half holds them.
TEST(MapWriterTest, ResidualsOnEightBitsAreTheLibmRounding) {
  constexpr int width = 256, height = 64;
  PhotometricSolution solution = SolvedEverywhere(width, height);
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> log2_value(-14.0f, 15.9f);
  std::vector<float> residuals;
  for (int i = 0; i < width * height; ++i) {
    float value = std::exp2(log2_value(rng));
    if (i % 4 == 1) {  // a tie: the dropped 16 bits exactly half a kept step
      value = std::bit_cast<float>((std::bit_cast<uint32_t>(value) & ~0xFFFFu) | 0x8000u);
    } else if (i % 4 == 2) {  // one below and one above a tie
      value = std::bit_cast<float>((std::bit_cast<uint32_t>(value) & ~0xFFFFu) | (i % 8 == 2 ? 0x7FFFu : 0x8001u));
    } else if (i % 64 == 3) {
      value = std::exp2(std::floor(log2_value(rng)));
    }
    residuals.push_back(i % 16 == 15 ? -value : value);
  }
  std::copy(residuals.begin(), residuals.end(), solution.residual.data());
  TemporaryFolder folder;
  WriteSolutionMaps(folder.path(), solution);
  std::vector<std::string> names;
  const ImageF confidence = ReadImageFloat(folder / "confidence.exr", &names);
  const int channel = static_cast<int>(std::find(names.begin(), names.end(), "residual") - names.begin());
  ASSERT_LT(channel, 3);
  for (int i = 0; i < width * height; ++i) {
    int exponent = 0;
    const float mantissa = std::frexp(residuals[i], &exponent);
    const float expected = std::ldexp(std::nearbyint(std::ldexp(mantissa, 8)), exponent - 8);
    ASSERT_EQ(confidence.data()[3 * i + channel], expected) << "residual " << residuals[i];
  }
}

// normal.png's codes are lround(clamp((n + 1) / 2, 0, 1) * 65535) of every
// component: floats near -1 (where the code is 0 or 1), near 0 and 1, tiny
// ones of either sign, out of range, and random ones.
TEST(MapWriterTest, NormalPngCodesAreTheRoundedScaledComponents) {
  std::vector<float> values = {-2.0f, -1.0f, 0.0f, -0.0f, 1.0f, 2.0f, 1e-30f, -1e-30f, 1e-45f, -1e-45f};
  for (float centre : {-1.0f, 0.0f, 1.0f}) {
    float below = centre, above = centre;
    for (int i = 0; i < 20000; ++i) {
      below = std::nextafter(below, -3.0f);
      above = std::nextafter(above, 3.0f);
      values.push_back(below);
      values.push_back(above);
    }
  }
  for (uint32_t bits = std::bit_cast<uint32_t>(1e-12f); bits < std::bit_cast<uint32_t>(1e-3f); bits += 997) {
    values.push_back(std::bit_cast<float>(bits));
    values.push_back(-std::bit_cast<float>(bits));
  }
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> uniform(-1.2f, 1.2f);
  while (values.size() % 3 != 0 || values.size() < 400000) values.push_back(uniform(rng));
  ImageF normals(static_cast<int>(values.size() / 3), 1, 3);
  std::copy(values.begin(), values.end(), normals.data());
  const ImageU16 codes = EncodeNormalsPng16(normals);
  for (size_t i = 0; i < values.size(); ++i) {
    const double value = std::clamp((double(values[i]) + 1.0) * 0.5, 0.0, 1.0);
    ASSERT_EQ(codes.data()[i], static_cast<uint16_t>(std::lround(value * 65535.0))) << values[i];
  }
}

std::string FileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // An EXR header's capDate is the second the file was written (OpenImageIO's
  // DateTime): blanked, so that two writes a second apart compare equal.
  const std::string attribute("capDate\0string\0", 15);
  if (const size_t at = bytes.find(attribute); at != std::string::npos && at + 19 <= bytes.size()) {
    uint32_t length = 0;
    std::memcpy(&length, bytes.data() + at + 15, 4);  // little-endian, as OpenEXR stores it
    if (at + 19 + length <= bytes.size()) std::fill_n(bytes.begin() + at + 19, length, '\0');
  }
  return bytes;
}

// The files are written concurrently; each is the same, byte for byte (but
// for the EXRs' capDate), as when they are written one after another, and
// the error map is among them.
TEST(MapWriterTest, ConcurrentWriteGivesTheFilesOfASequentialOne) {
  PhotometricSolution solution = SolutionWithSpecular();
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  for (size_t i = 0; i < solution.normal_in_table.size(); ++i) solution.normal_in_table.data()[i] = uniform(rng);
  for (size_t i = 0; i < solution.albedo.size(); ++i) solution.albedo.data()[i] = 0.5f + 0.4f * uniform(rng);
  ImageF error_deg(kWidth, kHeight, 1);
  for (size_t i = 0; i < error_deg.size(); ++i) error_deg.data()[i] = 1.0f + uniform(rng);
  TemporaryFolder sequential, concurrent;
  const auto sequential_outputs =
      WriteSolutionMaps(sequential.path(), solution, {}, ResultMapExrEncoding(), error_deg, /*threads=*/1);
  const auto concurrent_outputs =
      WriteSolutionMaps(concurrent.path(), solution, {}, ResultMapExrEncoding(), error_deg, /*threads=*/4);
  EXPECT_EQ(concurrent_outputs, sequential_outputs);
  EXPECT_EQ(concurrent_outputs.at("angular_error_deg"), "angular_error_deg.exr");
  const std::map<std::string, uintmax_t> sizes = FileSizesIn(sequential.path());
  EXPECT_EQ(sizes.size(), 9u);  // 7 maps, specular.exr, angular_error_deg.exr
  EXPECT_EQ(FileSizesIn(concurrent.path()), sizes);
  for (const auto& [name, bytes] : sizes) {
    EXPECT_EQ(FileBytes(concurrent / name), FileBytes(sequential / name)) << name;
  }
  // On the 2^-9 deg grid below 2 deg: within 2^-10 deg of the value.
  const ImageF error_from_file = ReadImageFloat(concurrent / "angular_error_deg.exr");
  for (size_t i = 0; i < error_deg.size(); ++i) {
    ASSERT_NEAR(error_from_file.data()[i], error_deg.data()[i], 1.0 / 1024) << i;
    ASSERT_EQ(error_from_file.data()[i] * 512, std::round(error_from_file.data()[i] * 512)) << i;
  }
}

// Streamed band by band (bands of 1 row, bands that do not divide the
// height, one band), with the error map's rows made alongside each band: the
// files of WriteSolutionMaps of the whole solution, byte for byte (but for
// the EXRs' capDate). Uncommitted or failed, the stream leaves no file.
TEST(MapWriterTest, StreamedBandsGiveTheFilesOfAWholeWrite) {
  PhotometricSolution solution = SolutionWithSpecular();
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> uniform(0.0f, 3.0f);
  for (size_t i = 0; i < solution.normal_in_table.size(); ++i) solution.normal_in_table.data()[i] = uniform(rng) - 1.5f;
  for (size_t i = 0; i < solution.albedo.size(); ++i) solution.albedo.data()[i] = 0.3f * uniform(rng);
  ImageF error_deg(kWidth, kHeight, 1);
  for (size_t i = 0; i < error_deg.size(); ++i) error_deg.data()[i] = uniform(rng);
  TemporaryFolder given;
  const auto given_outputs = WriteSolutionMaps(given.path(), solution, {}, ResultMapExrEncoding(), error_deg, 2);
  const std::map<std::string, uintmax_t> sizes = FileSizesIn(given.path());
  EXPECT_EQ(sizes.size(), 9u);
  for (const int band_rows : {1, 5, 7, kHeight}) {
    SCOPED_TRACE("bands of " + std::to_string(band_rows));
    TemporaryFolder streamed;
    SolutionMapStream stream(streamed.path(), kWidth, kHeight, true, true);
    double alongside_calls = 0;
    for (int y = 0; y < kHeight; y += band_rows) {
      const int rows = std::min(band_rows, kHeight - y);
      stream.AddBand(
          SolutionRows(solution, y, rows),
          [&] {
            ++alongside_calls;
            ImageF error_rows(kWidth, rows, 1);
            std::copy(error_deg.row(y), error_deg.row(y) + error_rows.size(), error_rows.data());
            return error_rows;
          },
          2);
    }
    EXPECT_EQ(alongside_calls, (kHeight + band_rows - 1) / band_rows);
    for (const auto& [name, bytes] : sizes) EXPECT_FALSE(fs::exists(streamed / name)) << name << " before Commit";
    EXPECT_EQ(stream.Commit(), given_outputs);
    ASSERT_EQ(FileSizesIn(streamed.path()), sizes);
    for (const auto& [name, bytes] : sizes) EXPECT_EQ(FileBytes(streamed / name), FileBytes(given / name)) << name;
  }

  TemporaryFolder uncommitted;
  {
    SolutionMapStream stream(uncommitted.path(), kWidth, kHeight, true, false);
    stream.AddBand(SolutionRows(solution, 0, 3));
    EXPECT_THROW(stream.Commit(), std::logic_error);  // rows missing
    EXPECT_THROW(stream.AddBand(SolutionRows(solution, 0, kHeight)), std::invalid_argument);  // too many rows
    EXPECT_THROW(stream.AddBand(PlainSolution()), std::invalid_argument);                   // no specular maps
  }
  EXPECT_TRUE(fs::is_empty(uncommitted.path()));

  TemporaryFolder failing;
  {
    SolutionMapStream stream(failing.path(), kWidth, kHeight, true, true);
    EXPECT_THROW(stream.AddBand(solution, []() -> ImageF { throw std::runtime_error("evaluation failed"); }, 2),
                 std::runtime_error);
    EXPECT_THROW(stream.AddBand(solution), std::invalid_argument);  // the error map's rows are missing
  }
  EXPECT_TRUE(fs::is_empty(failing.path()));
}

// The preview's table gives every value the code the sRGB curve gives it:
// random values over [0, 1.5], and the 64 floats on either side of every
// point where the code changes. (Checked once over every float in [0, 1.5].)
TEST(MapWriterTest, SrgbPreviewCodeEqualsTheCurve) {
  const auto curve = [](float v) { return std::lround(SrgbEncode(v) * 255.0); };
  std::mt19937 rng(31);
  std::uniform_real_distribution<float> uniform(0.0f, 1.5f);
  for (int i = 0; i < 200000; ++i) {
    const float v = uniform(rng);
    ASSERT_EQ(SrgbPreviewCode(v), curve(v)) << v;
  }
  int changes = 0;
  for (uint32_t bits = std::bit_cast<uint32_t>(0.0f); bits < std::bit_cast<uint32_t>(1.0f);) {
    // The next change of code: bisection, as the table is not consulted here.
    const long code = curve(std::bit_cast<float>(bits));
    uint32_t same = bits, changed = std::bit_cast<uint32_t>(1.0f);
    if (curve(std::bit_cast<float>(changed)) == code) break;
    while (changed - same > 1) {
      const uint32_t middle = same + (changed - same) / 2;
      (curve(std::bit_cast<float>(middle)) == code ? same : changed) = middle;
    }
    for (uint32_t b = changed - 64; b <= changed + 64; ++b) {
      ASSERT_EQ(SrgbPreviewCode(std::bit_cast<float>(b)), curve(std::bit_cast<float>(b))) << std::bit_cast<float>(b);
    }
    ++changes;
    bits = changed;
  }
  EXPECT_EQ(changes, 255);
  EXPECT_EQ(SrgbPreviewCode(-0.5f), 0);
  EXPECT_EQ(SrgbPreviewCode(std::nanf("")), 0);
  EXPECT_EQ(SrgbPreviewCode(std::numeric_limits<float>::infinity()), 255);
}

TEST(MapWriterTest, MisshapenErrorMapIsRefusedBeforeAnyFile) {
  TemporaryFolder folder;
  EXPECT_THAT([&] { WriteSolutionMaps(folder.path(), PlainSolution(), {}, ResultMapExrEncoding(), ImageF(4, 4, 1)); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("angular_error_deg is 4x4x1, must be 24x16x1")));
  EXPECT_TRUE(fs::is_empty(folder.path()));
}

TEST(MapWriterTest, FileSizesInListsEveryFile) {
  TemporaryFolder folder;
  WriteSolutionMaps(folder.path(), PlainSolution());
  const std::map<std::string, uintmax_t> sizes = FileSizesIn(folder.path());
  EXPECT_EQ(sizes.size(), 7u);
  EXPECT_EQ(sizes.at("normal.exr"), fs::file_size(folder / "normal.exr"));
  EXPECT_GT(sizes.at("status.png"), 0u);
}

TEST(MapWriterTest, MisshapenSpecularMapIsRefusedBeforeAnyFile) {
  TemporaryFolder folder;
  PhotometricSolution solution = SolutionWithSpecular();
  solution.specular = ImageF(kWidth, kHeight, 1);
  EXPECT_THAT([&] { WriteSolutionMaps(folder.path(), solution); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("PhotometricSolution.specular is 24x16x1, must be 24x16x2")));
  EXPECT_TRUE(fs::is_empty(folder.path()));
}

}  // namespace
}  // namespace scanbench
