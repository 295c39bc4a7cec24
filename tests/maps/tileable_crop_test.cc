#include "maps/tileable_crop.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/sim/simulated_rig.h"

namespace scanbench {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// A smooth pattern whose periods (37, 23, 53 px) divide no tile size, plus a
// little noise, 3 channels.
ImageF PeriodicPattern(int width, int height, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.01);
  ImageF image(width, height, 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < 3; ++c) {
        image(x, y, c) = static_cast<float>(0.5 + 0.2 * std::sin(kTwoPi * x / 37.0 + c) +
                                            0.15 * std::cos(kTwoPi * y / 23.0 + 2 * c) +
                                            0.1 * std::sin(kTwoPi * (x + y) / 53.0) + noise(rng));
      }
    }
  }
  return image;
}

// Mean absolute difference per channel across the wrap (column 0 against
// column W-1, row 0 against row H-1) and between interior neighbours; per
// direction also the largest interior step between adjacent columns (rows).
struct SeamFigures {
  double wrap = 0, neighbour = 0;        // both directions
  double wrap_x = 0, max_step_x = 0;     // columns
  double wrap_y = 0, max_step_y = 0;     // rows
};

SeamFigures MeasureSeams(const ImageF& tile) {
  const int w = tile.width(), h = tile.height(), channels = tile.channels();
  auto column_step = [&](int xa, int xb) {
    double sum = 0;
    for (int y = 0; y < h; ++y) {
      for (int c = 0; c < channels; ++c) sum += std::abs(tile(xa, y, c) - tile(xb, y, c));
    }
    return sum / (h * channels);
  };
  auto row_step = [&](int ya, int yb) {
    double sum = 0;
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < channels; ++c) sum += std::abs(tile(x, ya, c) - tile(x, yb, c));
    }
    return sum / (w * channels);
  };
  SeamFigures figures;
  figures.wrap_x = column_step(0, w - 1);
  figures.wrap_y = row_step(0, h - 1);
  figures.wrap = (figures.wrap_x * h + figures.wrap_y * w) / (w + h);
  double neighbour = 0;
  for (int x = 0; x + 1 < w; ++x) {
    const double step = column_step(x, x + 1);
    neighbour += step * h;
    figures.max_step_x = std::max(figures.max_step_x, step);
  }
  for (int y = 0; y + 1 < h; ++y) {
    const double step = row_step(y, y + 1);
    neighbour += step * w;
    figures.max_step_y = std::max(figures.max_step_y, step);
  }
  figures.neighbour = neighbour / (static_cast<double>(w - 1) * h + static_cast<double>(h - 1) * w);
  return figures;
}

ImageF Crop(const ImageF& image, int x0, int y0, int width, int height) {
  ImageF crop(width, height, image.channels());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < image.channels(); ++c) crop(x, y, c) = image(x0 + x, y0 + y, c);
    }
  }
  return crop;
}

void ExpectUnitNormals(const ImageF& normals) {
  for (int y = 0; y < normals.height(); ++y) {
    for (int x = 0; x < normals.width(); ++x) {
      const double n = std::sqrt(normals(x, y, 0) * normals(x, y, 0) + normals(x, y, 1) * normals(x, y, 1) +
                                 normals(x, y, 2) * normals(x, y, 2));
      ASSERT_NEAR(n, 1.0, 1e-5) << x << "," << y;
    }
  }
}

