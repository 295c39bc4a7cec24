#include "app/sim/textile_scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "app/sim/split_mix.h"
#include "calibration/color_checker.h"
#include "core/field_error.h"

namespace scanbench {
using sim_internal::Mix64;
namespace {

constexpr double kPi = std::numbers::pi;

constexpr char kOptions[] = "TextileSceneOptions";

void CheckRgb(const std::string& field, const Eigen::Vector3d& rgb) {
  for (int c = 0; c < 3; ++c) {
    SCANBENCH_REQUIRE_GE_LE(kOptions, field + "[" + std::to_string(c) + "]", rgb[c], 0, 1);
  }
}

// Uniform in [-1, 1), reproducible from its arguments.
double HashSigned(uint64_t seed, uint64_t stream, int64_t index) {
  const uint64_t h = Mix64(Mix64(Mix64(seed) ^ stream) ^ static_cast<uint64_t>(index));
  return static_cast<double>(h >> 11) * 0x1.0p-52 - 1.0;
}

// Streams of HashSigned, one per kind of variation.
enum Stream : uint64_t {
  kWarpCrown = 1,
  kWeftCrown,
  kWarpShade,
  kWeftShade,
  kWarpTint,   // + channel
  kWeftTint = kWarpTint + 3,
  kWarpSlubPhase = kWeftTint + 3,
  kWeftSlubPhase,
  kFolds,
  kWarpF0,
  kWeftF0,
  kWarpRoughness,
  kWeftRoughness,
  kWarpFibreAcross,
  kWeftFibreAcross,
  kWarpFibreAlong,
  kWeftFibreAlong,
};

// 0 -> 0, 1 -> 1 with zero first and second derivatives at both ends (C2).
double SmootherStep(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * t * (t * (6.0 * t - 15.0) + 10.0);
}
double SmootherStepDerivative(double t) {
  if (t <= 0.0 || t >= 1.0) return 0.0;
  return 30.0 * t * t * (1.0 - t) * (1.0 - t);
}

// Slub (thickness/colour irregularity) period along a thread, mm.
constexpr double kWarpSlubPeriodMm = 9.7;
constexpr double kWeftSlubPeriodMm = 7.3;

// The weave relief at one point: both threads there, and how the visible
// surface blends them. Warp thread i covers x in [i, i+1) * warp pitch, weft j
// covers y in [j, j+1) * weft pitch.
struct WeaveRelief {
  int64_t warp_index = 0, weft_index = 0;
  double fu = 0, fv = 0;                  // across the warp and weft thread, [-0.5, 0.5)
  double period = 2;                      // wefts (warps) per over/under cycle
  double warp_phase = 0, weft_phase = 0;  // rad, of the crowns' cos along the thread
  double warp_crown = 0, weft_crown = 0;  // mm, of each thread's centre line
  double profile_u = 0, profile_v = 0;    // cos^2 cross-section factors
  double w_warp = 0, w_weft = 0;          // soft-maximum weights, sum 1
  double relief = 0;                      // mm, the visible surface above the base
};

WeaveRelief WeaveAt(const TextileSceneOptions& o, double x_mm, double y_mm) {
  WeaveRelief w;
  const double u = x_mm / o.warp_pitch_mm;
  const double v = y_mm / o.weft_pitch_mm;
  const double iu = std::floor(u);
  const double jv = std::floor(v);
  w.warp_index = static_cast<int64_t>(iu);
  w.weft_index = static_cast<int64_t>(jv);
  w.fu = u - iu - 0.5;
  w.fv = v - jv - 0.5;

  // Over/under pattern: the crown of warp i follows cos(phase) along y with a
  // period of `period` wefts, shifted one weft per warp; weft j is the mirror
  // image, so at every crossing one thread is up where the other is down.
  w.period = o.weave == WeavePattern::kPlain ? 2.0 : 4.0;
  const double offset = o.weave == WeavePattern::kPlain ? 0.0 : 0.5;  // twill: crossings at +-45 deg
  w.warp_phase = 2.0 * kPi * (v - 0.5 - iu - offset) / w.period;
  w.weft_phase = 2.0 * kPi * (jv - (u - 0.5) - offset) / w.period;
  const double amplitude = o.crossing_amplitude_mm;
  w.warp_crown = o.thread_height_mm * (1.0 + o.thread_height_variation * HashSigned(o.seed, kWarpCrown, w.warp_index)) +
                 amplitude * std::cos(w.warp_phase);
  w.weft_crown = o.thread_height_mm * (1.0 + o.thread_height_variation * HashSigned(o.seed, kWeftCrown, w.weft_index)) -
                 amplitude * std::cos(w.weft_phase);

  // Rounded cross-section cos^2: zero height and slope at a thread's borders,
  // so neighbouring threads with different crowns still meet continuously.
  const double cos_u = std::cos(kPi * w.fu);
  const double cos_v = std::cos(kPi * w.fv);
  w.profile_u = cos_u * cos_u;
  w.profile_v = cos_v * cos_v;
  const double warp_z = w.profile_u * w.warp_crown;
  const double weft_z = w.profile_v * w.weft_crown;

  // Visible relief: soft maximum (log-sum-exp) of the two thread surfaces, so
  // the normal stays continuous where one thread dives under the other.
  const double k = o.smoothing_mm;
  const double top = std::max(warp_z, weft_z);
  const double e_other = std::exp(-std::abs(warp_z - weft_z) / k);  // the lower thread's term; the upper's is 1
  const double e_sum = 1.0 + e_other;
  w.w_warp = (warp_z >= weft_z ? 1.0 : e_other) / e_sum;
  w.w_weft = 1.0 - w.w_warp;
  w.relief = top + k * std::log1p(e_other);
  return w;
}

// d relief / d (x, y), mm per mm, from the two threads' analytic slopes.
Eigen::Vector2d WeaveGradient(const TextileSceneOptions& o, const WeaveRelief& w) {
  const double amplitude = o.crossing_amplitude_mm;
  const double profile_u_dx = -kPi * std::sin(2.0 * kPi * w.fu) / o.warp_pitch_mm;
  const double profile_v_dy = -kPi * std::sin(2.0 * kPi * w.fv) / o.weft_pitch_mm;
  const Eigen::Vector2d warp_grad(profile_u_dx * w.warp_crown,
                                  w.profile_u * (-amplitude * std::sin(w.warp_phase)) * 2.0 * kPi /
                                      (w.period * o.weft_pitch_mm));
  const Eigen::Vector2d weft_grad(w.profile_v * (amplitude * std::sin(w.weft_phase)) * (-2.0 * kPi) /
                                      (w.period * o.warp_pitch_mm),
                                  profile_v_dy * w.weft_crown);
  return w.w_warp * warp_grad + w.w_weft * weft_grad;
}

// Linear RGB in [0, 1]: each thread's colour with its shade, slubs and tint;
// the thread on top shows its colour, the gaps between threads are darker.
Eigen::Vector3d ThreadAlbedo(const TextileSceneOptions& o, const WeaveRelief& w, double x_mm, double y_mm) {
  const double cv = o.color_variation;
  Eigen::Vector3d warp_rgb = o.warp_rgb;
  Eigen::Vector3d weft_rgb = o.weft_rgb;
  const double warp_shade = 1.0 + cv * HashSigned(o.seed, kWarpShade, w.warp_index);
  const double weft_shade = 1.0 + cv * HashSigned(o.seed, kWeftShade, w.weft_index);
  // Slubs: slow brightness variation along each thread.
  const double warp_slub =
      1.0 + 0.5 * cv *
                std::sin(2.0 * kPi * y_mm / kWarpSlubPeriodMm + kPi * HashSigned(o.seed, kWarpSlubPhase, w.warp_index));
  const double weft_slub =
      1.0 + 0.5 * cv *
                std::sin(2.0 * kPi * x_mm / kWeftSlubPeriodMm + kPi * HashSigned(o.seed, kWeftSlubPhase, w.weft_index));
  for (int c = 0; c < 3; ++c) {
    warp_rgb[c] *= warp_shade * warp_slub * (1.0 + 0.3 * cv * HashSigned(o.seed, kWarpTint + c, w.warp_index));
    weft_rgb[c] *= weft_shade * weft_slub * (1.0 + 0.3 * cv * HashSigned(o.seed, kWeftTint + c, w.weft_index));
  }
  const double cover = o.thread_height_mm > 0 ? std::min(1.0, w.relief / o.thread_height_mm) : 1.0;
  const double gap_factor = 1.0 - o.gap_darkening * (1.0 - cover);
  return ((w.w_warp * warp_rgb + w.w_weft * weft_rgb) * gap_factor).cwiseMax(0.0).cwiseMin(1.0);
}

// The fibre tilt (a gradient, dimensionless) of the threads at `w`: fibre k
// of a thread covers [k, k+1) fibre diameters across it (x for the warp, y for
// the weft); along the thread it is inclined by a sine of fibre_wavelength_mm
// with its own phase, sideways by its own constant. Both average to zero over
// the ~100 fibres of a thread (and the sine over its wavelength).
Eigen::Vector2d FibreTilt(const TextileSceneOptions& o, double warp_weight, double x_mm, double y_mm) {
  const double amplitude = std::tan(o.fibre_tilt_deg * kPi / 180.0);
  const double along = 2.0 * kPi / o.fibre_wavelength_mm;
  const auto warp_fibre = static_cast<int64_t>(std::floor(x_mm / o.fibre_diameter_mm));
  const auto weft_fibre = static_cast<int64_t>(std::floor(y_mm / o.fibre_diameter_mm));
  // Warp fibres run along y: their inclination tilts the normal along y.
  const Eigen::Vector2d warp(amplitude * HashSigned(o.seed, kWarpFibreAcross, warp_fibre),
                             amplitude * std::sin(along * y_mm + kPi * HashSigned(o.seed, kWarpFibreAlong, warp_fibre)));
  const Eigen::Vector2d weft(amplitude * std::sin(along * x_mm + kPi * HashSigned(o.seed, kWeftFibreAlong, weft_fibre)),
                             amplitude * HashSigned(o.seed, kWeftFibreAcross, weft_fibre));
  return warp_weight * warp + (1.0 - warp_weight) * weft;
}

void CheckThreadBrdf(const std::string& field, const ThreadBrdf& b) {
  SCANBENCH_REQUIRE_GE_LE(kOptions, field + ".specular_f0", b.specular_f0, 0, 1);
  SCANBENCH_REQUIRE_GT_LE(kOptions, field + ".roughness", b.roughness, 0, 2);
  SCANBENCH_REQUIRE_GT_LE(kOptions, field + ".roughness_across", b.roughness_across, 0, 2);
}

// The card's outline: the patch grid plus the border on every side.
Eigen::Vector2d ChartCardSizeMm(const TextileSceneOptions& o) {
  return Eigen::Vector2d((kColorCheckerColumns - 1) * o.chart_pitch_mm + o.chart_patch_mm,
                         (kColorCheckerRows - 1) * o.chart_pitch_mm + o.chart_patch_mm) +
         Eigen::Vector2d::Constant(2.0 * o.chart_border_mm);
}

void CheckChart(const TextileSceneOptions& o) {
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "chart_patch_mm", o.chart_patch_mm, 0);
  if (!(o.chart_pitch_mm >= o.chart_patch_mm) || !std::isfinite(o.chart_pitch_mm)) {
    throw FieldError(kOptions, "chart_pitch_mm", o.chart_pitch_mm,
                     "must be finite and >= chart_patch_mm (" + std::to_string(o.chart_patch_mm) + ")");
  }
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "chart_border_mm", o.chart_border_mm, 0);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "chart_thickness_mm", o.chart_thickness_mm, 0, 5);
  const double half_smaller = 0.5 * ChartCardSizeMm(o).minCoeff();
  if (!(o.chart_edge_blend_mm > 0 && o.chart_edge_blend_mm <= std::min(10.0, half_smaller))) {
    throw FieldError(kOptions, "chart_edge_blend_mm", o.chart_edge_blend_mm,
                     "must lie in (0, " + std::to_string(std::min(10.0, half_smaller)) + "]");
  }
  CheckRgb("chart_surround_rgb", o.chart_surround_rgb);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "chart_gloss", o.chart_gloss, 0, 0.2);
  SCANBENCH_REQUIRE_GT_LE(kOptions, "chart_gloss_width_deg", o.chart_gloss_width_deg, 0, 45);
}

}  // namespace

