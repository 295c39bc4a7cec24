#include "app/sim/target_renderer.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

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

// Unit-variance value noise: a uniform random value per lattice point of
// spacing `cell` (mm), bilinearly interpolated.
double ValueNoise(double u, double v, double cell, uint64_t seed) {
  const double gu = u / cell, gv = v / cell;
  const double fu = std::floor(gu), fv = std::floor(gv);
  const int64_t iu = static_cast<int64_t>(fu), iv = static_cast<int64_t>(fv);
  auto lattice = [&](int64_t a, int64_t b) {
    const uint64_t h = Mix64(seed ^ Mix64(static_cast<uint64_t>(a) * 0x100000001B3ULL ^ static_cast<uint64_t>(b)));
    return (static_cast<double>(h >> 11) * 0x1.0p-53 - 0.5) * std::sqrt(12.0);
  };
  const double tu = gu - fu, tv = gv - fv;
  return (1 - tv) * ((1 - tu) * lattice(iu, iv) + tu * lattice(iu + 1, iv)) +
         tv * ((1 - tu) * lattice(iu, iv + 1) + tu * lattice(iu + 1, iv + 1));
}

// Where the plane through `origin` with normal `normal` meets the ray; t <= 0
// (or parallel) means behind the camera.
double RayPlaneT(const Eigen::Vector3d& camera, const Eigen::Vector3d& ray, const Eigen::Vector3d& origin,
                 const Eigen::Vector3d& normal) {
  const double denominator = normal.dot(ray);
  if (std::abs(denominator) < 1e-12) return -1;
  return normal.dot(origin - camera) / denominator;
}

// The geometry every target reduces to: a plane (table_from_target) and a
// reflectance over its (u, v), inside an extent; the table z = 0 elsewhere.
struct PlaneView {
  Eigen::Isometry3d table_from_target;
  Eigen::Isometry3d target_from_table;
  Eigen::Vector3d normal_in_table;
};

PlaneView PlaneOf(const SimulatedTarget& target) {
  PlaneView view;
  switch (target.kind) {
    case SimulatedTarget::Kind::kCheckerboard:
      view.table_from_target = target.table_from_target;
      break;
    case SimulatedTarget::Kind::kGrayChart:
      view.table_from_target = Eigen::Translation3d(0, 0, target.gray_chart.height_mm) * Eigen::Isometry3d::Identity();
      break;
    case SimulatedTarget::Kind::kWhiteSheet:
      view.table_from_target = Eigen::Translation3d(0, 0, target.white_sheet.height_mm) * Eigen::Isometry3d::Identity();
      break;
    case SimulatedTarget::Kind::kColorChart:
      view.table_from_target = Eigen::Translation3d(0, 0, target.chart_height_mm) * Eigen::Isometry3d::Identity();
      break;
  }
  view.target_from_table = view.table_from_target.inverse();
  view.normal_in_table = view.table_from_target.linear().col(2);
  return view;
}

// Half extent of the colour chart card: the patch grid plus the border.
Eigen::Vector2d ChartHalfSizeMm(const SimulatedTarget& t) {
  return 0.5 * Eigen::Vector2d((kColorCheckerColumns - 1) * t.chart_pitch_mm + t.chart_patch_mm + 2 * t.chart_border_mm,
                               (kColorCheckerRows - 1) * t.chart_pitch_mm + t.chart_patch_mm + 2 * t.chart_border_mm);
}

// White-balanced camera RGB at (u, v) of the colour chart; std::nullopt off it.
std::optional<Eigen::Vector3d> ChartCameraRgb(const SimulatedTarget& target, const std::vector<Eigen::Vector3d>& patch_rgb,
                                              double u, double v) {
  const Eigen::Vector2d half = ChartHalfSizeMm(target);
  if (std::abs(u) > half.x() || std::abs(v) > half.y()) return std::nullopt;
  const int patch = ColorCheckerPatchIndexAt(u, v, target.chart_patch_mm, target.chart_pitch_mm);
  return patch >= 0 ? patch_rgb[patch] : Eigen::Vector3d::Constant(target.chart_surround_reflectance);
}