TEST(TileableCrop, PeriodicPatternWrapsLikeAnInteriorStep) {
  const ImageF pattern = PeriodicPattern(300, 200, 11);
  TileableCropOptions options;
  options.tile_width = 128;
  options.blend_width_px = 16;
  std::vector<ImageF> tiles;
  const TileableCropSummary summary = MakeTileableCrop(options, {{&pattern, TileMapKind::kLinear}}, nullptr, &tiles);
  ASSERT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  ASSERT_EQ(tiles.size(), 1u);
  ASSERT_TRUE(tiles[0].SameSize(128, 128));
  EXPECT_EQ(summary.tile_width, 128);
  EXPECT_EQ(summary.tile_height, 128);
  // Window plus band inside the image.
  EXPECT_GE(summary.x0, 0);
  EXPECT_GE(summary.y0, 0);
  EXPECT_LE(summary.x0 + 128 + 16, 300);
  EXPECT_LE(summary.y0 + 128 + 16, 200);

  const SeamFigures blended = MeasureSeams(tiles[0]);
  const SeamFigures naive = MeasureSeams(Crop(pattern, summary.x0, summary.y0, 128, 128));
  EXPECT_LT(blended.wrap, 1.5 * blended.neighbour) << summary.message;
  EXPECT_GT(naive.wrap, 4.0 * naive.neighbour) << summary.message;
  // The summary reports the same figures.
  EXPECT_NEAR(summary.wrap_difference, blended.wrap, 1e-6);
  EXPECT_NEAR(summary.naive_wrap_difference, naive.wrap, 1e-6);
  EXPECT_NEAR(summary.neighbour_difference, blended.neighbour, 1e-6);

  // Outside the bands the tile is the source, unchanged.
  for (int y = 16; y < 128; y += 5) {
    for (int x = 16; x < 128; x += 3) {
      ASSERT_EQ(tiles[0](x, y, 1), pattern(summary.x0 + x, summary.y0 + y, 1)) << x << "," << y;
    }
  }
  // Column 0 is mostly the continuation past the right edge.
  const double t0 = 3 * std::pow(0.5 / 16, 2) - 2 * std::pow(0.5 / 16, 3);
  const int y = 60;
  EXPECT_NEAR(tiles[0](0, y, 0),
              t0 * pattern(summary.x0, summary.y0 + y, 0) + (1 - t0) * pattern(summary.x0 + 128, summary.y0 + y, 0),
              1e-6);
}

TEST(TileableCrop, SearchFindsALowerSeamCostThanTheCentre) {
  // A pattern plus strong low-frequency variation: the position matters.
  ImageF image = PeriodicPattern(320, 240, 5);
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      image(x, y, 0) += static_cast<float>(0.3 * std::sin(kTwoPi * x * y / (320.0 * 240.0) * 3));
    }
  }
  TileableCropOptions options;
  options.tile_width = 96;
  options.blend_width_px = 12;
  std::vector<ImageF> searched, centred;
  const TileableCropSummary with_search =
      MakeTileableCrop(options, {{&image, TileMapKind::kLinear}}, nullptr, &searched);
  options.search_position = false;
  const TileableCropSummary without = MakeTileableCrop(options, {{&image, TileMapKind::kLinear}}, nullptr, &centred);
  ASSERT_EQ(with_search.termination, Termination::kSuccess);
  ASSERT_EQ(without.termination, Termination::kSuccess);
  EXPECT_EQ(without.x0, (320 - 96 - 12) / 2);
  EXPECT_EQ(without.y0, (240 - 96 - 12) / 2);
  EXPECT_LT(with_search.seam_cost, 0.8 * without.seam_cost)
      << with_search.message << " / " << without.message;
}

TEST(TileableCrop, RequestedAndAutomaticSizes) {
  const ImageF pattern = PeriodicPattern(300, 200, 3);
  auto run = [&](int w, int h, int band) {
    TileableCropOptions options;
    options.tile_width = w;
    options.tile_height = h;
    options.blend_width_px = band;
    std::vector<ImageF> tiles;
    const TileableCropSummary summary =
        MakeTileableCrop(options, {{&pattern, TileMapKind::kLinear}, {&pattern, TileMapKind::kNormal}}, nullptr,
                         &tiles);
    EXPECT_EQ(summary.termination, Termination::kSuccess) << summary.message;
    EXPECT_EQ(tiles.size(), 2u);
    for (const ImageF& tile : tiles) {
      EXPECT_TRUE(tile.SameSize(summary.tile_width, summary.tile_height));
      EXPECT_EQ(tile.channels(), 3);
    }
    return summary;
  };
  TileableCropSummary s = run(100, 60, 8);
  EXPECT_EQ(s.tile_width, 100);
  EXPECT_EQ(s.tile_height, 60);
  s = run(64, 0, 8);
  EXPECT_EQ(s.tile_width, 64);
  EXPECT_EQ(s.tile_height, 64);
  s = run(0, 0, 32);  // 128 + 32 fits in 200 rows, 256 + 32 does not
  EXPECT_EQ(s.tile_width, 128);
  EXPECT_EQ(s.tile_height, 128);
  s = run(0, 0, 8);  // 128 + 8 fits, 256 + 8 does not
  EXPECT_EQ(s.tile_width, 128);
  s = run(0, 40, 16);  // width alone: 256 + 16 <= 300
  EXPECT_EQ(s.tile_width, 256);
  EXPECT_EQ(s.tile_height, 40);
}

