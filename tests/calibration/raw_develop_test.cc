#include "calibration/raw_develop.h"

#include <cstring>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace scanbench {
namespace {

// A flat colour: every site reads black + value[colour] * (white - black).
RawImage FlatMosaic(CfaPattern cfa, const std::array<double, 3>& value, uint16_t black = 600) {
  RawImage raw;
  raw.mosaic = ImageU16(16, 12, 1);
  raw.cfa = cfa;
  raw.black_level = {black, black, black, black};
  raw.white_level = 16383;
  for (int y = 0; y < 12; ++y) {
    for (int x = 0; x < 16; ++x) {
      raw.mosaic(x, y) = static_cast<uint16_t>(black + value[CfaColorAt(cfa, x, y)] * (16383 - black) + 0.5);
    }
  }
  return raw;
}

class RawDevelopCfaTest : public ::testing::TestWithParam<CfaPattern> {};

TEST_P(RawDevelopCfaTest, FlatColourDevelopsToItsValuesInEveryLayout) {
  const std::array<double, 3> colour = {0.2, 0.5, 0.8};
  for (auto demosaic : {RawDevelopOptions::Demosaic::kBilinear, RawDevelopOptions::Demosaic::kEdgeAware}) {
    RawDevelopOptions options;
    options.demosaic = demosaic;
    const DevelopedFrame developed = DevelopRaw(FlatMosaic(GetParam(), colour), nullptr, options);
    for (int y = 2; y < 10; ++y) {
      for (int x = 2; x < 14; ++x) {
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(developed.rgb(x, y, c), colour[c], 1e-4) << x << "," << y << " c" << c;
        ASSERT_EQ(developed.valid(x, y), 1);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllLayouts, RawDevelopCfaTest,
                         ::testing::Values(CfaPattern::kRGGB, CfaPattern::kBGGR, CfaPattern::kGRBG,
                                           CfaPattern::kGBRG),
                         [](const ::testing::TestParamInfo<CfaPattern>& param_info) {
                           return CfaPatternName(param_info.param);
                         });

TEST(RawDevelopTest, DarkFrameIsSubtractedSampleBySample) {
  RawImage frame = FlatMosaic(CfaPattern::kRGGB, {0.3, 0.3, 0.3});
  RawImage dark = FlatMosaic(CfaPattern::kRGGB, {0.0, 0.0, 0.0});
  // An ambient glow and a hot pixel in both frames vanish.
  for (int y = 0; y < 12; ++y) {
    for (int x = 0; x < 16; ++x) {
      frame.mosaic(x, y) += 50;
      dark.mosaic(x, y) += 50;
    }
  }
  frame.mosaic(7, 7) += 3000;
  dark.mosaic(7, 7) += 3000;
  const DevelopedFrame developed = DevelopRaw(frame, &dark, RawDevelopOptions());
  for (int y = 1; y < 11; ++y) {
    for (int x = 1; x < 15; ++x) ASSERT_NEAR(developed.rgb(x, y, 1), 0.3, 1e-4);
  }
  // Without the dark frame only the black level goes.
  const DevelopedFrame no_dark = DevelopRaw(frame, nullptr, RawDevelopOptions());
  EXPECT_NEAR(no_dark.rgb(4, 4, 1), 0.3 + 50.0 / (16383 - 600), 1e-4);
}

TEST(RawDevelopTest, NoiseBelowTheDarkLevelStaysNegative) {
  RawImage frame = FlatMosaic(CfaPattern::kRGGB, {0, 0, 0});
  frame.mosaic(6, 6) -= 20;  // a red site read below black by noise
  const DevelopedFrame developed = DevelopRaw(frame, nullptr, RawDevelopOptions());
  EXPECT_NEAR(developed.rgb(6, 6, 0), -20.0 / (16383 - 600), 1e-6);
}

TEST(RawDevelopTest, ClippedSamplesInvalidateTheirNeighbourhood) {
  RawImage frame = FlatMosaic(CfaPattern::kRGGB, {0.5, 0.5, 0.5});
  frame.mosaic(8, 6) = 16383;
  const DevelopedFrame developed = DevelopRaw(frame, nullptr, RawDevelopOptions());
  EXPECT_EQ(developed.num_clipped_samples, 1u);
  for (int y = 5; y <= 7; ++y) {
    for (int x = 7; x <= 9; ++x) EXPECT_EQ(developed.valid(x, y), 0) << x << "," << y;
  }
  EXPECT_EQ(developed.valid(10, 6), 1);
  EXPECT_EQ(developed.valid(8, 8), 1);
}

TEST(RawDevelopTest, KeptMosaicHoldsEachSampleAndOnlyItsOwnClipping) {
  const std::array<double, 3> colour = {0.2, 0.5, 0.8};
  RawImage frame = FlatMosaic(CfaPattern::kGBRG, colour);
  RawImage dark = FlatMosaic(CfaPattern::kGBRG, {0, 0, 0});
  dark.mosaic(3, 4) += 40;  // a warm site: subtracted from that sample only
  frame.mosaic(3, 4) += 40;
  frame.mosaic(8, 6) = 16383;
  RawDevelopOptions options;
  EXPECT_TRUE(DevelopRaw(frame, &dark, options).mosaic.empty());
  options.keep_mosaic = true;
  const DevelopedFrame developed = DevelopRaw(frame, &dark, options);
  ASSERT_EQ(developed.mosaic.width(), 16);
  ASSERT_EQ(developed.mosaic.channels(), 1);
  for (int y = 0; y < 12; ++y) {
    for (int x = 0; x < 16; ++x) {
      if (x == 8 && y == 6) continue;
      ASSERT_NEAR(developed.mosaic(x, y), colour[CfaColorAt(CfaPattern::kGBRG, x, y)], 1e-4) << x << "," << y;
      ASSERT_EQ(developed.mosaic_valid(x, y), 1) << x << "," << y;
    }
  }
  EXPECT_EQ(developed.mosaic_valid(8, 6), 0);
  EXPECT_EQ(developed.valid(9, 6), 0);  // the demosaiced pixel next to it reads the clipped sample
}

TEST(RawDevelopTest, MismatchedDarkFrameAndBadOptionsAreRejected) {
  const RawImage frame = FlatMosaic(CfaPattern::kRGGB, {0.5, 0.5, 0.5});
  const RawImage dark = FlatMosaic(CfaPattern::kBGGR, {0, 0, 0});
  EXPECT_THAT([&] { DevelopRaw(frame, &dark, RawDevelopOptions()); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("does not match")));
  RawDevelopOptions options;
  options.clip_fraction = 1.5;
  EXPECT_THAT([&] { DevelopRaw(frame, nullptr, options); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("clip_fraction = 1.5")));
}

// Noise, an edge and clipped samples: what the demosaic's and the clip
// dilation's reach across a band border would show.
RawImage TexturedMosaic(CfaPattern cfa, int width, int height, uint32_t seed) {
  RawImage raw;
  raw.mosaic = ImageU16(width, height, 1);
  raw.cfa = cfa;
  raw.black_level = {600, 601, 599, 600};
  raw.white_level = 16383;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> value(500, 16383);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) raw.mosaic(x, y) = static_cast<uint16_t>(x < width / 3 ? 4000 : value(rng));
  }
  return raw;
}

TEST(RawDevelopTest, RowBandsEqualTheFullFrameBitForBit) {
  for (const CfaPattern cfa : {CfaPattern::kRGGB, CfaPattern::kGBRG}) {
    const RawImage frame = TexturedMosaic(cfa, 37, 61, 7);
    const RawImage dark = TexturedMosaic(cfa, 37, 61, 8);
    for (auto demosaic : {RawDevelopOptions::Demosaic::kBilinear, RawDevelopOptions::Demosaic::kEdgeAware}) {
      RawDevelopOptions options;
      options.demosaic = demosaic;
      const DevelopedFrame whole = DevelopRaw(frame, &dark, options);
      size_t clipped = 0;
      // Odd and even starts, bands at the top and bottom edges, a one-row band.
      const std::vector<std::pair<int, int>> bands = {{0, 5}, {5, 16}, {16, 17}, {17, 40}, {40, 61}};
      for (const auto& [begin, end] : bands) {
        const DevelopedFrame band = DevelopRawRows(frame, &dark, options, begin, end);
        ASSERT_EQ(band.rgb.height(), end - begin);
        clipped += band.num_clipped_samples;
        for (int y = begin; y < end; ++y) {
          ASSERT_EQ(std::memcmp(band.rgb.row(y - begin), whole.rgb.row(y), sizeof(float) * 3 * 37), 0)
              << CfaPatternName(cfa) << " row " << y;
          ASSERT_EQ(std::memcmp(band.valid.row(y - begin), whole.valid.row(y), 37), 0) << "row " << y;
        }
      }
      EXPECT_GT(whole.num_clipped_samples, 0u);
      EXPECT_EQ(clipped, whole.num_clipped_samples);
    }
  }
  const RawImage frame = TexturedMosaic(CfaPattern::kRGGB, 8, 8, 1);
  EXPECT_THAT([&] { DevelopRawRows(frame, nullptr, RawDevelopOptions(), 4, 9); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("rows [4, 9)")));
}

}  // namespace
}  // namespace scanbench
