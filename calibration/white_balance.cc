#include "calibration/white_balance.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <set>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>

#include "core/field_error.h"
#include "core/format.h"
#include "calibration/bayer_sampling.h"
#include "calibration/camera_model.h"

namespace scanbench {
namespace {

// Raw pixels whose table point lies inside the patch's inset square.
std::vector<std::pair<int, int>> PatchPixels(const GrayPatch& patch, double height_mm, double inset,
                                             const CameraGeometry& camera) {
  const double half = 0.5 * patch.size_mm * (1.0 - 2.0 * inset);
  const Eigen::Vector2d& c = patch.centre_in_table_mm;
  // Bounding box of the projected square, one pixel wider.
  double min_x = 1e18, min_y = 1e18, max_x = -1e18, max_y = -1e18;
  for (const double sx : {-1.0, 1.0}) {
    for (const double sy : {-1.0, 1.0}) {
      const Eigen::Vector3d corner(c.x() + sx * half, c.y() + sy * half, height_mm);
      const Eigen::Vector3d in_cam = camera.cam_from_table * corner;
      if (!(in_cam.z() > 0)) return {};
      const Eigen::Vector2d pixel = ProjectToPixel(camera.intrinsics, in_cam);
      min_x = std::min(min_x, pixel.x());
      max_x = std::max(max_x, pixel.x());
      min_y = std::min(min_y, pixel.y());
      max_y = std::max(max_y, pixel.y());
    }
  }
  const int x0 = std::max(0, static_cast<int>(std::floor(min_x)) - 1);
  const int y0 = std::max(0, static_cast<int>(std::floor(min_y)) - 1);
  const int x1 = std::min(camera.intrinsics.width - 1, static_cast<int>(std::ceil(max_x)) + 1);
  const int y1 = std::min(camera.intrinsics.height - 1, static_cast<int>(std::ceil(max_y)) + 1);
  if (x0 > x1 || y0 > y1) return {};
  std::vector<Eigen::Vector2d> pixels;
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) pixels.emplace_back(x, y);
  }
  const std::vector<Eigen::Vector3d> points = ComputePlanePointsInTable(camera, pixels, height_mm);
  std::vector<std::pair<int, int>> inside;
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (std::abs(points[i].x() - c.x()) <= half && std::abs(points[i].y() - c.y()) <= half) {
      inside.emplace_back(static_cast<int>(pixels[i].x()), static_cast<int>(pixels[i].y()));
    }
  }
  return inside;
}

// Least squares of log v = log s_c + gamma_c log rho + a x + b y over the used
// patches (gamma fixed at 1 when !free_exponent). Returns per patch and
// colour the relative residual; fills s and gamma.
struct ChartFit {
  Eigen::Vector3d log_scale = Eigen::Vector3d::Zero();
  Eigen::Vector3d exponent = Eigen::Vector3d::Ones();
  Eigen::Vector3d log_scale_std = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> residual;  // per patch (all patches, used or not)
};

ChartFit FitChart(const GrayChartTarget& chart, const std::vector<PatchMeasurement>& patches,
                  const std::vector<double>& log_irradiance, bool free_exponent) {
  std::vector<int> used;
  for (size_t p = 0; p < patches.size(); ++p) {
    if (patches[p].used) used.push_back(static_cast<int>(p));
  }
  const int num_params = 3 + (free_exponent ? 3 : 0) + 2;
  const int rows = static_cast<int>(used.size()) * 3;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, num_params);
  Eigen::VectorXd b(rows);
  for (size_t u = 0; u < used.size(); ++u) {
    const PatchMeasurement& m = patches[used[u]];
    const Eigen::Vector2d& xy = chart.patches[used[u]].centre_in_table_mm;
    for (int c = 0; c < 3; ++c) {
      const int row = static_cast<int>(3 * u) + c;
      a(row, c) = 1.0;
      const double log_value = std::log(m.mean[c]) - log_irradiance[used[u]];
      if (free_exponent) {
        a(row, 3 + c) = std::log(m.reflectance);
        b(row) = log_value;
      } else {
        b(row) = log_value - std::log(m.reflectance);
      }
      a(row, num_params - 2) = xy.x();
      a(row, num_params - 1) = xy.y();
    }
  }
  const Eigen::VectorXd solution = a.colPivHouseholderQr().solve(b);
  ChartFit fit;
  fit.log_scale = solution.head<3>();
  if (free_exponent) fit.exponent = solution.segment<3>(3);
  // Parameter spread from the residual variance.
  const Eigen::VectorXd r = a * solution - b;
  const int dof = std::max(1, rows - num_params);
  const double variance = r.squaredNorm() / dof;
  const Eigen::MatrixXd covariance = (a.transpose() * a).inverse() * variance;
  for (int c = 0; c < 3; ++c) fit.log_scale_std[c] = std::sqrt(std::max(0.0, covariance(c, c)));
  fit.residual.assign(patches.size(), Eigen::Vector3d::Zero());
  for (size_t p = 0; p < patches.size(); ++p) {
    const PatchMeasurement& m = patches[p];
    const Eigen::Vector2d& xy = chart.patches[p].centre_in_table_mm;
    for (int c = 0; c < 3; ++c) {
      if (!(m.mean[c] > 0)) {
        fit.residual[p][c] = -1.0;
        continue;
      }
      const double predicted = fit.log_scale[c] + fit.exponent[c] * std::log(m.reflectance) + log_irradiance[p] +
                               solution(num_params - 2) * xy.x() + solution(num_params - 1) * xy.y();
      fit.residual[p][c] = std::exp(std::log(m.mean[c]) - predicted) - 1.0;
    }
  }
  return fit;
}