int ColorCheckerPatchIndexAt(double u_mm, double v_mm, double patch_mm, double pitch_mm) {
  // Column 0 is leftmost (-u), row 0 the top (+v); centres at multiples of the pitch.
  const double column = std::floor(u_mm / pitch_mm + 0.5 * kColorCheckerColumns);
  const double row = std::floor(0.5 * kColorCheckerRows - v_mm / pitch_mm);
  if (!(column >= 0 && column < kColorCheckerColumns && row >= 0 && row < kColorCheckerRows)) return -1;
  const double centre_u = (column - 0.5 * (kColorCheckerColumns - 1)) * pitch_mm;
  const double centre_v = (0.5 * (kColorCheckerRows - 1) - row) * pitch_mm;
  if (std::abs(u_mm - centre_u) > 0.5 * patch_mm || std::abs(v_mm - centre_v) > 0.5 * patch_mm) return -1;
  return static_cast<int>(row) * kColorCheckerColumns + static_cast<int>(column);
}

void TextileSceneOptions::Check() const {
  if (sample != SampleKind::kTextile && sample != SampleKind::kColorChecker) {
    throw FieldError(kOptions, "sample", static_cast<int>(sample), "must be kTextile or kColorChecker");
  }
  if (sample == SampleKind::kColorChecker) CheckChart(*this);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "sample_width_mm", sample_width_mm, 0);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "sample_height_mm", sample_height_mm, 0);
  const double half_smaller = 0.5 * std::min(sample_width_mm, sample_height_mm);
  if (!(edge_blend_mm > 0 && edge_blend_mm <= half_smaller)) {
    throw FieldError(kOptions, "edge_blend_mm", edge_blend_mm,
                     "must lie in (0, " + std::to_string(half_smaller) + "] (half the smaller sample extent)");
  }
  if (weave != WeavePattern::kPlain && weave != WeavePattern::kTwill) {
    throw FieldError(kOptions, "weave", static_cast<int>(weave), "must be kPlain or kTwill");
  }
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "warp_pitch_mm", warp_pitch_mm, 0);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "weft_pitch_mm", weft_pitch_mm, 0);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "thread_height_mm", thread_height_mm, 0);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "crossing_amplitude_mm", crossing_amplitude_mm, 0);
  SCANBENCH_REQUIRE_GE_LT(kOptions, "thread_height_variation", thread_height_variation, 0, 1);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "smoothing_mm", smoothing_mm, 0);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "base_thickness_mm", base_thickness_mm, 0);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "fold_amplitude_mm", fold_amplitude_mm, 0);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "num_fold_waves", num_fold_waves, 0, 64);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "fold_min_wavelength_mm", fold_min_wavelength_mm, 0);
  if (!(fold_max_wavelength_mm >= fold_min_wavelength_mm) || !std::isfinite(fold_max_wavelength_mm)) {
    throw FieldError(kOptions, "fold_max_wavelength_mm", fold_max_wavelength_mm,
                     "must be finite and >= fold_min_wavelength_mm (" + std::to_string(fold_min_wavelength_mm) +
                         ")");
  }
  CheckRgb("warp_rgb", warp_rgb);
  CheckRgb("weft_rgb", weft_rgb);
  CheckRgb("table_rgb", table_rgb);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "color_variation", color_variation, 0, 0.5);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "gap_darkening", gap_darkening, 0, 1);
  if (material != SurfaceMaterial::kLambert && material != SurfaceMaterial::kCloth &&
      material != SurfaceMaterial::kSatin) {
    throw FieldError(kOptions, "material", static_cast<int>(material), "must be kLambert, kCloth or kSatin");
  }
  CheckThreadBrdf("cloth_warp", cloth_warp);
  CheckThreadBrdf("cloth_weft", cloth_weft);
  CheckThreadBrdf("satin_warp", satin_warp);
  CheckThreadBrdf("satin_weft", satin_weft);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "material_variation", material_variation, 0, 0.5);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "fibre_tilt_deg", fibre_tilt_deg, 0, 20);
  SCANBENCH_REQUIRE_GT_LE(kOptions, "fibre_diameter_mm", fibre_diameter_mm, 0, 0.1, "mm");
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "fibre_wavelength_mm", fibre_wavelength_mm, 0);
}

