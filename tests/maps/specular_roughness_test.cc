#include "maps/specular_roughness.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "maps/gloss_mips.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;

constexpr int kWidth = 64, kHeight = 20, kSeam = 30;  // estimated at x < kSeam

// Alpha 0.5 on the estimated left part, 0 (not estimated) on the right.
ImageF LeftEstimated(float alpha = 0.49f) {
  ImageF specular(kWidth, kHeight, 1);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kSeam; ++x) specular(x, y) = alpha;
  return specular;
}

TEST(SpecularRoughnessTest, EstimatesKeptFallbackFarAwayFeatherBetween) {
  SpecularRoughnessOptions options;
  options.blend_width_px = 8;
  const ImageF fallback(kWidth, kHeight, 1, 0.09f);  // sqrt 0.3
  ImageF out;
  const SpecularRoughnessSummary s = BlendSpecularRoughness(options, LeftEstimated(), fallback, nullptr, &out);
  ASSERT_EQ(s.termination, Termination::kSuccess) << s.message;
  EXPECT_EQ(s.from_specular, size_t(kSeam) * kHeight);
  EXPECT_EQ(s.blended, 8u * kHeight);  // d = 1 .. 8
  EXPECT_EQ(s.from_fallback, size_t(kWidth - kSeam - 8) * kHeight);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kSeam; ++x) ASSERT_FLOAT_EQ(out(x, y), 0.49f);
    for (int x = kSeam + 9; x < kWidth; ++x) ASSERT_FLOAT_EQ(out(x, y), 0.09f);
  }
  // In perceptual roughness: 0.7 at the seam falling to 0.3, monotone, with
  // the smoothstep weight at d = 1 .. 8 (w + 1 = 9).
  for (int d = 1; d <= 8; ++d) {
    const double t = 1.0 - d / 9.0, weight = t * t * (3 - 2 * t);
    EXPECT_NEAR(std::sqrt(out(kSeam - 1 + d, 10)), weight * 0.7 + (1 - weight) * 0.3, 1e-5) << d;
    EXPECT_LT(out(kSeam - 1 + d, 10), out(kSeam - 2 + d, 10));
  }
}

TEST(SpecularRoughnessTest, UnsolvedPixelsKeepTheFallbackAndAreNoSource) {
  ImageU8 valid(kWidth, kHeight, 1, 1);
  for (int y = 0; y < kHeight; ++y) valid(kSeam - 1, y) = valid(kSeam + 2, y) = 0;
  const ImageF fallback(kWidth, kHeight, 1, 0.09f);
  ImageF out;
  const SpecularRoughnessSummary s =
      BlendSpecularRoughness(SpecularRoughnessOptions(), LeftEstimated(), fallback, &valid, &out);
  EXPECT_EQ(s.from_specular, size_t(kSeam - 1) * kHeight);
  EXPECT_FLOAT_EQ(out(kSeam - 1, 5), 0.09f);  // an estimate outside the mask is not used
  EXPECT_FLOAT_EQ(out(kSeam + 2, 5), 0.09f);  // nor is an unsolved pixel blended
  EXPECT_GT(out(kSeam, 5), 0.09f);            // d = 2 from the nearest estimate used
  EXPECT_EQ(s.from_specular + s.blended + s.from_fallback, size_t(kWidth - 2) * kHeight);
}

TEST(SpecularRoughnessTest, ZeroWidthIsAHardEdgeAndNoEstimateIsTheFallback) {
  SpecularRoughnessOptions hard;
  hard.blend_width_px = 0;
  const ImageF fallback(kWidth, kHeight, 1, 0.09f);
  ImageF out;
  EXPECT_EQ(BlendSpecularRoughness(hard, LeftEstimated(), fallback, nullptr, &out).blended, 0u);
  EXPECT_FLOAT_EQ(out(kSeam, 3), 0.09f);
  const SpecularRoughnessSummary none =
      BlendSpecularRoughness(SpecularRoughnessOptions(), ImageF(kWidth, kHeight, 1), fallback, nullptr, &out);
  EXPECT_EQ(none.from_specular, 0u);
  EXPECT_EQ(none.from_fallback, size_t(kWidth) * kHeight);
  EXPECT_FLOAT_EQ(out(kSeam, 3), 0.09f);
  // Non-finite fallback values become alpha 1, never NaN.
  ImageF bad = fallback;
  bad(1, 1) = NAN;
  BlendSpecularRoughness(SpecularRoughnessOptions(), LeftEstimated(), bad, nullptr, &out);
  EXPECT_FLOAT_EQ(out(1, 1), 0.49f);  // estimated: the fallback is not used
  bad(50, 1) = NAN;
  const SpecularRoughnessSummary noted = BlendSpecularRoughness(SpecularRoughnessOptions(), LeftEstimated(), bad,
                                                                nullptr, &out);
  EXPECT_FLOAT_EQ(out(50, 1), 1.0f);
  EXPECT_THAT(noted.message, HasSubstr("2 non-finite fallback values"));
}

TEST(SpecularRoughnessTest, BadInputsAreNamed) {
  const ImageF fallback(kWidth, kHeight, 1, 0.09f);
  ImageF out;
  SpecularRoughnessOptions options;
  options.blend_width_px = -1;
  EXPECT_THAT([&] { BlendSpecularRoughness(options, LeftEstimated(), fallback, nullptr, &out); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("blend_width_px")));
  EXPECT_THAT([&] { BlendSpecularRoughness({}, LeftEstimated(), ImageF(3, 3, 1), nullptr, &out); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("fallback_alpha is 3x3x1, must be 64x20x1")));
  EXPECT_THAT([&] { BlendSpecularRoughness({}, LeftEstimated(), fallback, nullptr, nullptr); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("roughness_alpha must not be null")));
}

}  // namespace
}  // namespace scanbench