// Reflectance at (u, v) of the target plane; std::nullopt off the target.
// The colour chart has no single reflectance: ChartCameraRgb.
std::optional<double> TargetReflectance(const SimulatedTarget& target, double u, double v) {
  switch (target.kind) {
    case SimulatedTarget::Kind::kCheckerboard: {
      const CheckerboardTarget& board = target.checkerboard;
      const double s = board.square_mm;
      const double half_w = 0.5 * (board.inner_corners_x + 1) * s;
      const double half_h = 0.5 * (board.inner_corners_y + 1) * s;
      if (std::abs(u) > half_w + target.board_margin_mm || std::abs(v) > half_h + target.board_margin_mm) {
        return std::nullopt;
      }
      if (std::abs(u) >= half_w || std::abs(v) >= half_h) return target.board_light_reflectance;
      // Square (a, b) from the top left; the top-left square is dark.
      const int a = static_cast<int>(std::floor((u + half_w) / s));
      const int b = static_cast<int>(std::floor((half_h - v) / s));
      return ((a + b) % 2 == 0) ? target.board_dark_reflectance : target.board_light_reflectance;
    }
    case SimulatedTarget::Kind::kGrayChart: {
      const double half_card = 0.5 * target.card_size_mm;
      if (std::abs(u) > half_card || std::abs(v) > half_card) return std::nullopt;
      for (const GrayPatch& patch : target.gray_chart.patches) {
        const double half = 0.5 * patch.size_mm;
        if (std::abs(u - patch.centre_in_table_mm.x()) <= half && std::abs(v - patch.centre_in_table_mm.y()) <= half) {
          return patch.reflectance;
        }
      }
      return target.card_reflectance;
    }
    case SimulatedTarget::Kind::kWhiteSheet: {
      if (std::abs(u) > 0.5 * target.sheet_size_mm.x() || std::abs(v) > 0.5 * target.sheet_size_mm.y()) {
        return std::nullopt;
      }
      const double texture =
          target.paper_texture > 0 ? target.paper_texture * ValueNoise(u, v, target.paper_texture_mm, target.paper_seed)
                                   : 0.0;
      return std::clamp(target.white_sheet.reflectance * (1.0 + texture), 0.0, 1.0);
    }
    case SimulatedTarget::Kind::kColorChart:
      break;
  }
  return std::nullopt;
}

int DefaultSupersampling(SimulatedTarget::Kind kind) {
  switch (kind) {
    case SimulatedTarget::Kind::kCheckerboard: return 4;
    case SimulatedTarget::Kind::kGrayChart: return 2;
    case SimulatedTarget::Kind::kWhiteSheet: return 1;
    case SimulatedTarget::Kind::kColorChart: return 2;
  }
  return 1;
}

// Separable Gaussian blur of a multi-channel image, edges clamped.
void GaussianBlur(ImageF& image, double sigma) {
  if (sigma <= 0) return;
  const int radius = std::max(1, static_cast<int>(std::ceil(3 * sigma)));
  std::vector<double> kernel(2 * radius + 1);
  double sum = 0;
  for (int i = -radius; i <= radius; ++i) sum += kernel[i + radius] = std::exp(-0.5 * i * i / (sigma * sigma));
  for (double& k : kernel) k /= sum;
  const int w = image.width(), h = image.height(), channels = image.channels();
  ImageF temp(w, h, channels);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < channels; ++c) {
        double acc = 0;
        for (int i = -radius; i <= radius; ++i) acc += kernel[i + radius] * image(std::clamp(x + i, 0, w - 1), y, c);
        temp(x, y, c) = static_cast<float>(acc);
      }
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < channels; ++c) {
        double acc = 0;
        for (int i = -radius; i <= radius; ++i) acc += kernel[i + radius] * temp(x, std::clamp(y + i, 0, h - 1), c);
        image(x, y, c) = static_cast<float>(acc);
      }
    }
  }
}

}  // namespace

