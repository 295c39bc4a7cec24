// The solve's albedo colour: where the matrix is applied, and how the colour
// is scored against a ground truth (which matrix is chosen:
// tests/app/session/albedo_color_choice_test.cc).
#include "pipeline/albedo_color.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "calibration/color_calibration.h"
#include "calibration/color_checker.h"
#include "calibration/color_science.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;
using Source = AlbedoColorOptions::Source;

TEST(AlbedoColorTest, TheMatrixIsAppliedToSolvedPixelsOnly) {
  AlbedoColor color;
  color.source = Source::kChart;
  color.rec709_from_camera << 1.6, -0.5, -0.1, -0.2, 1.3, -0.1, 0.0, -0.4, 1.4;
  color.color_space = "linear_rec709";
  ImageF albedo(2, 1, 3);
  for (size_t i = 0; i < albedo.size(); ++i) albedo.data()[i] = 0.1f * (i + 1);
  ImageU8 solved(2, 1, 1);
  solved.data()[0] = 1;
  const ImageF before = albedo;
  ApplyAlbedoColor(color, solved, &albedo);
  const Eigen::Vector3d expected = color.rec709_from_camera * Eigen::Vector3d(0.1, 0.2, 0.3);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(albedo.data()[c], expected[c], 1e-6);
  for (int c = 3; c < 6; ++c) EXPECT_EQ(albedo.data()[c], before.data()[c]);
  ImageU8 wrong(3, 1, 1);
  EXPECT_THROW(ApplyAlbedoColor(color, wrong, &albedo), std::invalid_argument);
}

// Two ColorChecker patches side by side, each 20 x 20 px.
ImageF TwoPatchTruth() {
  ImageF truth(40, 20, 3);
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 40; ++x) {
      const Eigen::Vector3d& v = ColorCheckerClassic()[x < 20 ? 14 : 17].linear_rec709;  // red, cyan
      for (int c = 0; c < 3; ++c) truth.data()[(y * 40 + x) * 3 + c] = static_cast<float>(v[c]);
    }
  }
  return truth;
}

TEST(AlbedoColorTest, ChartPatchesAreScoredByTheirMedianAlbedo) {
  const ImageF truth = TwoPatchTruth();
  ImageU8 mask(40, 20, 1);
  for (size_t i = 0; i < mask.size(); ++i) mask.data()[i] = 1;
  const AlbedoColorErrors exact = CompareAlbedoColor(truth, truth, mask);
  EXPECT_EQ(exact.chart_patches, 2);
  EXPECT_NEAR(exact.chart_max_delta_e, 0.0, 1e-9);
  EXPECT_NEAR(exact.delta_e.max, 0.0, 1e-9);

  // The red patch 10 % too bright, and a few wild pixels the median ignores.
  ImageF solved = truth;
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 20; ++x) {
      for (int c = 0; c < 3; ++c) solved.data()[(y * 40 + x) * 3 + c] *= 1.1f;
    }
  }
  for (int c = 0; c < 3; ++c) solved.data()[(5 * 40 + 30) * 3 + c] = 5.0f;
  const AlbedoColorErrors errors = CompareAlbedoColor(solved, truth, mask);
  ASSERT_EQ(errors.regions.size(), 2u);
  const AlbedoRegionError& red = errors.regions[0].name == "red" ? errors.regions[0] : errors.regions[1];
  const AlbedoRegionError& cyan = errors.regions[0].name == "cyan" ? errors.regions[0] : errors.regions[1];
  EXPECT_TRUE(red.chart_patch && cyan.chart_patch);
  const Eigen::Vector3d red_truth = ColorCheckerClassic()[14].linear_rec709;
  EXPECT_NEAR(red.delta_e, Ciede2000(LabFromLinearRec709(1.1 * red_truth), LabFromLinearRec709(red_truth)), 1e-3);
  EXPECT_NEAR(cyan.delta_e, 0.0, 1e-6);
  EXPECT_NEAR(errors.chart_mean_delta_e, red.delta_e / 2, 1e-6);
  EXPECT_GT(errors.delta_e.max, 20.0);  // the wild pixel counts per pixel

  // A textile's truth varies per pixel: no regions.
  ImageF textile(40, 20, 3);
  std::mt19937 random(7);
  std::uniform_real_distribution<float> value(0.05f, 0.9f);
  for (size_t i = 0; i < textile.size(); ++i) textile.data()[i] = value(random);
  EXPECT_TRUE(CompareAlbedoColor(textile, textile, mask).regions.empty());
}

// The regions as they were found before the hash buckets: every evaluated
// pixel's truth bits and index sorted, runs of at least min_pixels, largest
// first (std::sort, not stable: equal sizes in the order of their truth bits).
std::vector<AlbedoRegionError> RegionsBySorting(const ImageF& albedo, const ImageF& truth, const ImageU8& mask,
                                                double min_region_fraction) {
  std::vector<std::pair<std::array<uint32_t, 3>, uint32_t>> keyed;
  for (size_t i = 0; i < mask.num_pixels(); ++i) {
    if (mask.data()[i] == 0) continue;
    std::array<uint32_t, 3> key;
    std::memcpy(key.data(), truth.data() + 3 * i, sizeof(key));
    keyed.emplace_back(key, static_cast<uint32_t>(i));
  }
  const size_t min_pixels = std::max<size_t>(16, static_cast<size_t>(min_region_fraction * keyed.size()));
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::vector<uint32_t>> found;
  for (size_t begin = 0; begin < keyed.size();) {
    size_t end = begin + 1;
    while (end < keyed.size() && keyed[end].first == keyed[begin].first) ++end;
    if (end - begin >= min_pixels) {
      found.emplace_back();
      for (size_t j = begin; j < end; ++j) found.back().push_back(keyed[j].second);
    }
    begin = end;
  }
  std::vector<AlbedoRegionError> regions;
  if (found.size() < 2) return regions;
  std::vector<const std::vector<uint32_t>*> order;
  for (const auto& region : found) order.push_back(&region);
  std::sort(order.begin(), order.end(), [](auto* a, auto* b) { return a->size() > b->size(); });
  for (const auto* pixels : order) {
    AlbedoRegionError region;
    region.pixels = pixels->size();
    for (int c = 0; c < 3; ++c) {
      std::vector<float> channel;
      for (uint32_t i : *pixels) channel.push_back(albedo.data()[3 * size_t(i) + c]);
      std::nth_element(channel.begin(), channel.begin() + channel.size() / 2, channel.end());
      region.solved_linear_rec709[c] = channel[channel.size() / 2];
      region.truth_linear_rec709[c] = truth.data()[3 * size_t(pixels->front()) + c];
    }
    regions.push_back(region);
  }
  return regions;
}

