#include "maps/specular_roughness.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/field_error.h"
#include "core/format.h"
#include "maps/gloss_mips.h"

namespace scanbench {
namespace {

template <typename T>
void CheckMap(const Image<T>& image, const ImageF& reference, const char* name) {
  if (!image.SameSize(reference) || image.channels() != 1) {
    throw std::invalid_argument(std::string("specular roughness: ") + name + " is " + ShapeText(image) +
                                ", must be " + SizeText(reference.width(), reference.height()) + "x1");
  }
}

double Smoothstep(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

}  // namespace

void SpecularRoughnessOptions::Check() const {
  SCANBENCH_REQUIRE_GE_LE("SpecularRoughnessOptions", "blend_width_px", blend_width_px, 0, 256,
                          "(pixels; 0 = a hard edge)");
}

std::string SpecularRoughnessSummary::BriefReport() const {
  std::string report = "Specular roughness: " + std::string(TerminationName(termination)) + ", " +
                       std::to_string(from_specular) + " px from the specular map, " + std::to_string(blended) +
                       " blended, " + std::to_string(from_fallback) + " from the fallback, " + Significant(seconds) +
                       " s";
  if (termination != Termination::kSuccess && !message.empty()) report += " (" + message + ")";
  return report;
}

SpecularRoughnessSummary BlendSpecularRoughness(const SpecularRoughnessOptions& options, const ImageF& specular_alpha,
                                                const ImageF& fallback_alpha, const ImageU8* valid,
                                                ImageF* roughness_alpha, const ProgressCallback& progress) {
  const auto start = std::chrono::steady_clock::now();
  options.Check();
  if (specular_alpha.empty() || specular_alpha.channels() != 1) {
    throw std::invalid_argument("specular roughness: specular_alpha is " + ShapeText(specular_alpha) +
                                ", must be non-empty with 1 channel");
  }
  CheckMap(fallback_alpha, specular_alpha, "fallback_alpha");
  if (valid != nullptr) CheckMap(*valid, specular_alpha, "valid mask");
  if (roughness_alpha == nullptr) throw std::invalid_argument("specular roughness: roughness_alpha must not be null");

  const int width = specular_alpha.width(), height = specular_alpha.height();
  const int w = options.blend_width_px;
  auto is_valid = [&](int x, int y) { return valid == nullptr || (*valid)(x, y) != 0; };
  auto estimated = [&](int x, int y) {
    const float a = specular_alpha(x, y);
    return is_valid(x, y) && std::isfinite(a) && a > 0.0f;
  };
  // The estimates' bounding box grown by w: the feather lies within it.
  // Outside it nothing is blended, so the distance transform and the window
  // sums run on it alone (at 16 MP a solve estimates a lobe on a few pixels:
  // full-size, they were two 128 MB double maps, a distance transform and two
  // box filters over the whole image). Its values are the whole image's, bit
  // for bit: every estimate (the distance transform's only zeros) lies
  // inside, beyond the box the estimate maps are zero as the box filter's
  // constant border is, and the running window sums stay exactly 0 over the
  // all-zero rows and columns before it (tested against the whole-image form).
  int x_min = width, y_min = height, x_max = -1, y_max = -1;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (!estimated(x, y)) continue;
      x_min = std::min(x_min, x), x_max = std::max(x_max, x);
      y_min = std::min(y_min, y), y_max = std::max(y_max, y);
    }
  }
  const bool any_estimated = x_max >= 0;
  cv::Rect region;  // in the image; empty without estimates or feather
  if (any_estimated && w > 0) {
    const int rx0 = std::max(0, x_min - w), ry0 = std::max(0, y_min - w);
    const int rx1 = std::min(width, x_max + w + 1), ry1 = std::min(height, y_max + w + 1);
    region = cv::Rect(rx0, ry0, rx1 - rx0, ry1 - ry0);
  }
  // Perceptual roughness of the estimates (0 elsewhere) and their indicator, over the region.
  cv::Mat r_sum(region.height, region.width, CV_64F, cv::Scalar(0));
  cv::Mat count(region.height, region.width, CV_64F, cv::Scalar(0));
  cv::Mat not_estimated(region.height, region.width, CV_8U, cv::Scalar(1));
  cv::Mat distance;  // to the nearest estimated pixel, pixels (Euclidean), over the region
  if (!region.empty()) {
    for (int y = region.y; y < region.y + region.height; ++y) {
      for (int x = region.x; x < region.x + region.width; ++x) {
        if (!estimated(x, y)) continue;
        r_sum.at<double>(y - region.y, x - region.x) =
            std::sqrt(std::clamp(double(specular_alpha(x, y)), kMinGgxAlpha, 1.0));
        count.at<double>(y - region.y, x - region.x) = 1;
        not_estimated.at<uint8_t>(y - region.y, x - region.x) = 0;
      }
    }
    cv::distanceTransform(not_estimated, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
    // Window sums of both: their ratio is the mean r of the estimates nearby.
    const cv::Size window(2 * w + 1, 2 * w + 1);
    cv::boxFilter(r_sum, r_sum, CV_64F, window, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
    cv::boxFilter(count, count, CV_64F, window, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
  }
  SpecularRoughnessSummary s;
  if (progress && !progress(0.5)) {
    s.SetCancelled("specular roughness cancelled by the progress callback after the distance transform");
    s.seconds = SecondsSince(start);
    return s;
  }

  ImageF out(width, height, 1);
  size_t bad_fallback = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double fallback = fallback_alpha(x, y);
      if (!std::isfinite(fallback)) {
        fallback = 1.0;
        ++bad_fallback;
      }
      fallback = std::clamp(fallback, kMinGgxAlpha, 1.0);
      double alpha = fallback;
      const bool in_region = region.contains(cv::Point(x, y));
      const int ry = y - region.y, rx = x - region.x;
      if (estimated(x, y)) {
        alpha = std::clamp(double(specular_alpha(x, y)), kMinGgxAlpha, 1.0);
        ++s.from_specular;
      } else if (is_valid(x, y) && in_region && distance.at<float>(ry, rx) <= w && count.at<double>(ry, rx) > 0.5) {
        const double weight = Smoothstep(1.0 - distance.at<float>(ry, rx) / (w + 1.0));
        const double r = weight * (r_sum.at<double>(ry, rx) / count.at<double>(ry, rx)) +
                         (1.0 - weight) * std::sqrt(fallback);
        alpha = std::clamp(r * r, kMinGgxAlpha, 1.0);
        ++s.blended;
      } else if (is_valid(x, y)) {
        ++s.from_fallback;
      }
      out(x, y) = static_cast<float>(alpha);
    }
  }
  *roughness_alpha = std::move(out);
  s.termination = Termination::kSuccess;
  s.message = std::to_string(s.from_specular) + " px from the specular map, " + std::to_string(s.blended) +
              " blended over " + std::to_string(w) + " px, " + std::to_string(s.from_fallback) + " from the fallback";
  if (bad_fallback > 0) s.message += "; " + std::to_string(bad_fallback) + " non-finite fallback values taken as 1";
  s.seconds = SecondsSince(start);
  return s;
}

}  // namespace scanbench