// ---------------------------------------------------------------------------
SimulatedTarget SimulatedTarget::Checkerboard(const CheckerboardTarget& board, const Eigen::Isometry3d& pose) {
  SimulatedTarget target;
  target.kind = Kind::kCheckerboard;
  target.checkerboard = board;
  target.table_from_target = pose;
  return target;
}

SimulatedTarget SimulatedTarget::GrayChart(const GrayChartTarget& chart) {
  SimulatedTarget target;
  target.kind = Kind::kGrayChart;
  target.gray_chart = chart;
  return target;
}

SimulatedTarget SimulatedTarget::WhiteSheet(const WhiteSheetTarget& sheet) {
  SimulatedTarget target;
  target.kind = Kind::kWhiteSheet;
  target.white_sheet = sheet;
  return target;
}

SimulatedTarget SimulatedTarget::ColorChart(double patch_mm, double pitch_mm, double height_mm) {
  SimulatedTarget target;
  target.kind = Kind::kColorChart;
  target.chart_patch_mm = patch_mm;
  target.chart_pitch_mm = pitch_mm;
  target.chart_height_mm = height_mm;
  return target;
}

void SimulatedTarget::Check() const {
  const std::string where = "SimulatedTarget";
  auto check_reflectance = [&](const char* name, double value) {
    SCANBENCH_REQUIRE_GE_LE(where, name, value, 0, 1);
  };
  check_reflectance("table_reflectance", table_reflectance);
  switch (kind) {
    case Kind::kCheckerboard: {
      checkerboard.Check();
      const Eigen::Matrix3d r = table_from_target.linear();
      if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-9) ||
          !(r.determinant() > 0) || !table_from_target.translation().allFinite()) {
        throw FieldError(where, "table_from_target", "(not a rigid motion)", "must be a rotation and a finite translation");
      }
      if (!(table_from_target.linear()(2, 2) > 0)) {
        throw FieldError(where, "table_from_target", "(face turned down)", "must turn the board's face up (+z)");
      }
      SCANBENCH_REQUIRE_GE(where, "board_margin_mm", board_margin_mm, 0);
      check_reflectance("board_dark_reflectance", board_dark_reflectance);
      check_reflectance("board_light_reflectance", board_light_reflectance);
      break;
    }
    case Kind::kGrayChart:
      gray_chart.Check();
      SCANBENCH_REQUIRE_GT(where, "card_size_mm", card_size_mm, 0);
      check_reflectance("card_reflectance", card_reflectance);
      break;
    case Kind::kWhiteSheet:
      white_sheet.Check();
      SCANBENCH_REQUIRE_GT(where, "sheet_size_mm", sheet_size_mm.minCoeff(), 0);
      SCANBENCH_REQUIRE_GE_LE(where, "paper_texture", paper_texture, 0, 0.2);
      SCANBENCH_REQUIRE_GT(where, "paper_texture_mm", paper_texture_mm, 0);
      break;
    case Kind::kColorChart:
      SCANBENCH_REQUIRE_FINITE_GT(where, "chart_patch_mm", chart_patch_mm, 0);
      if (!(chart_pitch_mm >= chart_patch_mm) || !std::isfinite(chart_pitch_mm)) {
        throw FieldError(where, "chart_pitch_mm", chart_pitch_mm,
                         "must be finite and >= chart_patch_mm (" + std::to_string(chart_patch_mm) + ")");
      }
      SCANBENCH_REQUIRE_GE_LE(where, "chart_height_mm", chart_height_mm, 0, 200);
      SCANBENCH_REQUIRE_FINITE_GE(where, "chart_border_mm", chart_border_mm, 0);
      check_reflectance("chart_surround_reflectance", chart_surround_reflectance);
      SCANBENCH_REQUIRE_GE_LE(where, "chart_gloss", chart_gloss, 0, 0.2);
      SCANBENCH_REQUIRE_GT_LE(where, "chart_gloss_width_deg", chart_gloss_width_deg, 0, 45);
      break;
    default:
      throw FieldError(where, "kind", static_cast<int>(kind), "is not a SimulatedTarget::Kind");
  }
}