ThreadBrdf TextileScene::ThreadBrdfOf(bool warp, int64_t index) const {
  const TextileSceneOptions& o = options_;
  ThreadBrdf b = o.material == SurfaceMaterial::kSatin ? (warp ? o.satin_warp : o.satin_weft)
                                                       : (warp ? o.cloth_warp : o.cloth_weft);
  const double f0_scale = 1.0 + o.material_variation * HashSigned(o.seed, warp ? kWarpF0 : kWeftF0, index);
  const double rough_scale =
      1.0 + o.material_variation * HashSigned(o.seed, warp ? kWarpRoughness : kWeftRoughness, index);
  b.specular_f0 = std::clamp(b.specular_f0 * f0_scale, 0.0, 1.0);
  b.roughness = std::clamp(b.roughness * rough_scale, 1e-3, 2.0);
  b.roughness_across = std::clamp(b.roughness_across * rough_scale, 1e-3, 2.0);
  return b;
}

TextileScene::TextileScene(const TextileSceneOptions& options) : options_(options) {
  options_.Check();
  if (options_.sample == SampleKind::kColorChecker) {
    extent_mm_ = ChartCardSizeMm(options_);
    max_height_mm_ = options_.chart_thickness_mm;
    return;
  }
  extent_mm_ = Eigen::Vector2d(options_.sample_width_mm, options_.sample_height_mm);
  // Fold waves: random directions, log-uniform wavelengths, random phases and
  // weights normalised to 1 so the folds span exactly 0 .. 2 * amplitude at most.
  double weight_sum = 0;
  for (int k = 0; k < options_.num_fold_waves; ++k) {
    const double direction_rad = kPi * 0.5 * (1.0 + HashSigned(options_.seed, kFolds, 4 * k + 0));
    const double mix = 0.5 * (1.0 + HashSigned(options_.seed, kFolds, 4 * k + 1));
    const double wavelength_mm =
        options_.fold_min_wavelength_mm *
        std::pow(options_.fold_max_wavelength_mm / options_.fold_min_wavelength_mm, mix);
    FoldWave wave;
    wave.wave_vector = (2.0 * kPi / wavelength_mm) * Eigen::Vector2d(std::cos(direction_rad), std::sin(direction_rad));
    wave.phase = kPi * (1.0 + HashSigned(options_.seed, kFolds, 4 * k + 2));
    wave.weight = 0.7 + 0.3 * HashSigned(options_.seed, kFolds, 4 * k + 3);
    weight_sum += wave.weight;
    folds_.push_back(wave);
  }
  for (FoldWave& wave : folds_) wave.weight /= weight_sum;

  // Each thread's crown is at most (1 + variation) * height + amplitude; the
  // soft maximum adds at most smoothing * ln 2; the folds at most 2 * amplitude.
  max_height_mm_ = options_.base_thickness_mm +
                   options_.thread_height_mm * (1.0 + options_.thread_height_variation) +
                   options_.crossing_amplitude_mm + options_.smoothing_mm * std::numbers::ln2 +
                   (folds_.empty() ? 0.0 : 2.0 * options_.fold_amplitude_mm);
}

