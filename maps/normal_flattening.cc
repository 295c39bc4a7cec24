#include "maps/normal_flattening.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"

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

void CheckInputs(const ImageF& normal_in_tangent, const ImageU8* valid, const ImageF* flat_normal_in_tangent) {
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
  if (flat_normal_in_tangent == nullptr) {
    throw std::invalid_argument("FlattenNormals: flat_normal_in_tangent must not be null");
  }
}

// Slopes weighted by validity, (w dz/dx, w dz/dy, w) with y up as in the
// tangent frame; w = 0 for pixels left out.
struct WeightedSlopes {
  cv::Mat slopes;  // CV_32FC3
  size_t valid_count = 0;
};

WeightedSlopes WeightSlopes(const ImageF& normal_in_tangent, const ImageU8* valid, float max_slope, int num_threads) {
  const int width = normal_in_tangent.width(), height = normal_in_tangent.height();
  WeightedSlopes weighted{cv::Mat(height, width, CV_32FC3), 0};
  std::vector<size_t> row_counts(height, 0);
  ParallelRows(height, num_threads, {}, 0, 1, [&](int y) {
    const float* n = normal_in_tangent.row(y);
    cv::Vec3f* out = weighted.slopes.ptr<cv::Vec3f>(y);
    size_t count = 0;
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
      ++count;
    }
    row_counts[y] = count;
  });
  for (size_t count : row_counts) weighted.valid_count += count;
  return weighted;
}

// Normalised convolution: blur(w s) / blur(w), zero outside the image so the
// edges are averaged over what exists (the division happens in RemoveLowPass).
// Large sigmas are blurred on an area-averaged grid f times coarser and
// upsampled bilinearly: the low-pass holds nothing the coarse grid cannot
// carry, and the cost per pixel no longer grows with sigma (a 48 px sigma at
// full size is a 289-tap kernel).
cv::Mat LowPass(const cv::Mat& weighted_slopes, double sigma) {
  const int factor = LowPassFactor(sigma);
  cv::Mat low_pass;
  if (factor == 1) {
    cv::GaussianBlur(weighted_slopes, low_pass, cv::Size(0, 0), sigma, sigma, cv::BORDER_CONSTANT);
    return low_pass;
  }
  const double f = factor;
  const cv::Size coarse_size((weighted_slopes.cols + factor - 1) / factor,
                             (weighted_slopes.rows + factor - 1) / factor);
  cv::Mat coarse;
  cv::resize(weighted_slopes, coarse, coarse_size, 0, 0, cv::INTER_AREA);
  // Box of f px (variance (f^2 - 1) / 12) and bilinear tent (f^2 / 6) are part of the low-pass.
  const double coarse_variance = (sigma * sigma - (f * f - 1) / 12.0 - f * f / 6.0) / (f * f);
  const double coarse_sigma = std::sqrt(std::max(coarse_variance, 0.25));
  cv::GaussianBlur(coarse, coarse, cv::Size(0, 0), coarse_sigma, coarse_sigma, cv::BORDER_CONSTANT);
  cv::resize(coarse, low_pass, weighted_slopes.size(), 0, 0, cv::INTER_LINEAR);
  return low_pass;
}

// The output normals: the valid pixels' slopes minus the low-pass (none when
// `low_pass` is null: the input re-normalised), (0, 0, 1) elsewhere. Fills the
// summary's removed-tilt figures. The pixels of a band of rows run in
// parallel, each keeping its removed tilts; they are summed in pixel order
// after the band, so the figures are a sequential loop's whatever the thread
// count.
ImageF RemoveLowPass(const WeightedSlopes& weighted, const cv::Mat* low_pass, int num_threads,
                     NormalFlatteningSummary* summary) {
  const int width = weighted.slopes.cols, height = weighted.slopes.rows;
  ImageF out(width, height, 3);
  constexpr int kBandRows = 128;
  std::vector<std::vector<double>> band_tilts(std::min(kBandRows, height));
  double tilt_sum = 0, tilt_max = 0;
  for (int y_begin = 0; y_begin < height; y_begin += kBandRows) {
    const int rows = std::min(kBandRows, height - y_begin);
    ParallelRows(rows, num_threads, {}, 0, 1, [&](int r) {
      const int y = y_begin + r;
      const cv::Vec3f* s = weighted.slopes.ptr<cv::Vec3f>(y);
      const cv::Vec3f* lp = low_pass != nullptr ? low_pass->ptr<cv::Vec3f>(y) : nullptr;
      std::vector<double>& tilts = band_tilts[r];
      tilts.clear();
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
          tilts.push_back(std::atan(std::hypot(removed_p, removed_q)));
        }
        const float inverse_length = 1.0f / std::sqrt(p * p + q * q + 1.0f);
        o[0] = -p * inverse_length, o[1] = -q * inverse_length, o[2] = inverse_length;
      }
    });
    for (int r = 0; r < rows; ++r) {
      for (const double tilt : band_tilts[r]) {
        tilt_sum += tilt;
        tilt_max = std::max(tilt_max, tilt);
      }
    }
  }
  constexpr double kDeg = 180.0 / std::numbers::pi;
  summary->mean_removed_tilt_deg =
      weighted.valid_count > 0 ? tilt_sum / static_cast<double>(weighted.valid_count) * kDeg : 0.0;
  summary->max_removed_tilt_deg = tilt_max * kDeg;
  return out;
}

