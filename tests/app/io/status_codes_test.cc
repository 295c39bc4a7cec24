// status.png's code table (app/io/status_codes.h): every code named once, the
// solved codes in greens apart from every failure colour, and the headline's
// percentage never rounds a failure up to 100 %.
#include "app/io/status_codes.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace scanbench {
namespace {

TEST(StatusCodesTest, EveryCodeHasItsOwnNameAndColour) {
  std::set<std::string> names;
  std::set<uint32_t> colours;
  for (int code = 0; code < kNumStatusPngCodes; ++code) {
    const StatusCodeInfo& info = StatusCodes()[code];
    EXPECT_EQ(info.code, code);
    EXPECT_FALSE(std::string(info.name).empty()) << code;
    EXPECT_FALSE(std::string(info.meaning).empty()) << code;
    names.insert(info.name);
    colours.insert(uint32_t(info.r) << 16 | uint32_t(info.g) << 8 | info.b);
  }
  EXPECT_EQ(names.size(), size_t(kNumStatusPngCodes));
  EXPECT_EQ(colours.size(), size_t(kNumStatusPngCodes));
  EXPECT_STREQ(StatusCodeOf(200).name, "invalid input");
  EXPECT_STREQ(StatusCodeOf(-1).name, "invalid input");
}

// Issue #36: a fully solved result whose specular lobe is mostly unsupported
// (code 7) must read as solved: both solved codes are green (green the
// largest channel by a margin), no failure code is.
TEST(StatusCodesTest, SolvedCodesAreGreenAndNoOtherIs) {
  for (const StatusCodeInfo& info : StatusCodes()) {
    const bool green = info.g > info.r + 40 && info.g > info.b + 40;
    EXPECT_EQ(green, info.solved) << info.name;
  }
  EXPECT_TRUE(StatusCodeOf(0).solved);
  EXPECT_TRUE(StatusCodeOf(kStatusSolvedSpecularUnsupported).solved);
}

TEST(StatusCodesTest, CountsAndHeadline) {
  ImageU8 status(10, 2, 1, 7);  // all solved, no specular lobe
  status(0, 0) = 0;
  status(1, 0) = 1;  // outside the region: not part of the share
  StatusCounts counts = CountStatusCodes(status);
  EXPECT_EQ(counts.total, 20u);
  EXPECT_EQ(counts.in_region(), 19u);
  EXPECT_EQ(counts.solved(), 19u);
  EXPECT_DOUBLE_EQ(counts.SolvedFraction(), 1.0);
  EXPECT_EQ(counts.Headline(), "100 % solved (19 of 19 px in the region)");
  status(2, 0) = 2;
  status(3, 0) = 4;
  status(4, 0) = 250;  // unknown: invalid input
  counts = CountStatusCodes(status);
  EXPECT_EQ(counts.Headline(),
            "84.2 % solved (16 of 19 px in the region); 3 px unsolved: 1 too few lights, 1 no signal, 1 invalid input");
}

TEST(StatusCodesTest, PercentNeverRoundsUpToHundred) {
  EXPECT_EQ(FlooredPercentText(9999, 10000), "99.9 %");
  EXPECT_EQ(FlooredPercentText(10000, 10000), "100 %");
  EXPECT_EQ(FlooredPercentText(1, 3), "33.3 %");
  EXPECT_EQ(FlooredPercentText(0, 0), "100 %");
}

}  // namespace
}  // namespace scanbench
