#include "maps/specular_roughness.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

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

// The blend as first written, over the whole image (the distance transform and
// the window sums full-size): the reference the region-bounded form must equal
// bit for bit.
ImageF WholeImageBlend(int w, const ImageF& specular, const ImageF& fallback_alpha, const ImageU8* valid) {
  const int width = specular.width(), height = specular.height();
  auto is_valid = [&](int x, int y) { return valid == nullptr || (*valid)(x, y) != 0; };
  auto estimated = [&](int x, int y) {
    return is_valid(x, y) && std::isfinite(specular(x, y)) && specular(x, y) > 0.0f;
  };
  cv::Mat r_sum(height, width, CV_64F, cv::Scalar(0)), count(height, width, CV_64F, cv::Scalar(0));
  cv::Mat not_estimated(height, width, CV_8U, cv::Scalar(1));
  size_t any = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (!estimated(x, y)) continue;
      r_sum.at<double>(y, x) = std::sqrt(std::clamp(double(specular(x, y)), kMinGgxAlpha, 1.0));
      count.at<double>(y, x) = 1;
      not_estimated.at<uint8_t>(y, x) = 0;
      ++any;
    }
  }
  cv::Mat distance;
  if (any > 0 && w > 0) {
    cv::distanceTransform(not_estimated, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
    const cv::Size window(2 * w + 1, 2 * w + 1);
    cv::boxFilter(r_sum, r_sum, CV_64F, window, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
    cv::boxFilter(count, count, CV_64F, window, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
  }
  ImageF out(width, height, 1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double fallback = fallback_alpha(x, y);
      if (!std::isfinite(fallback)) fallback = 1.0;
      fallback = std::clamp(fallback, kMinGgxAlpha, 1.0);
      double alpha = fallback;
      if (estimated(x, y)) {
        alpha = std::clamp(double(specular(x, y)), kMinGgxAlpha, 1.0);
      } else if (is_valid(x, y) && !distance.empty() && distance.at<float>(y, x) <= w &&
                 count.at<double>(y, x) > 0.5) {
        const double t = std::clamp(1.0 - distance.at<float>(y, x) / (w + 1.0), 0.0, 1.0);
        const double weight = t * t * (3.0 - 2.0 * t);
        const double r = weight * (r_sum.at<double>(y, x) / count.at<double>(y, x)) +
                         (1.0 - weight) * std::sqrt(fallback);
        alpha = std::clamp(r * r, kMinGgxAlpha, 1.0);
      }
      out(x, y) = static_cast<float>(alpha);
    }
  }
  return out;
}

// Only the region around the estimates is transformed and window-summed; the
// map is the whole-image form's, bit for bit: a few estimates, clusters of
// them, estimates at the edges and corners, with and without a valid mask,
// at several feather widths (fixed seeds).
TEST(SpecularRoughnessTest, RegionAroundTheEstimatesEqualsTheWholeImageForm) {
  constexpr int kW = 301, kH = 207;
  std::mt19937 rng(20261203);
  std::uniform_real_distribution<float> alpha(0.02f, 0.9f), fallback_value(0.05f, 0.6f);
  for (int pattern = 0; pattern < 5; ++pattern) {
    ImageF specular(kW, kH, 1, 0.0f);
    if (pattern == 0) specular(150, 100) = alpha(rng);  // a single estimate (the 16 MP solve's case)
    if (pattern == 1) {                                   // a cluster
      for (int y = 60; y < 90; ++y)
        for (int x = 100; x < 170; ++x)
          if (rng() % 3 == 0) specular(x, y) = alpha(rng);
    }
    if (pattern == 2) {  // at the corners and edges
      specular(0, 0) = alpha(rng), specular(kW - 1, kH - 1) = alpha(rng), specular(kW - 1, 3) = alpha(rng);
      specular(5, kH - 1) = alpha(rng);
    }
    if (pattern == 3) {  // scattered over the whole image
      for (int i = 0; i < 400; ++i) specular(static_cast<int>(rng() % kW), static_cast<int>(rng() % kH)) = alpha(rng);
    }
    if (pattern == 4) {  // two far apart, one not finite (not estimated)
      specular(20, 30) = alpha(rng), specular(250, 180) = alpha(rng), specular(120, 120) = NAN;
    }
    ImageF fallback(kW, kH, 1);
    for (size_t i = 0; i < fallback.size(); ++i) fallback.data()[i] = fallback_value(rng);
    ImageU8 valid(kW, kH, 1, 1);
    for (size_t i = 0; i < valid.size(); ++i) valid.data()[i] = rng() % 10 != 0;
    for (const int w : {1, 3, 8, 24}) {
      for (const ImageU8* mask : {static_cast<const ImageU8*>(nullptr), static_cast<const ImageU8*>(&valid)}) {
        SpecularRoughnessOptions options;
        options.blend_width_px = w;
        ImageF out;
        const SpecularRoughnessSummary s = BlendSpecularRoughness(options, specular, fallback, mask, &out);
        ASSERT_EQ(s.termination, Termination::kSuccess) << s.message;
        const ImageF expected = WholeImageBlend(w, specular, fallback, mask);
        ASSERT_TRUE(out.SameSize(expected));
        size_t differing = 0;
        for (size_t i = 0; i < out.size(); ++i) differing += std::memcmp(&out.data()[i], &expected.data()[i], 4) != 0;
        EXPECT_EQ(differing, 0u) << "pattern " << pattern << ", w " << w << (mask ? ", masked" : "");
        if (pattern != 4 || mask == nullptr) {
          EXPECT_GT(s.blended, 0u) << "pattern " << pattern << ", w " << w;
        }
      }
    }
  }
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