void TargetRenderOptions::Check() const {
  const std::string where = "TargetRenderOptions";
  SCANBENCH_REQUIRE_GT_LE(where, "exposure", exposure, 0, 100);
  SCANBENCH_REQUIRE_GE_LE(where, "blur_px", blur_px, 0, 50);
  SCANBENCH_REQUIRE_GE_LE(where, "supersampling", supersampling, 0, 16, "(0 = per target)");
  SCANBENCH_REQUIRE_GE_LE(where, "led_ripple", led_ripple, 0, 0.5);
  SCANBENCH_REQUIRE_GT_LE(where, "led_ripple_period_deg", led_ripple_period_deg, 0, 90);
}

// ---------------------------------------------------------------------------
TargetRenderer::TargetRenderer(const SimulatedRigOptions& sensor, RigDescription true_rig)
    : sensor_(sensor), rig_(std::move(true_rig)) {
  sensor_.Check();
  const CameraIntrinsics& k = rig_.camera.intrinsics;
  if (k.width != sensor_.width || k.height != sensor_.height) {
    throw std::invalid_argument("TargetRenderer: rig camera is " + std::to_string(k.width) + "x" +
                                std::to_string(k.height) + " but SimulatedRigOptions width x height = " +
                                std::to_string(sensor_.width) + "x" + std::to_string(sensor_.height) +
                                "; they must match");
  }
  rays_in_table_ = ComputeRayDirectionsInTable(rig_.camera);
  camera_centre_in_table_ = CameraCentreInTable(rig_.camera);
}

namespace {
int NumThreads(const SimulatedRigOptions& sensor) {
  return ResolveThreadCount(sensor.num_threads);
}
}  // namespace

