#include "maps/normal_flattening.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/format.h"
#include "core/field_error.h"

namespace scanbench {
namespace {

constexpr const char* kWhere = "NormalFlatteningOptions";

// The low-pass is computed on a grid this many times coarser than sigma, so a
// large sigma costs no more than a small one (see LowPassFactor).
constexpr double kCoarseSigmaPx = 8.0;

// Integer reduction factor for the low-pass: the Gaussian is then at least
// kCoarseSigmaPx coarse pixels wide, well sampled, and the area-average
// downsampling and bilinear upsampling add only ~0.4% of its variance (which
// is subtracted from the coarse sigma). Below 16 px it blurs at full size.
int LowPassFactor(double sigma_px) { return std::max(1, static_cast<int>(std::floor(sigma_px / kCoarseSigmaPx))); }

}  // namespace

void NormalFlatteningOptions::Check() const {
  if (!(low_pass_sigma_px > 0) || !std::isfinite(low_pass_sigma_px)) {
    throw FieldError(kWhere, "low_pass_sigma_px", low_pass_sigma_px, "must be finite and > 0");
  }
  if (!(max_slope > 0) || !std::isfinite(max_slope)) {
    throw FieldError(kWhere, "max_slope", max_slope, "must be finite and > 0");
  }
}

ImageF FlattenNormals(const ImageF& normal_in_tangent, const ImageU8* valid, const NormalFlatteningOptions& options,
                      NormalFlatteningSummary* summary, const ProgressCallback& progress) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  if (normal_in_tangent.empty() || normal_in_tangent.channels() != 3) {
    throw std::invalid_argument("FlattenNormals: normal_in_tangent is " + std::to_string(normal_in_tangent.width()) +
                                "x" + std::to_string(normal_in_tangent.height()) + "x" +
                                std::to_string(normal_in_tangent.channels()) + ", must be a non-empty 3-channel image");
  }
  if (valid != nullptr && (!valid->SameSize(normal_in_tangent) || valid->channels() != 1)) {
    throw std::invalid_argument(
        "FlattenNormals: valid mask is " + std::to_string(valid->width()) + "x" + std::to_string(valid->height()) +
        "x" + std::to_string(valid->channels()) + ", must be 1 channel of the normal map's size " +
        std::to_string(normal_in_tangent.width()) + "x" + std::to_string(normal_in_tangent.height()));
  }
  NormalFlatteningSummary local_summary;
  NormalFlatteningSummary& result = summary != nullptr ? *summary : local_summary;
  result = NormalFlatteningSummary();

  const int width = normal_in_tangent.width(), height = normal_in_tangent.height();
  const float max_slope = static_cast<float>(options.max_slope);

  // Slopes weighted by validity: (w dz/dx, w dz/dy, w), y up as in the tangent frame.
  cv::Mat weighted(height, width, CV_32FC3);
  size_t valid_count = 0;
  for (int y = 0; y < height; ++y) {
    const float* n = normal_in_tangent.row(y);
    cv::Vec3f* out = weighted.ptr<cv::Vec3f>(y);
    for (int x = 0; x < width; ++x, n += 3) {
      const bool wanted = valid == nullptr || (*valid)(x, y) != 0;
      const bool usable = std::isfinite(n[0]) && std::isfinite(n[1]) && std::isfinite(n[2]) &&
                          n[0] * n[0] + n[1] * n[1] + n[2] * n[2] > 1e-12f;
      if (!wanted || !usable) {
        out[x] = cv::Vec3f(0, 0, 0);
        continue;
      }
      const float nz = std::max(n[2], 1e-6f);  // grazing or back-facing: clamp rather than divide by ~0
      out[x] =
          cv::Vec3f(std::clamp(-n[0] / nz, -max_slope, max_slope), std::clamp(-n[1] / nz, -max_slope, max_slope), 1.0f);
      ++valid_count;
    }
  }
  result.valid_pixels = valid_count;