// Ends the summary: termination, time and the message (`why` then the figures).
void Finish(Termination termination, const std::string& why, const NormalFlatteningOptions& options,
            size_t num_pixels, std::chrono::steady_clock::time_point start, NormalFlatteningSummary* summary) {
  summary->termination = termination;
  summary->seconds = SecondsSince(start);
  char figures[200];
  std::snprintf(figures, sizeof(figures),
                "%zu of %zu pixels valid, sigma %.1f px, removed tilt mean %.3f deg, max %.3f deg, %.2f s",
                summary->valid_pixels, num_pixels, options.low_pass_sigma_px, summary->mean_removed_tilt_deg,
                summary->max_removed_tilt_deg, summary->seconds);
  summary->message = why + figures;
}

}  // namespace

void NormalFlatteningOptions::Check() const {
  SCANBENCH_REQUIRE_FINITE_GT(kWhere, "low_pass_sigma_px", low_pass_sigma_px, 0);
  SCANBENCH_REQUIRE_FINITE_GT(kWhere, "max_slope", max_slope, 0);
  if (num_threads < 0 || num_threads > 256) throw FieldError(kWhere, "num_threads", num_threads, "must be in [0, 256]");
}

std::string NormalFlatteningSummary::BriefReport() const {
  std::string report = std::string("Normal flattening: ") + TerminationName(termination) + ", removed tilt mean " +
                       Fixed(mean_removed_tilt_deg, 3) + " deg, max " + Fixed(max_removed_tilt_deg, 3) + " deg over " +
                       std::to_string(valid_pixels) + " px, " + Fixed(seconds, 2) + " s";
  if (termination != Termination::kSuccess) report += " (" + message + ")";
  return report;
}

NormalFlatteningSummary FlattenNormals(const NormalFlatteningOptions& options, const ImageF& normal_in_tangent,
                                       const ImageU8* valid, ImageF* flat_normal_in_tangent,
                                       const ProgressCallback& progress) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  CheckInputs(normal_in_tangent, valid, flat_normal_in_tangent);
  NormalFlatteningSummary summary;
  const size_t num_pixels = normal_in_tangent.num_pixels();

  const WeightedSlopes weighted =
      WeightSlopes(normal_in_tangent, valid, static_cast<float>(options.max_slope), options.num_threads);
  summary.valid_pixels = weighted.valid_count;
  // Where nothing is removed the output is the input's valid normals, re-normalised.
  if (weighted.valid_count == 0) {
    *flat_normal_in_tangent = RemoveLowPass(weighted, nullptr, options.num_threads, &summary);
    Finish(Termination::kFailure, "no valid pixel with a finite normal, nothing flattened: ", options, num_pixels,
           start, &summary);
    return summary;
  }
  if (progress && !progress(0.3)) {
    *flat_normal_in_tangent = RemoveLowPass(weighted, nullptr, options.num_threads, &summary);
    Finish(Termination::kCancelled, "cancelled before the low-pass, normals unchanged: ", options, num_pixels, start,
           &summary);
    return summary;
  }
  const cv::Mat low_pass = LowPass(weighted.slopes, options.low_pass_sigma_px);
  if (progress && !progress(0.7)) {
    *flat_normal_in_tangent = RemoveLowPass(weighted, nullptr, options.num_threads, &summary);
    Finish(Termination::kCancelled, "cancelled after the low-pass, normals unchanged: ", options, num_pixels, start,
           &summary);
    return summary;
  }
  *flat_normal_in_tangent = RemoveLowPass(weighted, &low_pass, options.num_threads, &summary);
  Finish(Termination::kSuccess, "", options, num_pixels, start, &summary);
  if (progress) progress(1.0);
  return summary;
}

}  // namespace scanbench