bool TextileScene::OnSample(double x_mm, double y_mm) const {
  return std::abs(x_mm) <= 0.5 * extent_mm_.x() && std::abs(y_mm) <= 0.5 * extent_mm_.y();
}

SurfaceSample TextileScene::Sample(double x_mm, double y_mm, bool with_albedo) const {
  return Evaluate(x_mm, y_mm, true, with_albedo);
}

SurfaceSample TextileScene::Evaluate(double x_mm, double y_mm, bool with_gradient, bool with_albedo) const {
  const TextileSceneOptions& o = options_;
  SurfaceSample out;
  if (!OnSample(x_mm, y_mm)) {
    out.albedo = o.table_rgb;
    return out;
  }
  if (o.sample == SampleKind::kColorChecker) return EvaluateChart(x_mm, y_mm, with_gradient, with_albedo);
  const WeaveRelief weave = WeaveAt(o, x_mm, y_mm);
  Eigen::Vector2d fold_gradient = Eigen::Vector2d::Zero();
  const double fold = FoldHeightMm(x_mm, y_mm, with_gradient ? &fold_gradient : nullptr);
  const double inner = o.base_thickness_mm + weave.relief + fold;

  // Edge blend: inner height times a C2 ramp in each direction.
  const double tx = (0.5 * o.sample_width_mm - std::abs(x_mm)) / o.edge_blend_mm;
  const double ty = (0.5 * o.sample_height_mm - std::abs(y_mm)) / o.edge_blend_mm;
  const double sx = SmootherStep(tx);
  const double sy = SmootherStep(ty);
  const double blend = sx * sy;
  out.height_mm = blend * inner;

  if (with_gradient) {
    const Eigen::Vector2d inner_grad = WeaveGradient(o, weave) + fold_gradient;
    const double sx_dx = SmootherStepDerivative(tx) * (x_mm < 0 ? 1.0 : -1.0) / o.edge_blend_mm;
    const double sy_dy = SmootherStepDerivative(ty) * (y_mm < 0 ? 1.0 : -1.0) / o.edge_blend_mm;
    out.gradient = blend * inner_grad + inner * Eigen::Vector2d(sx_dx * sy, sx * sy_dy);
  }
  out.warp_weight = weave.w_warp;
  out.warp_index = weave.warp_index;
  out.weft_index = weave.weft_index;
  if (with_albedo) out.albedo = ThreadAlbedo(o, weave, x_mm, y_mm);
  return out;
}