  // Output where nothing is removed: the input's valid normals, re-normalised; (0, 0, 1) elsewhere.
  auto write_normals = [&](const cv::Mat* low_pass) {
    ImageF out(width, height, 3);
    double tilt_sum = 0, tilt_max = 0;
    for (int y = 0; y < height; ++y) {
      const cv::Vec3f* s = weighted.ptr<cv::Vec3f>(y);
      const cv::Vec3f* lp = low_pass != nullptr ? low_pass->ptr<cv::Vec3f>(y) : nullptr;
      float* o = out.row(y);
      for (int x = 0; x < width; ++x, o += 3) {
        if (s[x][2] == 0) {
          o[0] = 0, o[1] = 0, o[2] = 1;
          continue;
        }
        float p = s[x][0], q = s[x][1];
        if (lp != nullptr && lp[x][2] > 0) {
          const float removed_p = lp[x][0] / lp[x][2], removed_q = lp[x][1] / lp[x][2];
          p -= removed_p;
          q -= removed_q;
          const double tilt = std::atan(std::hypot(removed_p, removed_q));
          tilt_sum += tilt;
          tilt_max = std::max(tilt_max, tilt);
        }
        const float inverse_length = 1.0f / std::sqrt(p * p + q * q + 1.0f);
        o[0] = -p * inverse_length, o[1] = -q * inverse_length, o[2] = inverse_length;
      }
    }
    constexpr double kDeg = 180.0 / std::numbers::pi;
    result.mean_removed_tilt_deg = valid_count > 0 ? tilt_sum / static_cast<double>(valid_count) * kDeg : 0.0;
    result.max_removed_tilt_deg = tilt_max * kDeg;
    return out;
  };
  auto finish = [&](Termination termination, const std::string& message) {
    result.termination = termination;
    result.seconds = SecondsSince(start);
    char figures[200];
    std::snprintf(figures, sizeof(figures),
                  "%zu of %zu pixels valid, sigma %.1f px, removed tilt mean %.3f deg, max %.3f deg, %.2f s",
                  valid_count, static_cast<size_t>(width) * height, options.low_pass_sigma_px,
                  result.mean_removed_tilt_deg, result.max_removed_tilt_deg, result.seconds);
    result.message = message + figures;
  };

  if (valid_count == 0) {
    ImageF out = write_normals(nullptr);
    finish(Termination::kFailure, "no valid pixel with a finite normal, nothing flattened: ");
    return out;
  }
  if (progress && !progress(0.3)) {
    ImageF out = write_normals(nullptr);
    finish(Termination::kCancelled, "cancelled before the low-pass, normals unchanged: ");
    return out;
  }

  // Normalised convolution: blur(w s) / blur(w), zero outside the image so the
  // edges are averaged over what exists. Large sigmas are blurred on an
  // area-averaged grid f times coarser and upsampled bilinearly: the low-pass
  // holds nothing the coarse grid cannot carry, and the cost per pixel no
  // longer grows with sigma (a 48 px sigma at full size is a 289-tap kernel).
  const double sigma = options.low_pass_sigma_px;
  const int factor = LowPassFactor(sigma);
  cv::Mat low_pass;
  if (factor == 1) {
    cv::GaussianBlur(weighted, low_pass, cv::Size(0, 0), sigma, sigma, cv::BORDER_CONSTANT);
  } else {
    const double f = factor;
    const cv::Size coarse_size((width + factor - 1) / factor, (height + factor - 1) / factor);
    cv::Mat coarse;
    cv::resize(weighted, coarse, coarse_size, 0, 0, cv::INTER_AREA);
    // Box of f px (variance (f^2 - 1) / 12) and bilinear tent (f^2 / 6) are part of the low-pass.
    const double coarse_variance = (sigma * sigma - (f * f - 1) / 12.0 - f * f / 6.0) / (f * f);
    const double coarse_sigma = std::sqrt(std::max(coarse_variance, 0.25));
    cv::GaussianBlur(coarse, coarse, cv::Size(0, 0), coarse_sigma, coarse_sigma, cv::BORDER_CONSTANT);
    cv::resize(coarse, low_pass, weighted.size(), 0, 0, cv::INTER_LINEAR);
  }
  if (progress && !progress(0.7)) {
    ImageF out = write_normals(nullptr);
    finish(Termination::kCancelled, "cancelled after the low-pass, normals unchanged: ");
    return out;
  }
  ImageF out = write_normals(&low_pass);
  finish(Termination::kSuccess, "");
  if (progress) progress(1.0);
  return out;
}

}  // namespace scanbench