PreparedTarget TargetRenderer::Prepare(const SimulatedTarget& target, const TargetRenderOptions& render) const {
  target.Check();
  render.Check();
  const int w = sensor_.width, h = sensor_.height;
  const PlaneView plane = PlaneOf(target);
  const Eigen::Vector3d& camera = camera_centre_in_table_;
  const int samples = render.supersampling > 0 ? render.supersampling : DefaultSupersampling(target.kind);
  const int num_threads = NumThreads(sensor_);

  // (u, v) of every pixel centre's ray on the target plane (also off the
  // target), for the sub-pixel samples' Jacobian.
  ImageF plane_uv(w, h, 2);
  auto ray_at = [&](int x, int y) {
    return Eigen::Vector3d(rays_in_table_(x, y, 0), rays_in_table_(x, y, 1), rays_in_table_(x, y, 2));
  };
  ParallelRowsOrCancel("render", h, num_threads, {}, 0, 1, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector3d ray = ray_at(x, y);
      const double t = RayPlaneT(camera, ray, plane.table_from_target.translation(), plane.normal_in_table);
      const Eigen::Vector3d uv = plane.target_from_table * (camera + std::max(t, 0.0) * ray);
      plane_uv(x, y, 0) = static_cast<float>(uv.x());
      plane_uv(x, y, 1) = static_cast<float>(uv.y());
    }
  });

  // The colour chart's patches through the sensor's colour model, from their measured spectra.
  const bool colour = target.kind == SimulatedTarget::Kind::kColorChart;
  std::vector<Eigen::Vector3d> patch_rgb;
  if (colour) {
    for (const ColorCheckerPatch& patch : ColorCheckerClassic()) {
      patch_rgb.push_back(WhiteBalancedCameraRgbOf(sensor_.color, patch.reflectance));
    }
  }
  const bool glossy = colour && target.chart_gloss > 0;

  PreparedTarget prepared;
  prepared.reflectance = ImageF(w, h, colour ? 3 : 1);
  prepared.point_in_table = ImageF(w, h, 3);
  prepared.normal_in_table = ImageF(w, h, 3);
  if (glossy) {
    prepared.gloss = ImageF(w, h, 1);
    prepared.gloss_width_deg = target.chart_gloss_width_deg;
  }
  ParallelRowsOrCancel("render", h, num_threads, {}, 0, 1, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector3d ray = ray_at(x, y);
      // Jacobian of (u, v) over the pixel, from the neighbouring centres.
      const int x0 = std::max(0, x - 1), x1 = std::min(w - 1, x + 1);
      const int y0 = std::max(0, y - 1), y1 = std::min(h - 1, y + 1);
      const Eigen::Vector2d du((plane_uv(x1, y, 0) - plane_uv(x0, y, 0)) / std::max(1, x1 - x0),
                               (plane_uv(x1, y, 1) - plane_uv(x0, y, 1)) / std::max(1, x1 - x0));
      const Eigen::Vector2d dv((plane_uv(x, y1, 0) - plane_uv(x, y0, 0)) / std::max(1, y1 - y0),
                               (plane_uv(x, y1, 1) - plane_uv(x, y0, 1)) / std::max(1, y1 - y0));
      const Eigen::Vector2d centre(plane_uv(x, y, 0), plane_uv(x, y, 1));
      const double t = RayPlaneT(camera, ray, plane.table_from_target.translation(), plane.normal_in_table);
      double reflectance_sum = 0;
      Eigen::Vector3d rgb_sum = Eigen::Vector3d::Zero();
      int on_target = 0;
      for (int sy = 0; sy < samples; ++sy) {
        for (int sx = 0; sx < samples; ++sx) {
          const double ox = (sx + 0.5) / samples - 0.5, oy = (sy + 0.5) / samples - 0.5;
          const Eigen::Vector2d uv = centre + ox * du + oy * dv;
          if (colour) {
            const std::optional<Eigen::Vector3d> rgb =
                t > 0 ? ChartCameraRgb(target, patch_rgb, uv.x(), uv.y()) : std::nullopt;
            rgb_sum += rgb.value_or(Eigen::Vector3d::Constant(target.table_reflectance));
            on_target += rgb.has_value();
            continue;
          }
          const std::optional<double> r = t > 0 ? TargetReflectance(target, uv.x(), uv.y()) : std::nullopt;
          reflectance_sum += r.value_or(target.table_reflectance);
          on_target += r.has_value();
        }
      }
      if (colour) {
        for (int c = 0; c < 3; ++c) prepared.reflectance(x, y, c) = static_cast<float>(rgb_sum[c] / (samples * samples));
      } else {
        prepared.reflectance(x, y) = static_cast<float>(reflectance_sum / (samples * samples));
      }
      if (glossy) prepared.gloss(x, y) = static_cast<float>(target.chart_gloss * on_target / (samples * samples));
      // Lit where the centre's ray lands: the target if it is there, else the table.
      Eigen::Vector3d point, normal;
      if (t > 0 && on_target * 2 >= samples * samples) {
        point = camera + t * ray;
        normal = plane.normal_in_table;
      } else {
        point = camera + (-camera.z() / ray.z()) * ray;
        normal = Eigen::Vector3d::UnitZ();
      }
      for (int c = 0; c < 3; ++c) {
        prepared.point_in_table(x, y, c) = static_cast<float>(point[c]);
        prepared.normal_in_table(x, y, c) = static_cast<float>(normal[c]);
      }
    }
  });
  return prepared;
}

