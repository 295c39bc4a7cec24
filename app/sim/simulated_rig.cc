#include "app/sim/simulated_rig.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <numbers>
#include <span>
#include <sstream>
#include <string>
#include <thread>
#include <utility>

#include <Eigen/Geometry>

#include "core/parallel_for.h"
#include "calibration/camera_model.h"
#include "app/sim/sensor_color.h"
#include "app/sim/split_mix.h"
#include "calibration/color_checker.h"
#include "core/field_error.h"

namespace scanbench {
using sim_internal::kSplitMixGamma;
using sim_internal::Mix64;

namespace {

constexpr double kPi = std::numbers::pi;

// ---------------------------------------------------------------------------
// Noise. SplitMix64 as the generator: tiny state, so one per image row costs
// nothing, and its output depends only on the seed (not on the standard
// library's distributions, which differ between implementations).
class RowRng {
 public:
  explicit RowRng(uint64_t seed) : state_(seed) {}

  // Uniform in (0, 1): never 0, so log() is safe.
  double Uniform() {
    const uint64_t z = Mix64(state_);
    state_ += kSplitMixGamma;
    return (static_cast<double>(z >> 11) + 0.5) * 0x1.0p-53;
  }

  // Standard normal, Box-Muller, both values of a pair used.
  double Gaussian() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double radius = std::sqrt(-2.0 * std::log(Uniform()));
    const double angle = 2.0 * kPi * Uniform();
    spare_ = radius * std::sin(angle);
    has_spare_ = true;
    return radius * std::cos(angle);
  }

  // Poisson count. Exact (Knuth) for small means, where the Gaussian
  // approximation would be visibly skewed; Gaussian above.
  double Poisson(double mean) {
    if (mean <= 0) return 0;
    if (mean < kExactPoissonBelow) {
      const double limit = std::exp(-mean);
      double product = Uniform();
      int count = 0;
      while (product > limit) {
        ++count;
        product *= Uniform();
      }
      return count;
    }
    return mean + std::sqrt(mean) * Gaussian();
  }

 private:
  static constexpr double kExactPoissonBelow = 30.0;
  uint64_t state_;
  double spare_ = 0;
  bool has_spare_ = false;
};

// The fibre tilt's int16 step: tan(20 deg), the largest tilt
// TextileSceneOptions allows, a little under the int16 range.
constexpr double kFibreTiltStep = 0.364 / 32000.0;

// Footprint sub-sample offsets of one pixel, in units of its footprint side
// and centred on the pixel: a Latin hypercube (one sample in each of the
// `count` columns and rows), permuted and jittered by `seed`.
void FootprintOffsets(uint64_t seed, int count, std::vector<Eigen::Vector2d>* offsets) {
  offsets->resize(count);
  uint64_t state = seed;
  auto next = [&state] {
    const uint64_t z = Mix64(state);
    state += kSplitMixGamma;
    return static_cast<double>(z >> 11) * 0x1.0p-53;  // [0, 1)
  };
  int rows[64];
  for (int k = 0; k < count; ++k) rows[k] = k;
  for (int k = count - 1; k > 0; --k) std::swap(rows[k], rows[std::min(k, static_cast<int>(next() * (k + 1)))]);
  for (int k = 0; k < count; ++k) {
    (*offsets)[k] = Eigen::Vector2d((k + next()) / count - 0.5, (rows[k] + next()) / count - 0.5);
  }
}

uint64_t RowSeed(uint64_t seed, uint64_t frame_index, int row) {
  return Mix64(Mix64(Mix64(seed) ^ frame_index) ^ static_cast<uint64_t>(row));
}

// Where `ray_in_table` from `origin` meets the plane z = 0.
Eigen::Vector3d TablePlanePoint(const Eigen::Vector3d& origin, const Eigen::Vector3d& ray_in_table) {
  return origin + (-origin.z() / ray_in_table.z()) * ray_in_table;
}

}  // namespace

// ---------------------------------------------------------------------------
void SimulatedRigOptions::Check() const {
  const std::string where = "SimulatedRigOptions";
  SCANBENCH_REQUIRE_GT(where, "width", width, 0);
  SCANBENCH_REQUIRE_GT(where, "height", height, 0);
  if (cfa != CfaPattern::kRGGB && cfa != CfaPattern::kBGGR && cfa != CfaPattern::kGRBG &&
      cfa != CfaPattern::kGBRG) {
    throw FieldError(where, "cfa", static_cast<int>(cfa), "must be one of RGGB, BGGR, GRBG, GBRG");
  }
  SCANBENCH_REQUIRE_GT_LE(where, "white_level", white_level, 0, 65535);
  if (black_level < 0 || black_level >= white_level) {
    throw FieldError(where, "black_level", black_level,
                     "must lie in [0, white_level = " + std::to_string(white_level) + ")");
  }
  SCANBENCH_REQUIRE_FINITE_GT(where, "gain_e_per_dn", gain_e_per_dn, 0);
  SCANBENCH_REQUIRE_FINITE_GE(where, "read_noise_dn", read_noise_dn, 0);
  SCANBENCH_REQUIRE_GE_LE(where, "ambient", ambient, 0, 1);
  SCANBENCH_REQUIRE_GT_LE(where, "shadow_grid_mm", shadow_grid_mm, 0, 1);
  SCANBENCH_REQUIRE_GE_LE(where, "shadow_bias_mm", shadow_bias_mm, 0, 1);
  if (color != SensorColorModel::kNikonD5100 && color != SensorColorModel::kSrgbPrimaries) {
    throw FieldError(where, "color", static_cast<int>(color), "must be kNikonD5100 or kSrgbPrimaries");
  }
  SCANBENCH_REQUIRE_GE_LE(where, "num_threads", num_threads, 0, 256, "(0 = hardware concurrency)");
  SCANBENCH_REQUIRE_GE_LE(where, "footprint_samples", footprint_samples, 1, 64);
}