size_t DistinctReflectances(const std::vector<PatchMeasurement>& patches) {
  std::set<double> values;
  for (const PatchMeasurement& m : patches) {
    if (m.used) values.insert(m.reflectance);
  }
  return values.size();
}

// Relative irradiance of the LED at each patch centre as the (uncalibrated)
// LED description predicts it; its errors are left to the fitted gradient.
std::vector<double> LogIrradiance(const GrayChartTarget& chart, const LedDescription* led) {
  std::vector<double> values(chart.patches.size(), 0.0);
  if (led == nullptr) return values;
  for (size_t p = 0; p < chart.patches.size(); ++p) {
    const Eigen::Vector3d point(chart.patches[p].centre_in_table_mm.x(), chart.patches[p].centre_in_table_mm.y(),
                                chart.height_mm);
    const Eigen::Vector3d to_led = led->position_in_table_mm - point;
    const double d = to_led.norm();
    const Eigen::Vector3d l = to_led / d;
    const double cos_off_axis = std::max(1e-6, -l.dot(led->axis_in_table.normalized()));
    values[p] = std::log(std::max(1e-6, l.z())) + led->mu * std::log(cos_off_axis) - 2.0 * std::log(d);
  }
  return values;
}

// ---------------------------------------------------------------------------
// The steps of CalibrateWhiteBalance.

// Throws std::invalid_argument when the LED descriptions or frames do not fit
// the camera and each other.
void CheckFrames(const CameraGeometry& camera, const std::vector<LedDescription>& leds,
                 const std::vector<RawImage>& led_frames) {
  if (!leds.empty() && leds.size() != led_frames.size()) {
    throw std::invalid_argument("CalibrateWhiteBalance: " + std::to_string(leds.size()) + " LED descriptions for " +
                                std::to_string(led_frames.size()) + " frames; give one per frame or none");
  }
  for (size_t k = 0; k < led_frames.size(); ++k) {
    if (!led_frames[k].mosaic.SameSize(camera.intrinsics.width, camera.intrinsics.height)) {
      throw std::invalid_argument("gray chart frame of LED " + std::to_string(k) + " is " +
                                  std::to_string(led_frames[k].width()) + "x" + std::to_string(led_frames[k].height()) +
                                  " but the camera calibration is " + std::to_string(camera.intrinsics.width) + "x" +
                                  std::to_string(camera.intrinsics.height));
    }
  }
}

using PatchPixelList = std::vector<std::pair<int, int>>;

// Where each patch is, once for all LEDs. Sets *failure naming the first
// patch outside the image.
std::vector<PatchPixelList> LocatePatches(const GrayChartTarget& chart, const CameraGeometry& camera, double inset,
                                          std::string* failure) {
  std::vector<PatchPixelList> pixels;
  for (const GrayPatch& patch : chart.patches) {
    pixels.push_back(PatchPixels(patch, chart.height_mm, inset, camera));
    if (pixels.back().empty()) {
      *failure = "patch " + patch.name + " lies outside the image";
      break;
    }
  }
  return pixels;
}