TEST(TileableCrop, ValidMaskBoundsTheWindow) {
  const ImageF pattern = PeriodicPattern(300, 200, 4);
  // Valid: a 170 x 150 rectangle at (100, 30) with a hole near its top-left.
  ImageU8 valid(300, 200, 1, 0);
  for (int y = 30; y < 180; ++y) {
    for (int x = 100; x < 270; ++x) valid(x, y) = 1;
  }
  valid(105, 35) = 0;
  TileableCropOptions options;
  options.blend_width_px = 16;
  std::vector<ImageF> tiles;
  const TileableCropSummary summary = MakeTileableCrop(options, {{&pattern, TileMapKind::kLinear}}, &valid, &tiles);
  ASSERT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  EXPECT_EQ(summary.tile_width, 128);  // 144 fits in 150 rows beside the hole, 272 does not
  for (int y = summary.y0; y < summary.y0 + summary.tile_height + 16; ++y) {
    for (int x = summary.x0; x < summary.x0 + summary.tile_width + 16; ++x) {
      ASSERT_NE(valid(x, y), 0) << "the window uses invalid pixel " << x << "," << y;
    }
  }
  // A hole in the middle of the only window that fits: nothing fits any more.
  valid(185, 105) = 0;
  options.tile_width = 150 - 16;
  const TileableCropSummary failed = MakeTileableCrop(options, {{&pattern, TileMapKind::kLinear}}, &valid, &tiles);
  EXPECT_EQ(failed.termination, Termination::kFailure);
  EXPECT_THAT(failed.message, ::testing::HasSubstr("134x134 tile"));
  EXPECT_THAT(failed.message, ::testing::HasSubstr("150x150"));
  EXPECT_TRUE(tiles.empty());
}

TEST(TileableCrop, TooLargeRequestFailsNamingTheSizes) {
  const ImageF pattern = PeriodicPattern(120, 80, 2);
  TileableCropOptions options;
  options.tile_width = 512;
  options.tile_height = 100;
  std::vector<ImageF> tiles(1);
  TileableCropSummary summary = MakeTileableCrop(options, {{&pattern, TileMapKind::kLinear}}, nullptr, &tiles);
  EXPECT_EQ(summary.termination, Termination::kFailure);
  EXPECT_THAT(summary.message, ::testing::HasSubstr("512x100 tile"));
  EXPECT_THAT(summary.message, ::testing::HasSubstr("544x132"));
  EXPECT_THAT(summary.message, ::testing::HasSubstr("120x80"));
  EXPECT_TRUE(tiles.empty());
  // Automatic: the smallest power of two the band allows (32) plus the band is 64 rows; 40 rows cannot hold it.
  const ImageF thin = PeriodicPattern(200, 40, 2);
  options = {};
  summary = MakeTileableCrop(options, {{&thin, TileMapKind::kLinear}}, nullptr, &tiles);
  EXPECT_EQ(summary.termination, Termination::kFailure);
  EXPECT_THAT(summary.message, ::testing::HasSubstr("the smallest, 32x32"));
  EXPECT_THAT(summary.message, ::testing::HasSubstr("needs 64x64 valid pixels"));
  EXPECT_THAT(summary.message, ::testing::HasSubstr("200x40"));
}