// Band by band with the spill file and hash buckets: the regions (and their
// order among equal sizes) of a sort of every pixel, and the per-pixel
// figures of SummarizeErrors over all CIEDE2000 values; also with the
// possible regions counted first (only their pixels spilled).
TEST(AlbedoColorTest, BandedComparisonFindsTheRegionsOfAFullSort) {
  const int width = 120, height = 90;
  std::mt19937 random(11);
  std::uniform_real_distribution<float> value(0.05f, 0.9f);
  // 40 uniform patches of 4 sizes (ties), on a textile background, unmasked holes.
  std::vector<std::array<float, 3>> patches(40);
  for (auto& patch : patches) patch = {value(random), value(random), value(random)};
  patches[3] = {static_cast<float>(ColorCheckerClassic()[14].linear_rec709[0]),
                static_cast<float>(ColorCheckerClassic()[14].linear_rec709[1]),
                static_cast<float>(ColorCheckerClassic()[14].linear_rec709[2])};
  ImageF truth(width, height, 3), albedo(width, height, 3);
  ImageU8 mask(width, height, 1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const int cell = (y / 15) * 8 + x / 15;  // 6 x 8 cells of 15 x 15 px
      const int side = 6 + 3 * (cell % 4);      // 6, 9, 12 or 15 px squares in them
      const bool in_patch = cell < 40 && x % 15 < side && y % 15 < side;
      for (int c = 0; c < 3; ++c) {
        truth(x, y, c) = in_patch ? patches[cell][c] : value(random);
        albedo(x, y, c) = truth(x, y, c) * (0.9f + 0.2f * value(random));
      }
      mask(x, y) = (x * 7 + y * 3) % 11 != 0;
    }
  }
  const AlbedoColorErrors whole = CompareAlbedoColor(albedo, truth, mask, 0.002);
  for (const bool count_first : {false, true})
  for (int band_rows : {1, 7, 32, height}) {
    SCOPED_TRACE("bands of " + std::to_string(band_rows) + (count_first ? ", possible regions counted first" : ""));
    AlbedoColorComparison comparison(0.002);
    if (count_first) {
      // Over every pixel (a superset of the mask), in bands of 13 rows.
      for (int y = 0; y < height; y += 13) {
        const int rows = std::min(13, height - y);
        ImageF truth_rows(width, rows, 3);
        std::copy(truth.row(y), truth.row(y) + truth_rows.size(), truth_rows.data());
        comparison.CountPossibleRegions(truth_rows, ImageU8(width, rows, 1, 1));
      }
    }
    std::vector<double> per_pixel;
    for (int y = 0; y < height; y += band_rows) {
      const int rows = std::min(band_rows, height - y);
      ImageF albedo_rows(width, rows, 3), truth_rows(width, rows, 3);
      ImageU8 mask_rows(width, rows, 1);
      std::copy(albedo.row(y), albedo.row(y) + albedo_rows.size(), albedo_rows.data());
      std::copy(truth.row(y), truth.row(y) + truth_rows.size(), truth_rows.data());
      std::copy(mask.row(y), mask.row(y) + mask_rows.size(), mask_rows.data());
      comparison.AddRows(albedo_rows, mask_rows, truth_rows, 2);
    }
    const AlbedoColorErrors banded = comparison.Finish();
    EXPECT_EQ(banded.delta_e.mean, whole.delta_e.mean);
    EXPECT_EQ(banded.delta_e.median, whole.delta_e.median);
    EXPECT_EQ(banded.delta_e.percentile_95, whole.delta_e.percentile_95);
    EXPECT_EQ(banded.delta_e.max, whole.delta_e.max);
    EXPECT_EQ(banded.delta_e.num_pixels, whole.delta_e.num_pixels);
    const std::vector<AlbedoRegionError> sorted = RegionsBySorting(albedo, truth, mask, 0.002);
    ASSERT_EQ(sorted.size(), 40u);
    ASSERT_EQ(banded.regions.size(), sorted.size());
    for (size_t r = 0; r < sorted.size(); ++r) {
      EXPECT_EQ(banded.regions[r].pixels, sorted[r].pixels) << r;
      EXPECT_EQ(banded.regions[r].truth_linear_rec709, sorted[r].truth_linear_rec709) << r;
      EXPECT_EQ(banded.regions[r].solved_linear_rec709, sorted[r].solved_linear_rec709) << r;
      EXPECT_EQ(banded.regions[r].name, whole.regions[r].name) << r;
    }
    EXPECT_EQ(banded.chart_patches, 1);
    EXPECT_EQ(banded.chart_mean_delta_e, whole.chart_mean_delta_e);
    EXPECT_EQ(banded.region_mean_delta_e, whole.region_mean_delta_e);
  }
}

}  // namespace
}  // namespace scanbench