// ---------------------------------------------------------------------------
RigDescription MakeDefaultSimulatedRig(int width, int height, SensorColorModel color) {
  SCANBENCH_REQUIRE_GT("MakeDefaultSimulatedRig", "width", width, 0);
  SCANBENCH_REQUIRE_GT("MakeDefaultSimulatedRig", "height", height, 0);

  RigDescription rig;
  rig.name = color == SensorColorModel::kSrgbPrimaries ? "simulated D5100 + 85 mm, 10 x D65 LED"
                                                       : "simulated D5100 + 85 mm, 10 x LED-B5 white LED";

  // Camera. An 85 mm lens focused at 600 mm has its image plane at
  // f * s / (s - f) = 99 mm: that is the pinhole focal length. Binning keeps
  // the sensor's physical size, so the pixel pitch scales with 1 / size.
  constexpr double kLensFocalMm = 85.0;
  constexpr double kWorkingDistanceMm = 600.0;
  const double image_distance_mm = kLensFocalMm * kWorkingDistanceMm / (kWorkingDistanceMm - kLensFocalMm);
  CameraIntrinsics& k = rig.camera.intrinsics;
  k.width = width;
  k.height = height;
  k.fx = image_distance_mm / (kD5100SensorWidthMm / width);
  k.fy = image_distance_mm / (kD5100SensorHeightMm / height);
  // Principal point a little off centre, as a real lens mount has it.
  k.cx = 0.5 * (width - 1) + 0.004 * width;
  k.cy = 0.5 * (height - 1) - 0.003 * height;
  // Mild barrel distortion with a little decentring: about 1 px full-res
  // displacement in the corners, typical of a short-tele prime.
  k.k1 = -0.06;
  k.k2 = 0.35;
  k.k3 = 0.0;
  k.p1 = 4e-4;
  k.p2 = -3e-4;

  // Pose: looking straight down (the 180 deg turn about x makes image x =
  // table +x and image up = table +y), then tilted 1 deg about table x and
  // turned 0.4 deg about z, as mounting leaves it; the optical axis still
  // passes through the sample centre 600 mm away.
  const Eigen::Matrix3d table_from_cam_rotation =
      (Eigen::AngleAxisd(0.4 * kPi / 180.0, Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(1.0 * kPi / 180.0, Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  const Eigen::Vector3d optical_axis_in_table = table_from_cam_rotation.col(2);
  const Eigen::Vector3d camera_centre_in_table = -kWorkingDistanceMm * optical_axis_in_table;
  Eigen::Isometry3d table_from_cam = Eigen::Isometry3d::Identity();
  table_from_cam.linear() = table_from_cam_rotation;
  table_from_cam.translation() = camera_centre_in_table;
  rig.camera.cam_from_table = table_from_cam.inverse();

  // LEDs: 5 at 30 deg elevation and 5 at 60 deg, azimuths interleaved by 36
  // deg, ~500 mm from the centre; small per-LED placement errors, falloff
  // exponents and brightnesses as a hand-built bench has them.
  struct LedBuild {
    double elevation_deg, azimuth_deg, radius_mm, mu, brightness, tint_r, tint_b;
  };
  constexpr LedBuild kLeds[10] = {
      {30.0, 0.0, 503.0, 1.2, 1.00, 1.01, 0.98},    {30.4, 72.5, 497.0, 2.1, 0.93, 0.99, 1.02},
      {29.7, 143.6, 501.0, 1.6, 1.06, 1.02, 1.00},  {30.2, 216.3, 495.0, 2.8, 0.95, 0.98, 0.99},
      {29.8, 288.1, 506.0, 1.4, 0.91, 1.00, 1.03},  {60.3, 36.2, 499.0, 1.9, 1.03, 0.97, 1.01},
      {59.6, 108.0, 504.0, 2.5, 0.97, 1.03, 0.98},  {60.1, 179.4, 498.0, 1.1, 1.09, 1.00, 0.97},
      {59.9, 252.2, 502.0, 2.3, 0.92, 1.01, 1.02},  {60.2, 323.7, 496.0, 1.7, 0.99, 0.99, 1.00},
  };
  // Raw response of the sensor to the LEDs' white relative to green (the
  // inverse of the camera's white-balance multipliers for that light).
  const Eigen::Vector3d kRawWhite = SimulatedSensorColor(color).raw_white_relative_to_green;
  // Brightest LED: an albedo-1 patch facing it at the centre reads 0.72 of the raw range.
  constexpr double kBrightestFraction = 0.72;

  double brightest = 0;
  for (int i = 0; i < 10; ++i) {
    const LedBuild& b = kLeds[i];
    const double el = b.elevation_deg * kPi / 180.0;
    const double az = b.azimuth_deg * kPi / 180.0;
    LedDescription led;
    led.id = i;
    led.position_in_table_mm =
        b.radius_mm * Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    led.axis_in_table = -led.position_in_table_mm.normalized();
    led.mu = b.mu;
    led.rgb_intensity = b.brightness * kRawWhite.cwiseProduct(Eigen::Vector3d(b.tint_r, 1.0, b.tint_b));
    const double at_centre = std::pow(kLedReferenceDistanceMm / b.radius_mm, 2);
    brightest = std::max(brightest, led.rgb_intensity.maxCoeff() * at_centre);
    rig.leds.push_back(led);
  }
  for (LedDescription& led : rig.leds) led.rgb_intensity *= kBrightestFraction / brightest;
  return rig;
}

// ---------------------------------------------------------------------------
SimulatedRig::SimulatedRig(const SimulatedRigOptions& options, TextileScene scene, RigDescription rig,
                           const ProgressCallback& progress)
    : options_(options), scene_(std::move(scene)), rig_(std::move(rig)) {
  options_.Check();
  CheckRig();
  // Progress: the shadow grid is ~10 % of the work, the ray tracing the rest
  // (undistorting the rays in the calibration library reports nothing).
  BuildShadowGrid(SubRange(progress, 0.0, 0.1));
  const ImageF rays = ComputeRayDirectionsInTable(rig_.camera);
  const Eigen::Vector3d camera_centre = CameraCentreInTable(rig_.camera);
  camera_centre_in_table_ = camera_centre;
  mm_per_pixel_ = CentrePixelFootprintMm(rays, camera_centre);
  PrepareColor();

  const size_t num_pixels = static_cast<size_t>(options_.width) * options_.height;
  point_in_table_.resize(3 * num_pixels);
  normal_xy_in_table_.resize(2 * num_pixels);
  albedo_.resize(3 * num_pixels);
  if (!camera_is_rec709_) albedo_linear_rec709_.resize(3 * num_pixels);
  if (scene_.options().sample == SampleKind::kColorChecker && scene_.options().chart_gloss > 0) {
    gloss_.resize(num_pixels);
  }
  const TextileSceneOptions& so = scene_.options();
  if (so.sample == SampleKind::kTextile && so.material != SurfaceMaterial::kLambert) {
    // A fibre as wide as the pixel would be resolved structure, i.e. geometry.
    if (so.fibre_tilt_deg > 0 && !(so.fibre_diameter_mm < mm_per_pixel_)) {
      throw FieldError("TextileSceneOptions", "fibre_diameter_mm", so.fibre_diameter_mm,
                       "mm must be below the pixel footprint (" + std::to_string(mm_per_pixel_) +
                           " mm) for its tilt to be integrated over the pixel");
    }
    fibre_tilt_.resize(2 * static_cast<size_t>(options_.footprint_samples) * num_pixels);
    warp_weight_.resize(num_pixels);
    thread_index_.resize(2 * num_pixels);
    // Per-thread parameters once, for every thread that meets the sample.
    const Eigen::Vector2d half = 0.5 * scene_.SampleExtentMm();
    warp_index_base_ = static_cast<int64_t>(std::floor(-half.x() / so.warp_pitch_mm)) - 1;
    weft_index_base_ = static_cast<int64_t>(std::floor(-half.y() / so.weft_pitch_mm)) - 1;
    const int64_t warps = static_cast<int64_t>(std::ceil(half.x() / so.warp_pitch_mm)) + 2 - warp_index_base_;
    const int64_t wefts = static_cast<int64_t>(std::ceil(half.y() / so.weft_pitch_mm)) + 2 - weft_index_base_;
    for (int64_t k = 0; k < warps; ++k) warp_brdf_.push_back(scene_.ThreadBrdfOf(true, warp_index_base_ + k));
    for (int64_t k = 0; k < wefts; ++k) weft_brdf_.push_back(scene_.ThreadBrdfOf(false, weft_index_base_ + k));
  }
  ParallelRowsOrCancel("render", options_.height, NumThreads(), progress, 0.1, 1.0,
                       [&](int y) { TraceRow(y, rays, camera_centre); });
}

void SimulatedRig::PrepareColor() {
  const SensorColor& color = SimulatedSensorColor(options_.color);
  camera_is_rec709_ = options_.color == SensorColorModel::kSrgbPrimaries;
  camera_from_linear_rec709_ = color.camera_from_linear_rec709;
  patch_camera_rgb_.clear();
  for (const ColorCheckerPatch& patch : ColorCheckerClassic()) {
    patch_camera_rgb_.push_back(WhiteBalancedCameraRgbOf(options_.color, patch.reflectance));
  }
  const double width_rad = scene_.options().chart_gloss_width_deg * kPi / 180.0;
  gloss_tan2_width_ = std::tan(width_rad) * std::tan(width_rad);
}

Eigen::Vector3d SimulatedRig::CameraRgbOf(const SurfaceSample& s) const {
  if (camera_is_rec709_) return s.albedo;
  if (s.spectral_patch >= 0) return patch_camera_rgb_[s.spectral_patch];
  return camera_from_linear_rec709_ * s.albedo;
}

void SimulatedRig::CheckRig() const {
  const CameraIntrinsics& k = rig_.camera.intrinsics;
  if (k.width != options_.width || k.height != options_.height) {
    throw std::invalid_argument("SimulatedRig: rig camera is " + std::to_string(k.width) + "x" +
                                std::to_string(k.height) + " but SimulatedRigOptions width x height = " +
                                std::to_string(options_.width) + "x" + std::to_string(options_.height) +
                                "; they must match");
  }
  CheckCameraIntrinsics(k);
  const Eigen::Vector3d camera_centre = CameraCentreInTable(rig_.camera);
  if (!(camera_centre.z() > scene_.MaxHeightMm())) {
    throw FieldError("SimulatedRig", "camera centre z", camera_centre.z(),
                     "mm must be above the highest point of the scene (" + std::to_string(scene_.MaxHeightMm()) +
                         " mm)");
  }
  for (size_t i = 0; i < rig_.leds.size(); ++i) {
    const LedDescription& led = rig_.leds[i];
    const std::string name = "leds[" + std::to_string(i) + "]";
    if (!led.position_in_table_mm.allFinite()) {
      throw FieldError("SimulatedRig", name + ".position_in_table_mm.z", led.position_in_table_mm.z(),
                       "(all components) must be finite");
    }
    if (!(std::abs(led.axis_in_table.norm() - 1.0) < 1e-6)) {
      throw FieldError("SimulatedRig", name + ".axis_in_table norm", led.axis_in_table.norm(), "must be 1");
    }
    SCANBENCH_REQUIRE_FINITE_GE("SimulatedRig", name + ".mu", led.mu, 0);
    for (int c = 0; c < 3; ++c) {
      SCANBENCH_REQUIRE_FINITE_GE("SimulatedRig", name + ".rgb_intensity[" + std::to_string(c) + "]",
                                  led.rgb_intensity[c], 0);
    }
  }
}

double SimulatedRig::CentrePixelFootprintMm(const ImageF& rays, const Eigen::Vector3d& camera_centre) const {
  const int cx = options_.width / 2, cy = options_.height / 2;
  auto ray = [&](int x, int y) { return Eigen::Vector3d(rays(x, y, 0), rays(x, y, 1), rays(x, y, 2)); };
  const Eigen::Vector3d centre = TablePlanePoint(camera_centre, ray(cx, cy));
  double sum = 0;
  int count = 0;
  if (cx + 1 < options_.width) {
    sum += (TablePlanePoint(camera_centre, ray(cx + 1, cy)) - centre).norm();
    ++count;
  }
  if (cy + 1 < options_.height) {
    sum += (TablePlanePoint(camera_centre, ray(cx, cy + 1)) - centre).norm();
    ++count;
  }
  return count > 0 ? sum / count : 0.0;
}

void SimulatedRig::TraceRow(int y, const ImageF& rays, const Eigen::Vector3d& camera_centre) {
  std::vector<Eigen::Vector2d> offsets;
  for (int x = 0; x < options_.width; ++x) {
    const size_t i = static_cast<size_t>(y) * options_.width + x;
    const Eigen::Vector3d ray(rays(x, y, 0), rays(x, y, 1), rays(x, y, 2));
    if (!(ray.z() < -1e-9)) {
      throw std::invalid_argument("SimulatedRig: the ray of pixel " + std::to_string(x) + "," + std::to_string(y) +
                                  " does not reach the table");
    }
    const double z = SurfaceHeightAlongRay(camera_centre, ray);
    Eigen::Vector3d point = camera_centre + ((camera_centre.z() - z) / -ray.z()) * ray;
    const SurfaceSample s = scene_.Sample(point.x(), point.y(), true);
    point.z() = s.height_mm;
    const Eigen::Vector3d normal = Eigen::Vector3d(-s.gradient.x(), -s.gradient.y(), 1.0).normalized();
    const Eigen::Vector3d camera_rgb = CameraRgbOf(s);
    for (int c = 0; c < 3; ++c) {
      point_in_table_[3 * i + c] = static_cast<float>(point[c]);
      albedo_[3 * i + c] = static_cast<float>(camera_rgb[c]);
      if (!camera_is_rec709_) albedo_linear_rec709_[3 * i + c] = static_cast<float>(s.albedo[c]);
    }
    if (!gloss_.empty()) gloss_[i] = static_cast<float>(s.gloss);
    normal_xy_in_table_[2 * i + 0] = static_cast<float>(normal.x());
    normal_xy_in_table_[2 * i + 1] = static_cast<float>(normal.y());
    if (HasMaterial()) {
      // The fibres under the pixel's footprint (on the table plane around the
      // surface point); the seed is the scene's, so frames agree pixel for pixel.
      const int samples = options_.footprint_samples;
      FootprintOffsets(Mix64(scene_.options().seed ^ 0xF1B5E5ULL) ^ i, samples, &offsets);
      for (int k = 0; k < samples; ++k) {
        const Eigen::Vector2d at = point.head<2>() + mm_per_pixel_ * offsets[k];
        const Eigen::Vector2d tilt = scene_.FibreTiltGradient(at.x(), at.y(), s.warp_weight);
        for (int a = 0; a < 2; ++a) {
          fibre_tilt_[2 * (samples * i + k) + a] =
              static_cast<int16_t>(std::clamp(std::nearbyint(tilt[a] / kFibreTiltStep), -32767.0, 32767.0));
        }
      }
      const bool thread = s.warp_weight >= 0 && scene_.OnSample(point.x(), point.y());
      warp_weight_[i] = thread ? static_cast<float>(s.warp_weight) : -1.0f;
      thread_index_[2 * i + 0] = static_cast<int32_t>(std::clamp<int64_t>(
          s.warp_index - warp_index_base_, 0, static_cast<int64_t>(warp_brdf_.size()) - 1));
      thread_index_[2 * i + 1] = static_cast<int32_t>(std::clamp<int64_t>(
          s.weft_index - weft_index_base_, 0, static_cast<int64_t>(weft_brdf_.size()) - 1));
    }
  }
}

// Ray / height-field intersection: fixed-point iteration on z over the shadow
// grid (cheap, to ~1e-4 mm), then Newton on the analytic field to well below
// 1e-6 mm (1-2 steps + 1 final evaluation); a bisection where that does not
// converge. With the camera's half field of view (tan ~0.17) and slopes below
// ~2.5 the ray meets the surface exactly once.
double SimulatedRig::SurfaceHeightAlongRay(const Eigen::Vector3d& camera_centre, const Eigen::Vector3d& ray) const {
  constexpr double kConvergedMm = 1e-7;
  constexpr double kNewtonFinalStepMm = 1e-4;
  constexpr int kMaxIterations = 200;
  auto point_at_height = [&](double z) {
    return Eigen::Vector3d(camera_centre + ((camera_centre.z() - z) / -ray.z()) * ray);
  };
  // Coarse: on the grid (cheap) to ~1e-4 mm.
  double z = 0;
  for (int it = 0; it < 50; ++it) {
    const Eigen::Vector3d p = point_at_height(z);
    const double z_next = GridHeight(p.x(), p.y());
    const bool done = std::abs(z_next - z) < 1e-4;
    z = z_next;
    if (done) break;
  }
  // Exact: Newton on g(z) = z - H(ray point at height z), whose slope
  // g' = 1 - grad H . (ray_xy / ray_z) stays near 1 at this field of view;
  // where it does not, a plain fixed-point step (z <- H) instead.
  const Eigen::Vector2d ray_xy_per_z = ray.head<2>() / ray.z();
  for (int it = 0; it < kMaxIterations; ++it) {
    const Eigen::Vector3d p = point_at_height(z);
    const SurfaceSample s = scene_.Sample(p.x(), p.y(), false);
    const double g = z - s.height_mm;
    const double g_slope = 1.0 - s.gradient.dot(ray_xy_per_z);
    const bool newton = g_slope > 0.1;
    const double step = newton ? g / g_slope : g;
    z -= step;
    // Newton's error after a step is ~ (g'' / 2 g') step^2 with g'' <~ 2 /mm
    // here, so a step below 1e-4 mm leaves < 1e-8 mm; the fixed-point
    // step only shrinks linearly, so it must itself be tiny.
    if (std::abs(step) < (newton ? kNewtonFinalStepMm : kConvergedMm)) return z;
  }
  // Steep spot where the iteration does not contract: bracket the first
  // crossing from above, then bisect. f(z) = ray height - surface height.
  auto f = [&](double zz) {
    const Eigen::Vector3d p = point_at_height(zz);
    return zz - scene_.HeightMm(p.x(), p.y());
  };
  double z_above = scene_.MaxHeightMm() + 1e-3;  // ray above the surface: f > 0
  double z_below = z_above;
  constexpr double kBracketStepMm = 0.01;
  while (z_above > 0) {  // f(0) <= 0 always, so this finds a bracket
    z_below = std::max(0.0, z_above - kBracketStepMm);
    if (f(z_below) <= 0) break;
    z_above = z_below;
  }
  for (int it = 0; it < 60 && z_above - z_below > 1e-9; ++it) {
    const double mid = 0.5 * (z_below + z_above);
    (f(mid) > 0 ? z_above : z_below) = mid;
  }
  return 0.5 * (z_below + z_above);
}

int SimulatedRig::NumThreads() const {
  return ResolveThreadCount(options_.num_threads);
}

void SimulatedRig::BuildShadowGrid(const ProgressCallback& progress) {
  // The height is 0 off the sample, so the grid covers the sample only.
  const Eigen::Vector2d extent = scene_.SampleExtentMm();
  ShadowGrid& g = grid_;
  g.spacing = options_.shadow_grid_mm;
  g.origin_x = -0.5 * extent.x();
  g.origin_y = -0.5 * extent.y();
  g.nx = static_cast<int>(std::ceil(extent.x() / g.spacing)) + 1;
  g.ny = static_cast<int>(std::ceil(extent.y() / g.spacing)) + 1;
  g.height.assign(static_cast<size_t>(g.nx) * g.ny, 0.0f);
  ParallelRowsOrCancel("render", g.ny, NumThreads(), progress, 0.0, 0.9, [&](int j) {
    for (int i = 0; i < g.nx; ++i) {
      g.height[static_cast<size_t>(j) * g.nx + i] =
          static_cast<float>(scene_.HeightMm(g.origin_x + i * g.spacing, g.origin_y + j * g.spacing));
    }
  });
  // Tile maxima over the samples that the bilinear cells of each tile read.
  g.tiles_x = std::max(1, (g.nx - 1 + kTileCells - 1) / kTileCells);
  g.tiles_y = std::max(1, (g.ny - 1 + kTileCells - 1) / kTileCells);
  g.tile_max.assign(static_cast<size_t>(g.tiles_x) * g.tiles_y, 0.0f);
  g.max_height = 0;
  for (int tj = 0; tj < g.tiles_y; ++tj) {
    for (int ti = 0; ti < g.tiles_x; ++ti) {
      float m = 0;
      for (int j = tj * kTileCells; j <= std::min(g.ny - 1, (tj + 1) * kTileCells); ++j) {
        for (int i = ti * kTileCells; i <= std::min(g.nx - 1, (ti + 1) * kTileCells); ++i) {
          m = std::max(m, g.height[static_cast<size_t>(j) * g.nx + i]);
        }
      }
      g.tile_max[static_cast<size_t>(tj) * g.tiles_x + ti] = m;
      g.max_height = std::max(g.max_height, m);
    }
  }
  if (progress && !progress(1.0)) throw Cancelled("render");
}

double SimulatedRig::GridHeight(double x_mm, double y_mm) const {
  const ShadowGrid& g = grid_;
  const double gx = (x_mm - g.origin_x) / g.spacing;
  const double gy = (y_mm - g.origin_y) / g.spacing;
  if (!(gx >= 0 && gy >= 0 && gx <= g.nx - 1 && gy <= g.ny - 1)) return 0.0;
  const int ci = std::min(static_cast<int>(gx), g.nx - 2);
  const int cj = std::min(static_cast<int>(gy), g.ny - 2);
  const double fx = gx - ci, fy = gy - cj;
  const float* h0 = g.height.data() + static_cast<size_t>(cj) * g.nx + ci;
  const float* h1 = h0 + g.nx;
  return (1 - fy) * ((1 - fx) * h0[0] + fx * h0[1]) + fy * ((1 - fx) * h1[0] + fx * h1[1]);
}

bool SimulatedRig::Occluded(const Eigen::Vector3d& p, const Eigen::Vector3d& l, double distance_mm) const {
  const ShadowGrid& g = grid_;
  const double bias = options_.shadow_bias_mm;
  const double horizontal = std::hypot(l.x(), l.y());
  if (horizontal < 1e-12) return false;  // straight up: nothing above the surface point
  const double fine_step = 0.75 * g.spacing / horizontal;

  double s_end = distance_mm;
  const bool rising = l.z() > 0;
  if (rising) {
    const double top = g.max_height + bias;
    if (p.z() >= top) return false;
    s_end = std::min(s_end, (top - p.z()) / l.z());
  }
  // Clip to the grid's rectangle: off it the surface is the table (z = 0),
  // which a ray starting on or above it never dips under.
  double s_begin = 0;
  const double lo[2] = {g.origin_x, g.origin_y};
  const double hi[2] = {g.origin_x + (g.nx - 1) * g.spacing, g.origin_y + (g.ny - 1) * g.spacing};
  for (int a = 0; a < 2; ++a) {
    if (std::abs(l[a]) < 1e-15) {
      if (p[a] < lo[a] || p[a] > hi[a]) return false;
      continue;
    }
    const double t1 = (lo[a] - p[a]) / l[a];
    const double t2 = (hi[a] - p[a]) / l[a];
    s_begin = std::max(s_begin, std::min(t1, t2));
    s_end = std::min(s_end, std::max(t1, t2));
  }
  if (s_begin >= s_end) return false;

  const double tile_size = kTileCells * g.spacing;
  double s = std::max(s_begin, fine_step);  // the first step leaves the point's own cell
  while (s <= s_end) {
    const Eigen::Vector3d q = p + s * l;
    const double gx = (q.x() - g.origin_x) / g.spacing;
    const double gy = (q.y() - g.origin_y) / g.spacing;
    const int ci = std::clamp(static_cast<int>(gx), 0, g.nx - 2);
    const int cj = std::clamp(static_cast<int>(gy), 0, g.ny - 2);
    const int ti = ci / kTileCells;
    const int tj = cj / kTileCells;
    if (rising && q.z() - bias > g.tile_max[static_cast<size_t>(tj) * g.tiles_x + ti]) {
      // Above everything in this tile and still climbing: jump to its exit.
      const double x0 = g.origin_x + ti * tile_size, y0 = g.origin_y + tj * tile_size;
      double exit = std::numeric_limits<double>::infinity();
      if (l.x() > 0) exit = std::min(exit, (x0 + tile_size - q.x()) / l.x());
      if (l.x() < 0) exit = std::min(exit, (x0 - q.x()) / l.x());
      if (l.y() > 0) exit = std::min(exit, (y0 + tile_size - q.y()) / l.y());
      if (l.y() < 0) exit = std::min(exit, (y0 - q.y()) / l.y());
      s += std::max(exit, 0.0) + 1e-6;
      continue;
    }
    const double fx = gx - ci, fy = gy - cj;
    const float* h0 = g.height.data() + static_cast<size_t>(cj) * g.nx + ci;
    const float* h1 = h0 + g.nx;
    const double h = (1 - fy) * ((1 - fx) * h0[0] + fx * h0[1]) + fy * ((1 - fx) * h1[0] + fx * h1[1]);
    if (h > q.z() + bias) return true;
    s += fine_step;
  }
  return false;
}

Eigen::Vector3d SimulatedRig::PointAt(size_t i) const {
  return Eigen::Vector3d(point_in_table_[3 * i], point_in_table_[3 * i + 1], point_in_table_[3 * i + 2]);
}

Eigen::Vector3d SimulatedRig::NormalAt(size_t i) const {
  const double nx = normal_xy_in_table_[2 * i], ny = normal_xy_in_table_[2 * i + 1];
  return Eigen::Vector3d(nx, ny, std::sqrt(std::max(0.0, 1.0 - nx * nx - ny * ny)));
}

Eigen::Vector2d SimulatedRig::GradientAt(size_t i) const {
  const Eigen::Vector3d n = NormalAt(i);
  return Eigen::Vector2d(-n.x() / n.z(), -n.y() / n.z());
}

Eigen::Vector3d SimulatedRig::FootprintNormal(size_t i, int k, const Eigen::Vector2d& gradient) const {
  const int16_t* tilt = fibre_tilt_.data() + 2 * (static_cast<size_t>(options_.footprint_samples) * i + k);
  return Eigen::Vector3d(-(gradient.x() + kFibreTiltStep * tilt[0]), -(gradient.y() + kFibreTiltStep * tilt[1]), 1.0)
      .normalized();
}

Eigen::Vector3d SimulatedRig::TrueNormalAt(size_t i) const {
  if (!HasMaterial() || warp_weight_[i] < 0) return NormalAt(i);
  // The pixel-scale normal of a fibre-covered surface: the mean of the
  // shading normals its footprint averages, as rendered.
  const Eigen::Vector2d gradient = GradientAt(i);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int k = 0; k < options_.footprint_samples; ++k) sum += FootprintNormal(i, k, gradient);
  return sum.normalized();
}

std::vector<Eigen::Vector3d> SimulatedRig::FootprintShadingNormals(int x, int y) const {
  std::vector<Eigen::Vector3d> normals;
  if (x < 0 || y < 0 || x >= width() || y >= height()) {
    throw std::out_of_range("SimulatedRig: pixel " + std::to_string(x) + "," + std::to_string(y) +
                            " is outside the " + std::to_string(width()) + "x" + std::to_string(height()) + " image");
  }
  const size_t i = static_cast<size_t>(y) * options_.width + x;
  if (!HasMaterial() || warp_weight_[i] < 0) return normals;
  const Eigen::Vector2d gradient = GradientAt(i);
  for (int k = 0; k < options_.footprint_samples; ++k) normals.push_back(FootprintNormal(i, k, gradient));
  return normals;
}

double SimulatedRig::DirectFactor(size_t i, const LedDescription& led, bool cast_shadows) const {
  const Eigen::Vector3d point_in_table = PointAt(i);
  const Eigen::Vector3d to_led = led.position_in_table_mm - point_in_table;
  const double distance2 = to_led.squaredNorm();
  const double distance = std::sqrt(distance2);
  const Eigen::Vector3d light_dir_in_table = to_led / distance;
  const double n_dot_l = NormalAt(i).dot(light_dir_in_table);
  if (!(n_dot_l > 0)) return 0.0;
  const double cos_off_axis = -led.axis_in_table.dot(light_dir_in_table);
  if (!(cos_off_axis > 0)) return 0.0;
  const double falloff = led.mu == 0 ? 1.0 : std::pow(cos_off_axis, led.mu);
  const double factor =
      n_dot_l * falloff * (kLedReferenceDistanceMm * kLedReferenceDistanceMm / distance2);
  if (cast_shadows && Occluded(point_in_table, light_dir_in_table, distance)) return 0.0;
  return factor;
}

void SimulatedRig::MaterialDirect(size_t i, const LedDescription& led, bool cast_shadows, double* diffuse,
                                  double* specular) const {
  *diffuse = 0;
  *specular = 0;
  const float warp_weight = warp_weight_[i];
  if (warp_weight < 0) {  // the table: Lambertian
    *diffuse = DirectFactor(i, led, cast_shadows);
    return;
  }
  const Eigen::Vector3d point_in_table = PointAt(i);
  const Eigen::Vector3d to_led = led.position_in_table_mm - point_in_table;
  const double distance2 = to_led.squaredNorm();
  const double distance = std::sqrt(distance2);
  const Eigen::Vector3d l = to_led / distance;
  // The geometry decides what is lit (attached and cast shadows), the
  // fibre-tilted shading normals under the footprint how it reflects.
  if (!(NormalAt(i).dot(l) > 0)) return;
  const double cos_off_axis = -led.axis_in_table.dot(l);
  if (!(cos_off_axis > 0)) return;
  const double falloff = led.mu == 0 ? 1.0 : std::pow(cos_off_axis, led.mu);
  const double irradiance = falloff * (kLedReferenceDistanceMm * kLedReferenceDistanceMm / distance2);
  if (cast_shadows && Occluded(point_in_table, l, distance)) return;
  const Eigen::Vector3d v = (camera_centre_in_table_ - point_in_table).normalized();
  const SurfaceMaterial material = scene_.options().material;
  const ThreadBrdf& warp_brdf = warp_brdf_[thread_index_[2 * i]];
  const ThreadBrdf& weft_brdf = weft_brdf_[thread_index_[2 * i + 1]];
  // The footprint average of the response over the fibres' shading normals;
  // a thread with a negligible share of the surface is left out.
  const double w = warp_weight;
  const bool with_warp = w > 1e-6, with_weft = w < 1 - 1e-6;
  const Eigen::Vector2d gradient = GradientAt(i);
  const int samples = options_.footprint_samples;
  Eigen::Vector3d normals[64];
  for (int k = 0; k < samples; ++k) normals[k] = FootprintNormal(i, k, gradient);
  const std::span<const Eigen::Vector3d> footprint(normals, samples);
  // Warp threads run along table y, weft threads along x.
  MaterialResponse mean;
  if (with_warp) {
    const MaterialResponse r = MeanMaterialResponse(material, warp_brdf, footprint, Eigen::Vector3d::UnitY(), l, v);
    mean.diffuse += w * r.diffuse;
    mean.specular += w * r.specular;
  }
  if (with_weft) {
    const MaterialResponse r = MeanMaterialResponse(material, weft_brdf, footprint, Eigen::Vector3d::UnitX(), l, v);
    mean.diffuse += (1 - w) * r.diffuse;
    mean.specular += (1 - w) * r.specular;
  }
  *diffuse = irradiance * mean.diffuse;
  *specular = irradiance * mean.specular;
}

double SimulatedRig::SpecularAt(size_t i, const LedDescription& led) const {
  if (gloss_.empty() || gloss_[i] == 0) return 0.0;
  const Eigen::Vector3d point = PointAt(i);
  const Eigen::Vector3d half =
      ((led.position_in_table_mm - point).normalized() + (camera_centre_in_table_ - point).normalized()).normalized();
  const double cos_h = NormalAt(i).dot(half);
  if (!(cos_h > 0)) return 0.0;
  const double tan2_h = (1.0 - cos_h * cos_h) / (cos_h * cos_h);
  return gloss_[i] * std::exp(-tan2_h / gloss_tan2_width_);
}

ImageF SimulatedRig::RenderLinear(std::optional<int> lit_led_index, const ProgressCallback& progress) const {
  if (lit_led_index && (*lit_led_index < 0 || *lit_led_index >= num_leds())) {
    throw std::out_of_range("SimulatedRig: LED index " + std::to_string(*lit_led_index) + " is not in [0, " +
                            std::to_string(num_leds()) + ")");
  }
  const LedDescription* led = lit_led_index ? &rig_.leds[*lit_led_index] : nullptr;
  ImageF out(options_.width, options_.height, 3);
  ParallelRowsOrCancel("render", options_.height, NumThreads(), progress, 0.0, 1.0, [&](int y) {
    float* row = out.row(y);
    for (int x = 0; x < options_.width; ++x) {
      const size_t i = static_cast<size_t>(y) * options_.width + x;
      if (HasMaterial()) {
        double diffuse = 0, white = 0;
        if (led) MaterialDirect(i, *led, options_.cast_shadows, &diffuse, &white);
        for (int c = 0; c < 3; ++c) {
          const double e = led ? led->rgb_intensity[c] : 0.0;
          row[3 * x + c] = static_cast<float>(albedo_[3 * i + c] * (diffuse * e + options_.ambient) + white * e);
        }
        continue;
      }
      const double direct = led ? DirectFactor(i, *led, options_.cast_shadows) : 0.0;
      const double specular = direct > 0 ? SpecularAt(i, *led) : 0.0;
      for (int c = 0; c < 3; ++c) {
        const double irradiance = direct * (led ? led->rgb_intensity[c] : 0.0) + options_.ambient;
        row[3 * x + c] = static_cast<float>(albedo_[3 * i + c] * irradiance);
        if (specular > 0) row[3 * x + c] += static_cast<float>(specular * direct * led->rgb_intensity[c]);
      }
    }
  });
  return out;
}

RawImage RenderSensorMosaic(const SimulatedRigOptions& options, uint64_t frame_index,
                            const SensorRowFunction& linear_row, const ProgressCallback& progress) {
  options.Check();
  RawImage raw;
  raw.cfa = options.cfa;
  raw.black_level.fill(static_cast<uint16_t>(options.black_level));
  raw.white_level = static_cast<uint16_t>(options.white_level);
  raw.mosaic = ImageU16(options.width, options.height, 1);

  const double range_dn = options.white_level - options.black_level;
  const double gain = options.gain_e_per_dn;
  ParallelRowsOrCancel("render", options.height, ResolveThreadCount(options.num_threads), progress, 0.0, 1.0, [&](int y) {
    RowRng rng(RowSeed(options.seed, frame_index, y));
    std::vector<double> values(options.width);
    linear_row(y, values.data());
    uint16_t* row = raw.mosaic.row(y);
    for (int x = 0; x < options.width; ++x) {
      double signal_dn = values[x] * range_dn;
      if (options.add_noise) {
        const double electrons = rng.Poisson(signal_dn * gain);
        signal_dn = electrons / gain + options.read_noise_dn * rng.Gaussian();
      }
      const double dn = std::nearbyint(signal_dn + options.black_level);
      row[x] = static_cast<uint16_t>(std::clamp(dn, 0.0, static_cast<double>(options.white_level)));
    }
  });
  return raw;
}

RawImage SimulatedRig::RenderFrame(std::optional<int> lit_led_index, uint64_t frame_index,
                                   const ProgressCallback& progress) const {
  if (lit_led_index && (*lit_led_index < 0 || *lit_led_index >= num_leds())) {
    throw std::out_of_range("SimulatedRig: LED index " + std::to_string(*lit_led_index) + " is not in [0, " +
                            std::to_string(num_leds()) + ")");
  }
  const LedDescription* led = lit_led_index ? &rig_.leds[*lit_led_index] : nullptr;
  return RenderSensorMosaic(
      options_, frame_index,
      [&](int y, double* values) {
        for (int x = 0; x < options_.width; ++x) {
          const size_t i = static_cast<size_t>(y) * options_.width + x;
          const int c = CfaColorAt(options_.cfa, x, y);
          if (HasMaterial()) {
            // The specular part is the LED's own white; the diffuse part the thread's colour.
            double diffuse = 0, white = 0;
            if (led) MaterialDirect(i, *led, options_.cast_shadows, &diffuse, &white);
            const double e = led ? led->rgb_intensity[c] : 0.0;
            values[x] = albedo_[3 * i + c] * (diffuse * e + options_.ambient) + white * e;
            continue;
          }
          const double direct = led ? DirectFactor(i, *led, options_.cast_shadows) : 0.0;
          const double irradiance = direct * (led ? led->rgb_intensity[c] : 0.0) + options_.ambient;
          values[x] = albedo_[3 * i + c] * irradiance;
          // Gloss: the LED's own colour (raw white), off the solver's Lambertian model.
          if (direct > 0 && !gloss_.empty()) values[x] += SpecularAt(i, *led) * direct * led->rgb_intensity[c];
        }
      },
      progress);
}

ImageU8 SimulatedRig::RenderShadowMask(int led_index) const {
  if (led_index < 0 || led_index >= num_leds()) {
    throw std::out_of_range("SimulatedRig: LED index " + std::to_string(led_index) + " is not in [0, " +
                            std::to_string(num_leds()) + ")");
  }
  const LedDescription& led = rig_.leds[led_index];
  ImageU8 mask(options_.width, options_.height, 1);
  ParallelRowsOrCancel("render", options_.height, NumThreads(), {}, 0.0, 1.0, [&](int y) {
    for (int x = 0; x < options_.width; ++x) {
      const size_t i = static_cast<size_t>(y) * options_.width + x;
      mask(x, y) = DirectFactor(i, led, true) > 0 ? 0 : 1;
    }
  });
  return mask;
}

GroundTruthMaps SimulatedRig::RenderGroundTruth() const {
  GroundTruthMaps maps;
  const int w = options_.width, h = options_.height;
  maps.point_in_table = ImageF(w, h, 3);
  maps.normal_in_table = ImageF(w, h, 3);
  maps.albedo = ImageF(w, h, 3);
  maps.albedo_white_balanced_camera = ImageF(w, h, 3);
  maps.height_mm = ImageF(w, h, 1);
  maps.sample_mask = ImageU8(w, h, 1);
  maps.mm_per_pixel = mm_per_pixel_;
  ParallelRowsOrCancel("render", h, NumThreads(), {}, 0.0, 1.0, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const Eigen::Vector3d normal = TrueNormalAt(i);
      for (int c = 0; c < 3; ++c) {
        maps.point_in_table(x, y, c) = point_in_table_[3 * i + c];
        maps.normal_in_table(x, y, c) = static_cast<float>(normal[c]);
        maps.albedo(x, y, c) = camera_is_rec709_ ? albedo_[3 * i + c] : albedo_linear_rec709_[3 * i + c];
        maps.albedo_white_balanced_camera(x, y, c) = albedo_[3 * i + c];
      }
      maps.height_mm(x, y) = point_in_table_[3 * i + 2];
      maps.sample_mask(x, y) = scene_.OnSample(point_in_table_[3 * i], point_in_table_[3 * i + 1]) ? 1 : 0;
    }
  });
  return maps;
}

}  // namespace scanbench