TEST(TileableCrop, NormalsStayUnitThroughTheBand) {
  // Random tilted normals, some not unit, one zero and one facing down in the band.
  std::mt19937_64 rng(9);
  std::normal_distribution<double> slope(0.0, 0.5);
  ImageF normals(160, 120, 3);
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const double p = slope(rng), q = slope(rng), scale = 0.5 + (x % 3);
      const double n = std::sqrt(p * p + q * q + 1);
      normals(x, y, 0) = static_cast<float>(scale * p / n);
      normals(x, y, 1) = static_cast<float>(scale * q / n);
      normals(x, y, 2) = static_cast<float>(scale / n);
    }
  }
  TileableCropOptions options;
  options.tile_width = 64;
  options.blend_width_px = 16;
  options.search_position = false;
  const int x0 = (160 - 80) / 2, y0 = (120 - 80) / 2;
  for (int c = 0; c < 3; ++c) normals(x0 + 64 + 2, y0 + 30, c) = 0.0f;  // zero, mixed into tile column 2
  normals(x0 + 3, y0 + 40, 2) = -0.5f;                                     // facing down, in the band
  std::vector<ImageF> tiles;
  const TileableCropSummary summary = MakeTileableCrop(options, {{&normals, TileMapKind::kNormal}}, nullptr, &tiles);
  ASSERT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  EXPECT_EQ(summary.x0, x0);
  EXPECT_EQ(summary.y0, y0);
  ExpectUnitNormals(tiles[0]);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) ASSERT_GT(tiles[0](x, y, 2), 0.0f) << x << "," << y;
  }
}

TEST(TileableCrop, SimulatedTwillTilesWithoutAVisibleSeam) {
  SimulatedRigOptions rig_options;
  rig_options.width = kD5100Width / 8;  // 616 x 408, 0.23 mm per pixel: ~10 px per thread
  rig_options.height = kD5100Height / 8;
  const SimulatedRig sim(rig_options, TextileScene(TextileSceneOptions{}),
                         MakeDefaultSimulatedRig(rig_options.width, rig_options.height));
  const GroundTruthMaps truth = sim.RenderGroundTruth();
  TileableCropOptions options;
  options.blend_width_px = 24;
  std::vector<ImageF> tiles;
  const TileableCropSummary summary =
      MakeTileableCrop(options, {{&truth.albedo, TileMapKind::kLinear}, {&truth.normal_in_table, TileMapKind::kNormal},
                        {&truth.height_mm, TileMapKind::kLinear}}, &truth.sample_mask, &tiles);
  ASSERT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  ASSERT_EQ(tiles.size(), 3u);
  EXPECT_EQ(summary.tile_width, 256) << summary.message;
  EXPECT_EQ(summary.tile_height, 256);
  for (int y = summary.y0; y < summary.y0 + 256 + 24; ++y) {
    for (int x = summary.x0; x < summary.x0 + 256 + 24; ++x) {
      ASSERT_NE(truth.sample_mask(x, y), 0) << "off the sample at " << x << "," << y;
    }
  }
  ExpectUnitNormals(tiles[1]);
  // A woven texture has sharp steps at thread edges everywhere: the wrap must
  // look like one of them (no larger than the largest interior step), while a
  // plain crop's wrap is larger than any.
  for (int i = 0; i < 2; ++i) {
    const ImageF& source = i == 0 ? truth.albedo : truth.normal_in_table;
    const SeamFigures blended = MeasureSeams(tiles[i]);
    const SeamFigures naive = MeasureSeams(Crop(source, summary.x0, summary.y0, 256, 256));
    const std::string what = "map " + std::to_string(i) + ": " + summary.message;
    EXPECT_LE(blended.wrap_x, blended.max_step_x) << what;
    EXPECT_LE(blended.wrap_y, blended.max_step_y) << what;
    EXPECT_LT(blended.wrap, 2.0 * blended.neighbour) << what;
    EXPECT_GT(naive.wrap_x, naive.max_step_x) << what;
    EXPECT_GT(naive.wrap_y, naive.max_step_y) << what;
    EXPECT_GT(naive.wrap, 1.5 * blended.wrap) << what;
  }
}