// Every patch's raw samples under LED k averaged per colour, flagged clipped
// or underexposed. Sets *failure when a patch has too few samples.
std::vector<PatchMeasurement> MeasurePatches(const GrayChartTarget& chart, const std::vector<PatchPixelList>& pixels,
                                             const LinearBayerReader& reader, size_t k,
                                             const WhiteBalanceOptions& options, std::string* failure) {
  std::vector<PatchMeasurement> patches;
  for (size_t p = 0; p < chart.patches.size(); ++p) {
    RgbStatistics stats{};
    for (const auto& [x, y] : pixels[p]) reader.Accumulate(x, y, stats);
    PatchMeasurement m;
    m.name = chart.patches[p].name;
    m.reflectance = chart.patches[p].reflectance;
    bool enough = true;
    for (int c = 0; c < 3; ++c) {
      m.mean[c] = stats[c].Mean();
      m.standard_error[c] = stats[c].StandardError();
      m.samples[c] = stats[c].count;
      m.clipped |= stats[c].clipped > 0;
      // A colour whose bright samples clipped reads low: that is "clipped", not underexposed.
      m.underexposed |= stats[c].clipped == 0 && !(m.mean[c] >= options.min_level);
      enough &= stats[c].count + stats[c].clipped >= options.min_samples;
    }
    if (!enough) {
      *failure = "LED " + std::to_string(k) + ": patch " + m.name + " has fewer than min_samples = " +
                 std::to_string(options.min_samples) + " samples of some colour";
      return patches;
    }
    m.used = !m.clipped && !m.underexposed;
    patches.push_back(m);
  }
  return patches;
}

// The linear fit; patches that leave it beyond the tolerance are outside the
// linear range: drop the worst (flagged non-linear) and refit. False when
// fewer than 3 usable patches of 2 reflectances remain.
bool FitLinearRange(const GrayChartTarget& chart, const std::vector<double>& log_irradiance,
                    double linearity_tolerance, std::vector<PatchMeasurement>* patches, ChartFit* linear) {
  while (true) {
    if (DistinctReflectances(*patches) < 2 ||
        std::count_if(patches->begin(), patches->end(), [](const PatchMeasurement& m) { return m.used; }) < 3) {
      return false;
    }
    *linear = FitChart(chart, *patches, log_irradiance, false);
    int worst = -1;
    double worst_residual = linearity_tolerance;
    for (size_t p = 0; p < patches->size(); ++p) {
      if (!(*patches)[p].used) continue;
      const double r = linear->residual[p].cwiseAbs().maxCoeff();
      if (r > worst_residual) {
        worst_residual = r;
        worst = static_cast<int>(p);
      }
    }
    if (worst < 0) return true;
    (*patches)[worst].used = false;
    (*patches)[worst].nonlinear = true;
  }
}

// The LED's figures from the linear fit: response exponents (a free fit),
// linearity, linear range and gains with their spread.
void DescribeLed(const GrayChartTarget& chart, const std::vector<double>& log_irradiance, const ChartFit& linear,
                 double linearity_tolerance, LedWhiteBalance* led) {
  const ChartFit free = FitChart(chart, led->patches, log_irradiance, true);
  led->response_exponent = free.exponent;
  led->used_patches = 0;
  led->linear_range_min = 1e9;
  led->linear_range_max = 0;
  Eigen::Vector3d sum_squares = Eigen::Vector3d::Zero();
  for (size_t p = 0; p < led->patches.size(); ++p) {
    PatchMeasurement& m = led->patches[p];
    m.linear_residual = linear.residual[p];
    // A patch left out for clipping may still be far off the line: say so.
    if (!m.used && !m.nonlinear && !m.underexposed && linear.residual[p].cwiseAbs().maxCoeff() > linearity_tolerance) {
      m.nonlinear = true;
    }
    if (!m.used) continue;
    ++led->used_patches;
    sum_squares += m.linear_residual.cwiseAbs2();
    led->linear_range_min = std::min(led->linear_range_min, m.mean.minCoeff());
    led->linear_range_max = std::max(led->linear_range_max, m.mean.maxCoeff());
  }
  led->linearity_rms = (sum_squares / std::max(1, led->used_patches)).cwiseSqrt();
  for (int c = 0; c < 3; ++c) {
    led->gains[c] = std::exp(linear.log_scale[1] - linear.log_scale[c]);
    led->gains_std[c] = c == 1 ? 0.0 : led->gains[c] * std::hypot(linear.log_scale_std[1], linear.log_scale_std[c]);
  }
}

}  // namespace