ImageF TargetRenderer::RenderLinear(const PreparedTarget& target, const std::vector<int>& leds,
                                    const TargetRenderOptions& render) const {
  render.Check();
  for (const int led : leds) {
    if (led < 0 || led >= num_leds()) {
      throw std::out_of_range("TargetRenderer: LED index " + std::to_string(led) + " is not in [0, " +
                              std::to_string(num_leds()) + ")");
    }
  }
  const int w = sensor_.width, h = sensor_.height;
  if (!target.reflectance.SameSize(w, h)) {
    throw std::invalid_argument("TargetRenderer: prepared target is " + std::to_string(target.reflectance.width()) +
                                "x" + std::to_string(target.reflectance.height()) + ", the sensor " +
                                std::to_string(w) + "x" + std::to_string(h));
  }
  const int reflectance_channels = target.reflectance.channels();
  const bool glossy = !target.gloss.empty();
  const double gloss_tan2_width = std::pow(std::tan(target.gloss_width_deg * kPi / 180.0), 2);
  ImageF out(w, h, 3);
  ParallelRowsOrCancel("render", h, NumThreads(sensor_), {}, 0, 1, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector3d point(target.point_in_table(x, y, 0), target.point_in_table(x, y, 1),
                                  target.point_in_table(x, y, 2));
      const Eigen::Vector3d normal(target.normal_in_table(x, y, 0), target.normal_in_table(x, y, 1),
                                   target.normal_in_table(x, y, 2));
      Eigen::Vector3d irradiance = Eigen::Vector3d::Constant(sensor_.ambient);
      Eigen::Vector3d specular = Eigen::Vector3d::Zero();  // added radiance of the gloss, per reflectance 1
      for (const int k : leds) {
        const LedDescription& led = rig_.leds[k];
        const Eigen::Vector3d to_led = led.position_in_table_mm - point;
        const double distance2 = to_led.squaredNorm();
        const Eigen::Vector3d l = to_led / std::sqrt(distance2);
        const double n_dot_l = normal.dot(l);
        const double cos_off_axis = -led.axis_in_table.dot(l);
        if (!(n_dot_l > 0) || !(cos_off_axis > 0)) continue;
        double falloff = led.mu == 0 ? 1.0 : std::pow(cos_off_axis, led.mu);
        if (render.led_ripple > 0) {
          const double off_axis_deg = std::acos(std::min(1.0, cos_off_axis)) * 180.0 / kPi;
          falloff *= 1.0 + render.led_ripple * std::sin(2 * kPi * off_axis_deg / render.led_ripple_period_deg);
        }
        const Eigen::Vector3d direct =
            (n_dot_l * falloff * kLedReferenceDistanceMm * kLedReferenceDistanceMm / distance2) * led.rgb_intensity;
        irradiance += direct;
        if (glossy && target.gloss(x, y) > 0) {
          const Eigen::Vector3d half = (l + (camera_centre_in_table_ - point).normalized()).normalized();
          const double cos_h = normal.dot(half);
          const double tan2_h = (1.0 - cos_h * cos_h) / (cos_h * cos_h);
          if (cos_h > 0) specular += target.gloss(x, y) * std::exp(-tan2_h / gloss_tan2_width) * direct;
        }
      }
      for (int c = 0; c < 3; ++c) {
        const double reflectance = target.reflectance(x, y, reflectance_channels == 3 ? c : 0);
        out(x, y, c) = static_cast<float>(render.exposure * reflectance * irradiance[c] + render.exposure * specular[c]);
      }
    }
  });
  GaussianBlur(out, render.blur_px);
  return out;
}

ImageF TargetRenderer::RenderLinear(const SimulatedTarget& target, std::optional<int> led,
                                    const TargetRenderOptions& render) const {
  const std::vector<int> leds = led ? std::vector<int>{*led} : std::vector<int>{};
  return RenderLinear(Prepare(target, render), leds, render);
}

RawImage TargetRenderer::RenderFrame(const PreparedTarget& target, const std::vector<int>& leds,
                                     uint64_t frame_index, const TargetRenderOptions& render) const {
  const ImageF linear = RenderLinear(target, leds, render);
  return RenderSensorMosaic(sensor_, frame_index, [&](int y, double* values) {
    for (int x = 0; x < sensor_.width; ++x) values[x] = linear(x, y, CfaColorAt(sensor_.cfa, x, y));
  });
}

RawImage TargetRenderer::RenderFrame(const SimulatedTarget& target, std::optional<int> led, uint64_t frame_index,
                                     const TargetRenderOptions& render) const {
  const std::vector<int> leds = led ? std::vector<int>{*led} : std::vector<int>{};
  return RenderFrame(Prepare(target, render), leds, frame_index, render);
}

