// The solution's files from a hand-made solution: the specular map (issue #13)
// and its mark in status.png, and that nothing changes without one.
#include "app/controllers/map_writer.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/io/image_io.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::TemporaryFolder;

constexpr int kWidth = 24, kHeight = 16;

// Solved everywhere but the last row (no signal); normals up, grey albedo.
PhotometricSolution PlainSolution() {
  PhotometricSolution s;
  s.normal_in_table = ImageF(kWidth, kHeight, 3);
  s.albedo = ImageF(kWidth, kHeight, 3, 0.5f);
  s.status = ImageU8(kWidth, kHeight, 1, static_cast<uint8_t>(PixelStatus::kSolved));
  s.lights_used = ImageU8(kWidth, kHeight, 1, 10);
  s.condition_number = ImageF(kWidth, kHeight, 1, 2.0f);
  s.residual = ImageF(kWidth, kHeight, 1, 0.01f);
  s.solve_path = ImageU8(kWidth, kHeight, 1, 1);
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
  EXPECT_FLOAT_EQ(specular(3, 2, f0), 0.07f);
  EXPECT_FLOAT_EQ(specular(3, 2, 1 - f0), 0.16f);
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