TEST(TileableCrop, BadOptionsAndInputsAreNamed) {
  const ImageF image(64, 64, 3);
  const ImageF other(32, 64, 3);
  const ImageF gray(64, 64, 1);
  const ImageU8 small_mask(10, 10, 1);
  std::vector<ImageF> tiles;
  auto expect_error = [&](const std::vector<TileableMapInput>& maps, const ImageU8* valid,
                          const TileableCropOptions& options, std::vector<ImageF>* out, const std::string& text) {
    try {
      MakeTileableCrop(options, maps, valid, out);
      ADD_FAILURE() << "no error for " << text;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(text));
    }
  };
  TileableCropOptions options;
  options.tile_width = -1;
  expect_error({{&image}}, nullptr, options, &tiles, "TileableCropOptions.tile_width = -1");
  options = {};
  options.tile_height = -2;
  expect_error({{&image}}, nullptr, options, &tiles, "TileableCropOptions.tile_height = -2");
  options = {};
  options.blend_width_px = 0;
  expect_error({{&image}}, nullptr, options, &tiles, "TileableCropOptions.blend_width_px = 0");
  options = {};
  options.tile_width = 16;
  expect_error({{&image}}, nullptr, options, &tiles, "blend_width_px = 32 must be <= tile_width (16)");
  options = {};
  expect_error({}, nullptr, options, &tiles, "no maps");
  expect_error({{nullptr}}, nullptr, options, &tiles, "maps[0] is null");
  expect_error({{&image}, {&other}}, nullptr, options, &tiles, "maps[1] is 32x64, maps[0] is 64x64");
  expect_error({{&gray, TileMapKind::kNormal}}, nullptr, options, &tiles, "maps[0] is a normal map with 1 channels");
  expect_error({{&image}}, &small_mask, options, &tiles, "valid mask is 10x10x1, must be 64x64x1");
  expect_error({{&image}}, nullptr, options, nullptr, "tiles must not be null");
}

TEST(TileableCrop, CancelLeavesNoTiles) {
  const ImageF pattern = PeriodicPattern(200, 150, 5);
  TileableCropOptions options;
  options.tile_width = 64;
  options.blend_width_px = 8;
  for (int allowed_calls : {0, 1}) {  // after the search, after the first map
    int calls = 0;
    std::vector<ImageF> tiles;
    const TileableCropSummary summary =
        MakeTileableCrop(options, {{&pattern, TileMapKind::kLinear}, {&pattern, TileMapKind::kLinear}}, nullptr,
                         &tiles, [&](double) { return calls++ < allowed_calls; });
    EXPECT_EQ(summary.termination, Termination::kCancelled) << allowed_calls;
    EXPECT_TRUE(tiles.empty());
    EXPECT_THAT(summary.BriefReport(), ::testing::HasSubstr("cancelled"));
  }
}

TEST(TileableCrop, ProgressRisesToOneAndBriefReportGivesThePlace) {
  const ImageF pattern = PeriodicPattern(200, 150, 5);
  TileableCropOptions options;
  options.tile_width = 64;
  options.blend_width_px = 8;
  std::vector<double> fractions;
  std::vector<ImageF> tiles;
  const TileableCropSummary summary =
      MakeTileableCrop(options, {{&pattern, TileMapKind::kLinear}}, nullptr, &tiles, [&](double f) {
        fractions.push_back(f);
        return true;
      });
  ASSERT_EQ(summary.termination, Termination::kSuccess) << summary.message;
  ASSERT_FALSE(fractions.empty());
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_EQ(fractions.back(), 1.0);
  EXPECT_THAT(summary.BriefReport(), ::testing::HasSubstr("success, 64x64 at (" + std::to_string(summary.x0) + ", " +
                                                          std::to_string(summary.y0) + ")"));
}

}  // namespace
}  // namespace scanbench