// A flat card: its thickness times the C2 edge ramp of the textile's, so the
// normal tilts only within chart_edge_blend_mm of the card's edge.
SurfaceSample TextileScene::EvaluateChart(double x_mm, double y_mm, bool with_gradient, bool with_albedo) const {
  const TextileSceneOptions& o = options_;
  SurfaceSample out;
  const double tx = (0.5 * extent_mm_.x() - std::abs(x_mm)) / o.chart_edge_blend_mm;
  const double ty = (0.5 * extent_mm_.y() - std::abs(y_mm)) / o.chart_edge_blend_mm;
  const double sx = SmootherStep(tx), sy = SmootherStep(ty);
  out.height_mm = o.chart_thickness_mm * sx * sy;
  if (with_gradient) {
    const double sx_dx = SmootherStepDerivative(tx) * (x_mm < 0 ? 1.0 : -1.0) / o.chart_edge_blend_mm;
    const double sy_dy = SmootherStepDerivative(ty) * (y_mm < 0 ? 1.0 : -1.0) / o.chart_edge_blend_mm;
    out.gradient = o.chart_thickness_mm * Eigen::Vector2d(sx_dx * sy, sx * sy_dy);
  }
  out.gloss = o.chart_gloss;
  if (with_albedo) {
    out.spectral_patch = ColorCheckerPatchIndexAt(x_mm, y_mm, o.chart_patch_mm, o.chart_pitch_mm);
    out.albedo = out.spectral_patch >= 0 ? ColorCheckerClassic()[out.spectral_patch].linear_rec709
                                         : o.chart_surround_rgb;
  }
  return out;
}