// ---------------------------------------------------------------------------
std::vector<Eigen::Isometry3d> DefaultCheckerboardPoses() {
  struct Pose {
    double tilt_x_deg, tilt_y_deg, turn_z_deg, x_mm, y_mm, height_mm;
  };
  constexpr Pose kPoses[] = {
      {0, 0, 0, 0, 0, 0},          // flat on the table: fixes the table pose
      {30, 0, 2, 0, 2, 50},        {-30, 0, -2, 0, -2, 50},    {0, 32, 3, 2, 0, 50},
      {0, -32, -3, -2, 0, 50},     {22, 22, 4, 4, -2, 60},     {-20, 25, -4, -4, 2, 40},
      {25, -20, 2, 3, 3, 70},      {-24, -24, -2, -3, -3, 30},
  };
  std::vector<Eigen::Isometry3d> poses;
  for (const Pose& p : kPoses) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = (Eigen::AngleAxisd(p.turn_z_deg * kPi / 180, Eigen::Vector3d::UnitZ()) *
                     Eigen::AngleAxisd(p.tilt_y_deg * kPi / 180, Eigen::Vector3d::UnitY()) *
                     Eigen::AngleAxisd(p.tilt_x_deg * kPi / 180, Eigen::Vector3d::UnitX()))
                        .toRotationMatrix();
    pose.translation() = Eigen::Vector3d(p.x_mm, p.y_mm, p.height_mm);
    poses.push_back(pose);
  }
  return poses;
}

void MeasuredRigOptions::Check() const {
  const std::string where = "MeasuredRigOptions";
  SCANBENCH_REQUIRE_GE_LE(where, "led_position_error_mm", led_position_error_mm, 0, 50);
  SCANBENCH_REQUIRE_FINITE_GE(where, "nominal_mu", nominal_mu, 0);
}

RigDescription MakeMeasuredRigDescription(const RigDescription& truth, const MeasuredRigOptions& options) {
  options.Check();
  RigDescription measured = truth;
  measured.name = truth.name + " (measured, uncalibrated)";

  // Nominal camera: thin-lens image distance of an 85 mm lens at 600 mm over
  // the D5100's pixel pitch, centred, undistorted, straight down.
  constexpr double kLensFocalMm = 85.0, kWorkingDistanceMm = 600.0;
  const double image_distance_mm = kLensFocalMm * kWorkingDistanceMm / (kWorkingDistanceMm - kLensFocalMm);
  CameraIntrinsics& k = measured.camera.intrinsics;
  k.fx = image_distance_mm / (kD5100SensorWidthMm / k.width);
  k.fy = image_distance_mm / (kD5100SensorHeightMm / k.height);
  k.cx = 0.5 * (k.width - 1);
  k.cy = 0.5 * (k.height - 1);
  k.k1 = k.k2 = k.k3 = k.p1 = k.p2 = 0;
  Eigen::Isometry3d table_from_cam = Eigen::Isometry3d::Identity();
  table_from_cam.linear() = Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  table_from_cam.translation() = Eigen::Vector3d(0, 0, kWorkingDistanceMm);
  measured.camera.cam_from_table = table_from_cam.inverse();

  // LEDs: tape-measure positions, aimed at the origin, datasheet falloff,
  // one nominal intensity for all.
  Eigen::Vector3d mean_intensity = Eigen::Vector3d::Zero();
  for (const LedDescription& led : truth.leds) mean_intensity += led.rgb_intensity;
  if (!truth.leds.empty()) mean_intensity /= static_cast<double>(truth.leds.size());
  // Standard normal errors from the seed alone (Box-Muller on a hash), not
  // from <random>'s distributions, which differ between libraries.
  uint64_t counter = 0;
  auto uniform = [&] { return (static_cast<double>(Mix64(Mix64(options.seed) ^ counter++) >> 11) + 0.5) * 0x1.0p-53; };
  auto gaussian = [&] { return std::sqrt(-2.0 * std::log(uniform())) * std::cos(2.0 * kPi * uniform()); };
  for (LedDescription& led : measured.leds) {
    const Eigen::Vector3d offset(gaussian(), gaussian(), gaussian());
    led.position_in_table_mm += options.led_position_error_mm * offset;
    led.axis_in_table = -led.position_in_table_mm.normalized();
    led.mu = options.nominal_mu;
    led.rgb_intensity = mean_intensity;
  }
  return measured;
}

}  // namespace scanbench