void WhiteBalanceOptions::Check() const {
  const std::string where = "WhiteBalanceOptions";
  SCANBENCH_REQUIRE_GE_LE(where, "patch_inset", patch_inset, 0, 0.45);
  SCANBENCH_REQUIRE_GT_LE(where, "clip_fraction", clip_fraction, 0, 1);
  SCANBENCH_REQUIRE_GE_LT(where, "min_level", min_level, 0, 1);
  SCANBENCH_REQUIRE_GT_LT(where, "linearity_tolerance", linearity_tolerance, 0, 1);
  SCANBENCH_REQUIRE_GE(where, "min_samples", min_samples, 1);
}

std::string WhiteBalanceSummary::BriefReport() const {
  std::ostringstream out;
  out << "White balance: " << (IsUsable() ? "success" : "failure");
  if (!message.empty()) out << " (" << message << ")";
  for (const LedWhiteBalance& led : leds) {
    out << "\n  LED " << led.led_index << ": gains R " << Fixed(led.gains[0], 4) << " B " << Fixed(led.gains[2], 4)
        << ", exponent " << Fixed(led.response_exponent[0], 3) << "/" << Fixed(led.response_exponent[1], 3) << "/"
        << Fixed(led.response_exponent[2], 3) << ", linear rms " << Fixed(100 * led.linearity_rms.maxCoeff(), 2)
        << " %, linear over " << Fixed(led.linear_range_min, 3) << ".." << Fixed(led.linear_range_max, 3) << ", "
        << led.used_patches << "/" << led.patches.size() << " patches used";
    for (const PatchMeasurement& m : led.patches) {
      if (m.clipped) out << "; " << m.name << " clipped";
      if (m.underexposed) out << "; " << m.name << " underexposed";
      if (m.nonlinear) out << "; " << m.name << " non-linear";
    }
  }
  return out.str();
}

WhiteBalanceSummary CalibrateWhiteBalance(const WhiteBalanceOptions& options, const GrayChartTarget& chart,
                                          const CameraGeometry& camera, const std::vector<LedDescription>& leds,
                                          const RawImage& dark, const std::vector<RawImage>& led_frames,
                                          const ProgressCallback& progress) {
  options.Check();
  chart.Check();
  CheckCameraIntrinsics(camera.intrinsics);
  WhiteBalanceSummary summary;
  if (led_frames.empty()) {
    summary.SetFailure("no LED frames given");
    return summary;
  }
  CheckFrames(camera, leds, led_frames);
  std::string failure;
  const std::vector<PatchPixelList> pixels = LocatePatches(chart, camera, options.patch_inset, &failure);
  if (!failure.empty()) {
    summary.SetFailure(failure);
    return summary;
  }

  for (size_t k = 0; k < led_frames.size(); ++k) {
    const LinearBayerReader reader(led_frames[k], dark, options.clip_fraction,
                                   "gray chart frame of LED " + std::to_string(k));
    LedWhiteBalance led;
    led.led_index = static_cast<int>(k);
    led.patches = MeasurePatches(chart, pixels, reader, k, options, &failure);
    if (!failure.empty()) {
      summary.SetFailure(failure);
      return summary;
    }
    const std::vector<double> log_irradiance = LogIrradiance(chart, leds.empty() ? nullptr : &leds[k]);
    ChartFit linear;
    if (!FitLinearRange(chart, log_irradiance, options.linearity_tolerance, &led.patches, &linear)) {
      summary.SetFailure("LED " + std::to_string(k) + ": fewer than 3 usable patches of 2 reflectances (clipped, "
                         "underexposed or non-linear); change the exposure");
      summary.leds.push_back(led);
      return summary;
    }
    DescribeLed(chart, log_irradiance, linear, options.linearity_tolerance, &led);
    summary.leds.push_back(led);
    if (progress && !progress(double(k + 1) / led_frames.size())) {
      summary.SetCancelled();
      return summary;
    }
  }
  summary.termination = Termination::kSuccess;
  return summary;
}

}  // namespace scanbench