Eigen::Vector2d TextileScene::FibreTiltGradient(double x_mm, double y_mm) const {
  return FibreTiltGradient(x_mm, y_mm, WeaveAt(options_, x_mm, y_mm).w_warp);
}

Eigen::Vector2d TextileScene::FibreTiltGradient(double x_mm, double y_mm, double warp_weight) const {
  const TextileSceneOptions& o = options_;
  if (o.sample != SampleKind::kTextile || o.material == SurfaceMaterial::kLambert || o.fibre_tilt_deg == 0 ||
      !OnSample(x_mm, y_mm)) {
    return Eigen::Vector2d::Zero();
  }
  // Faded with the edge blend, as the relief is, so the table edge stays clean.
  const double blend = SmootherStep((0.5 * o.sample_width_mm - std::abs(x_mm)) / o.edge_blend_mm) *
                       SmootherStep((0.5 * o.sample_height_mm - std::abs(y_mm)) / o.edge_blend_mm);
  return blend * FibreTilt(o, std::clamp(warp_weight, 0.0, 1.0), x_mm, y_mm);
}

double TextileScene::FoldHeightMm(double x_mm, double y_mm, Eigen::Vector2d* gradient) const {
  if (folds_.empty()) return 0;
  const double amplitude = options_.fold_amplitude_mm;
  double sum = 0;
  for (const FoldWave& wave : folds_) {
    const double arg = wave.wave_vector.x() * x_mm + wave.wave_vector.y() * y_mm + wave.phase;
    sum += wave.weight * std::sin(arg);
    if (gradient) *gradient += (amplitude * wave.weight * std::cos(arg)) * wave.wave_vector;
  }
  return amplitude * (1.0 + sum);
}

double TextileScene::HeightMm(double x_mm, double y_mm) const {
  return Evaluate(x_mm, y_mm, false, false).height_mm;
}

Eigen::Vector2d TextileScene::HeightGradient(double x_mm, double y_mm) const {
  return Sample(x_mm, y_mm, false).gradient;
}

Eigen::Vector3d TextileScene::NormalInTable(double x_mm, double y_mm) const {
  const Eigen::Vector2d g = HeightGradient(x_mm, y_mm);
  return Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
}

Eigen::Vector3d TextileScene::Albedo(double x_mm, double y_mm) const {
  return Evaluate(x_mm, y_mm, false, true).albedo;
}

}  // namespace scanbench
