#include "app/sim/observation_sets.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>

#include <Eigen/Geometry>

#include "app/sim/shading_models.h"
#include "app/sim/split_mix.h"
#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"

namespace scanbench {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

// SplitMix64 as a stream: the same numbers on every compiler and library.
class SetRandom {
 public:
  explicit SetRandom(uint64_t state) : state_(state) {}
  uint64_t Next() { return sim_internal::Mix64(state_ += sim_internal::kSplitMixGamma); }
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  double LogUniform(double lo, double hi) { return std::exp(Uniform(std::log(lo), std::log(hi))); }
  int Integer(int lo, int hi) { return lo + static_cast<int>(Uniform() * (hi - lo + 1) * (1 - 1e-12)); }
  bool Chance(double p) { return Uniform() < p; }
  double Normal() {
    const double u1 = std::max(Uniform(), 1e-300), u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }
  Eigen::Vector3d UnitVector() {
    const double z = Uniform(-1.0, 1.0), phi = Uniform(0.0, 2.0 * kPi), r = std::sqrt(1.0 - z * z);
    return {r * std::cos(phi), r * std::sin(phi), z};
  }

 private:
  uint64_t state_;
};

Eigen::Vector3d FromElevationAzimuth(double elevation, double azimuth) {
  return {std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth), std::sin(elevation)};
}

// `d` turned by a random angle of rms `sigma` (rad) about a random axis orthogonal to it.
Eigen::Vector3d Perturbed(SetRandom& rng, const Eigen::Vector3d& d, double sigma) {
  if (sigma <= 0) return d;
  const Eigen::Vector3d axis = d.cross(rng.UnitVector());
  if (!(axis.squaredNorm() > 1e-12)) return d;
  return Eigen::AngleAxisd(sigma * rng.Normal(), axis.normalized()) * d;
}

// One pixel's scene before the sensor: true and believed lighting in the camera frame.
struct PixelLighting {
  LightSetKind kind = LightSetKind::kHemisphere;
  Eigen::Vector3d view_true = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d view_believed = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Vector3d> dir_true, dir_believed;
  std::vector<double> irradiance_true, irradiance_believed;
};

int DrawDistantLightCount(SetRandom& rng, const ObservationSetOptions& options) {
  const double u = rng.Uniform();
  int count = u < 0.4 ? rng.Integer(6, 12) : u < 0.7 ? rng.Integer(13, 40) : rng.Integer(41, options.max_lights);
  return std::clamp(count, options.min_lights, options.max_lights);
}

std::vector<Eigen::Vector3d> HemisphereLights(SetRandom& rng, int count) {
  const double min_elevation = rng.Uniform(5.0, 45.0) * kDeg;
  std::vector<Eigen::Vector3d> dirs;
  for (int k = 0; k < count; ++k) {
    dirs.push_back(FromElevationAzimuth(std::asin(rng.Uniform(std::sin(min_elevation), 1.0)),
                                        rng.Uniform(0.0, 2.0 * kPi)));
  }
  return dirs;
}

std::vector<Eigen::Vector3d> RingLights(SetRandom& rng, int count) {
  const int rings = std::min(rng.Integer(1, 3), count / 3);
  std::vector<Eigen::Vector3d> dirs;
  const double offset = rng.Uniform(0.0, 2.0 * kPi);
  for (int ring = 0; ring < std::max(rings, 1); ++ring) {
    const int on_ring = count / std::max(rings, 1) + (ring < count % std::max(rings, 1) ? 1 : 0);
    const double elevation = rng.Uniform(25.0, 85.0) * kDeg;
    for (int k = 0; k < on_ring; ++k) {
      const double azimuth = offset + (k + 0.5 * ring) * 2.0 * kPi / on_ring + rng.Uniform(-5.0, 5.0) * kDeg;
      dirs.push_back(FromElevationAzimuth(elevation + rng.Uniform(-3.0, 3.0) * kDeg, azimuth));
    }
  }
  return dirs;
}

std::vector<Eigen::Vector3d> GridLights(SetRandom& rng, int count) {
  const int side = std::max(3, static_cast<int>(std::ceil(std::sqrt(count * rng.Uniform(1.0, 1.5)))));
  const double extent = rng.Uniform(0.3, 1.1);
  std::vector<Eigen::Vector3d> grid;
  for (int i = 0; i < side; ++i) {
    for (int j = 0; j < side; ++j) {
      const double x = extent * (2.0 * i / (side - 1) - 1.0), y = extent * (2.0 * j / (side - 1) - 1.0);
      grid.push_back(Eigen::Vector3d(x, y, 1.0).normalized());
    }
  }
  // A random subset of `count` (a partial Fisher-Yates shuffle).
  for (int k = 0; k < std::min<int>(count, grid.size()); ++k) {
    std::swap(grid[k], grid[rng.Integer(k, static_cast<int>(grid.size()) - 1)]);
  }
  grid.resize(std::min<size_t>(count, grid.size()));
  return grid;
}

void DrawDistantLighting(SetRandom& rng, const ObservationSetOptions& options, PixelLighting* lighting) {
  const int count = DrawDistantLightCount(rng, options);
  const double u = rng.Uniform();
  lighting->kind = u < 0.3 ? LightSetKind::kHemisphere : u < 0.65 ? LightSetKind::kRings : LightSetKind::kGrid;
  lighting->dir_true = lighting->kind == LightSetKind::kHemisphere ? HemisphereLights(rng, count)
                       : lighting->kind == LightSetKind::kRings    ? RingLights(rng, count)
                                                                   : GridLights(rng, count);
  const double direction_error = rng.Uniform(0.0, 1.5) * kDeg;
  const double intensity_error = rng.Uniform(0.0, 0.04);
  const bool equal_intensities = rng.Chance(0.5);
  for (const Eigen::Vector3d& d : lighting->dir_true) {
    const double e = equal_intensities ? 1.0 : rng.Uniform(0.5, 1.5);
    lighting->irradiance_true.push_back(e);
    lighting->irradiance_believed.push_back(e * std::exp(intensity_error * rng.Normal()));
    lighting->dir_believed.push_back(Perturbed(rng, d, direction_error));
  }
}

// The scanner's geometry: a camera 450-800 mm above the table, LEDs on one or
// two rings aimed at the centre, the pixel somewhere on a 300 x 200 mm sample
// lifted by drape that the light model knows only up to a depth error.
void DrawNearFieldLighting(SetRandom& rng, const ObservationSetOptions& options, PixelLighting* lighting) {
  lighting->kind = LightSetKind::kNearField;
  const int count = std::clamp(rng.Chance(0.5) ? 10 : rng.Integer(6, 16), options.min_lights, options.max_lights);
  const Eigen::Vector3d camera(0, 0, rng.Uniform(450.0, 800.0));
  const Eigen::Vector3d point_true(rng.Uniform(-150.0, 150.0), rng.Uniform(-100.0, 100.0), rng.Uniform(0.0, 40.0));
  const Eigen::Vector3d point_believed = point_true + Eigen::Vector3d(0, 0, rng.Uniform(-1.0, 1.0) * rng.Uniform(0.0, 20.0));
  const int rings = rng.Chance(0.7) ? 2 : 1;
  const double distance = rng.Uniform(300.0, 700.0);
  const double falloff_mu = rng.Uniform(0.0, 3.0);  // the LED's cos^mu beam
  const double offset = rng.Uniform(0.0, 2.0 * kPi);
  const double elevations[2] = {rng.Uniform(20.0, 45.0) * kDeg, rng.Uniform(50.0, 75.0) * kDeg};
  for (int k = 0; k < count; ++k) {
    const int ring = k % rings;
    const int on_ring = count / rings + (ring < count % rings ? 1 : 0);
    const double azimuth = offset + ((k / rings) + 0.5 * ring) * 2.0 * kPi / on_ring;
    const Eigen::Vector3d led = distance * FromElevationAzimuth(elevations[ring], azimuth);
    const Eigen::Vector3d led_believed = led + 2.0 * Eigen::Vector3d(rng.Normal(), rng.Normal(), rng.Normal());
    const Eigen::Vector3d axis = -led.normalized();  // aimed at the sample centre
    auto irradiance = [&](const Eigen::Vector3d& source, const Eigen::Vector3d& point, double mu) {
      const Eigen::Vector3d to_point = point - source;
      const double d2 = to_point.squaredNorm();
      return distance * distance * std::pow(std::max(axis.dot(to_point) / std::sqrt(d2), 0.0), mu) / d2;
    };
    lighting->dir_true.push_back((led - point_true).normalized());
    lighting->dir_believed.push_back((led_believed - point_believed).normalized());
    lighting->irradiance_true.push_back(irradiance(led, point_true, falloff_mu));
    lighting->irradiance_believed.push_back(irradiance(led_believed, point_believed, falloff_mu) *
                                            std::exp(0.02 * rng.Normal()));
  }
  lighting->view_true = (camera - point_true).normalized();
  lighting->view_believed = (camera - point_believed).normalized();
}

// A normal facing the camera: like a sphere seen from afar (uniform over the
// projected disc), like a textile (within 40 deg of the view), or uniform in
// solid angle, never steeper than 87 deg.
Eigen::Vector3d DrawNormal(SetRandom& rng, const Eigen::Vector3d& view) {
  const double u = rng.Uniform();
  double cos_theta;
  if (u < 0.5) cos_theta = std::sqrt(1.0 - rng.Uniform());
  else if (u < 0.75) cos_theta = rng.Uniform(std::cos(40.0 * kDeg), 1.0);
  else cos_theta = rng.Uniform(0.0, 1.0);
  cos_theta = std::max(cos_theta, std::cos(87.0 * kDeg));
  const double phi = rng.Uniform(0.0, 2.0 * kPi), sin_theta = std::sqrt(1.0 - cos_theta * cos_theta);
  const Eigen::Vector3d local(sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta);
  return Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), view) * local;
}

ShadingModel DrawMaterial(SetRandom& rng, const ObservationSetOptions& options, int32_t* flags) {
  ShadingModel m;
  m.albedo = rng.Uniform(0.03, 1.0);
  if (rng.Chance(0.35)) {
    m.diffuse = DiffuseModel::kBurley;
    m.diffuse_roughness = rng.Uniform(0.0, 1.0);
    *flags |= 1 << 4;
  }
  if (rng.Chance(options.specular_share)) {
    *flags |= 1;
    m.specular = rng.Chance(0.25) ? SpecularModel::kAnisotropicGgx : SpecularModel::kGgx;
    m.alpha = rng.LogUniform(0.02, 0.8);
    m.alpha_across = m.alpha;
    if (m.specular == SpecularModel::kAnisotropicGgx) {
      m.alpha_across = std::clamp(m.alpha * rng.LogUniform(1.5, 8.0), 0.02, 1.0);
      m.tangent = rng.UnitVector();
      *flags |= 1 << 1;
    }
    if (rng.Chance(0.15)) {  // a metal: coloured F0 high, hardly any diffuse
      m.specular_f0 = rng.Uniform(0.5, 1.0);
      m.albedo *= rng.Uniform(0.0, 0.15);
      *flags |= 1 << 2;
    } else {
      // Dielectrics, from cloth (0.02) to lacquer; up to 0.25 to cover strong highlights.
      m.specular_f0 = rng.LogUniform(0.02, 0.25);
    }
  }
  if (rng.Chance(options.sheen_share)) {
    *flags |= 1 << 3;
    const double u = rng.Uniform();
    m.sheen = u < 0.35 ? SheenModel::kVelvet : u < 0.7 ? SheenModel::kCharlie : SheenModel::kFuzz;
    m.sheen_color = rng.Uniform(0.05, 1.0);
    m.sheen_roughness = rng.Uniform(0.15, 1.0);
    m.fuzz_density = rng.LogUniform(0.02, 1.0);
  }
  return m;
}

// Cast shadow from the neighbourhood: a horizon around the normal, highest
// towards a random azimuth and falling to 0 over half a random width.
struct Horizon {
  bool present = false;
  double height = 0, centre = 0, half_width = kPi;
  Eigen::Vector3d e1 = Eigen::Vector3d::UnitX(), e2 = Eigen::Vector3d::UnitY();
  bool Shadows(const Eigen::Vector3d& n, const Eigen::Vector3d& l) const {
    if (!present) return false;
    double delta = std::atan2(l.dot(e2), l.dot(e1)) - centre;
    delta = std::remainder(delta, 2.0 * kPi);
    if (std::abs(delta) >= half_width) return false;
    const double horizon = height * std::cos(0.5 * kPi * delta / half_width);
    return std::asin(std::clamp(l.dot(n), -1.0, 1.0)) < horizon;
  }
};

struct RenderedSet {
  Eigen::Vector3f normal;
  float albedo = 0;
  int32_t kind = 0, flags = 0;
  std::vector<Eigen::Vector3f> dir;
  std::vector<float> value;
  int64_t clipped = 0;
};

// Renders one set: lights, normal, material, shadows, inter-reflection, sensor.
bool RenderSet(SetRandom& rng, const ObservationSetOptions& options, RenderedSet* out) {
  PixelLighting lighting;
  if (rng.Chance(options.near_field_share)) DrawNearFieldLighting(rng, options, &lighting);
  else DrawDistantLighting(rng, options, &lighting);
  int32_t flags = 0;
  const ShadingModel material = DrawMaterial(rng, options, &flags);
  // The pixel's footprint: one normal, or two (an edge, a thread crossing).
  Eigen::Vector3d normals[2] = {DrawNormal(rng, lighting.view_true), Eigen::Vector3d::Zero()};
  double weights[2] = {1.0, 0.0};
  if (rng.Chance(0.1)) {
    normals[1] = Perturbed(rng, normals[0], rng.Uniform(5.0, 30.0) * kDeg);
    if (normals[1].dot(lighting.view_true) < 0.05) normals[1] = normals[0];
    weights[1] = rng.Uniform(0.1, 0.5);
    weights[0] = 1.0 - weights[1];
    flags |= 1 << 7;
  }
  const Eigen::Vector3d normal_true = (weights[0] * normals[0] + weights[1] * normals[1]).normalized();
  Horizon horizon;
  if (rng.Chance(options.shadow_share)) {
    horizon.present = true;
    horizon.height = rng.Uniform(10.0, 70.0) * kDeg;
    horizon.centre = rng.Uniform(0.0, 2.0 * kPi);
    horizon.half_width = rng.Uniform(20.0, 180.0) * kDeg;
    horizon.e1 = normal_true.unitOrthogonal();
    horizon.e2 = normal_true.cross(horizon.e1);
    flags |= 1 << 5;
  }
  double bounce = 0;
  Eigen::Vector3d bounce_from = rng.UnitVector();
  if (rng.Chance(0.4)) {
    bounce = rng.Uniform(0.0, 0.15);
    flags |= 1 << 6;
  }
  const double ambient = rng.Uniform(0.0, 0.01);

  // Noise-free readings in units of the irradiance the sensor sees.
  const int count = static_cast<int>(lighting.dir_true.size());
  std::vector<double> expected(count);
  double brightest = 0;
  for (int k = 0; k < count; ++k) {
    const Eigen::Vector3d& l = lighting.dir_true[k];
    double direct = 0;
    for (int f = 0; f < 2; ++f) {
      if (weights[f] > 0) direct += weights[f] * ShadedValue(material, normals[f], l, lighting.view_true);
    }
    if (horizon.Shadows(normal_true, l)) direct = 0;
    const double indirect = material.albedo * (bounce * (0.3 + 0.7 * std::max(0.0, l.dot(bounce_from))) + ambient);
    expected[k] = lighting.irradiance_true[k] * (direct + indirect);
    brightest = std::max(brightest, expected[k]);
  }
  if (!(brightest > 0)) return false;

  // The sensor: exposure, shot and read noise, quantisation, clipping.
  const double exposure = rng.Uniform(0.25, 1.4) / brightest;
  const double shot = rng.LogUniform(2e-5, 1e-3), read = rng.LogUniform(2e-4, 3e-3);
  const int bits_choices[4] = {8, 12, 14, 16};
  const double levels = std::ldexp(1.0, bits_choices[rng.Integer(0, 3)]) - 1.0;
  // Every set is turned so that its believed view is +z (what the solver does per pixel).
  const Eigen::Quaterniond to_view = Eigen::Quaterniond::FromTwoVectors(lighting.view_believed, Eigen::Vector3d::UnitZ());
  out->dir.clear();
  out->value.clear();
  out->clipped = 0;
  for (int k = 0; k < count; ++k) {
    const double x = exposure * expected[k];
    const double noisy = x + std::sqrt(shot * x + read * read) * rng.Normal();
    const double quantised = std::round(std::clamp(noisy, 0.0, 1.0) * levels) / levels;
    if (quantised >= 1.0) {
      ++out->clipped;
      continue;
    }
    out->dir.push_back((to_view * lighting.dir_believed[k]).cast<float>());
    out->value.push_back(static_cast<float>(quantised / (exposure * lighting.irradiance_believed[k])));
  }
  if (static_cast<int>(out->dir.size()) < 3) return false;
  out->normal = (to_view * normal_true).cast<float>();
  out->albedo = static_cast<float>(material.albedo);
  out->kind = static_cast<int32_t>(lighting.kind);
  out->flags = flags;
  return true;
}

}  // namespace

void ObservationSetOptions::Check() const {
  SCANBENCH_REQUIRE_GE_LE("ObservationSetOptions", "num_sets", num_sets, 1, 100000000);
  SCANBENCH_REQUIRE_GE_LE("ObservationSetOptions", "min_lights", min_lights, 3, max_lights);
  SCANBENCH_REQUIRE_GE_LE("ObservationSetOptions", "max_lights", max_lights, min_lights, 256);
  SCANBENCH_REQUIRE_GE_LE("ObservationSetOptions", "near_field_share", near_field_share, 0.0, 1.0);
  SCANBENCH_REQUIRE_GE_LE("ObservationSetOptions", "specular_share", specular_share, 0.0, 1.0);
  SCANBENCH_REQUIRE_GE_LE("ObservationSetOptions", "sheen_share", sheen_share, 0.0, 1.0);
  SCANBENCH_REQUIRE_GE_LE("ObservationSetOptions", "shadow_share", shadow_share, 0.0, 1.0);
  SCANBENCH_REQUIRE_GE("ObservationSetOptions", "num_threads", num_threads, 0);
}

std::string ObservationSetSummary::BriefReport() const {
  std::ostringstream text;
  text << "observation sets: " << TerminationName(termination) << ", " << num_sets << " sets, " << num_samples
       << " samples (" << num_clipped << " clipped left out), " << Significant(seconds) << " s";
  if (!message.empty()) text << ": " << message;
  return text.str();
}

ObservationSetSummary GenerateObservationSets(const ObservationSetOptions& options, ObservationSets* sets) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  ObservationSetSummary summary;
  constexpr int kChunk = 1024;
  const int num_chunks = (options.num_sets + kChunk - 1) / kChunk;
  std::vector<std::vector<RenderedSet>> chunks(num_chunks);
  const bool finished = ParallelFor(
      options.num_sets, ResolveThreadCount(options.num_threads), kChunk,
      [&](int first, int last, int) {
        std::vector<RenderedSet>& chunk = chunks[first / kChunk];
        chunk.resize(last - first);
        for (int index = first; index < last; ++index) {
          SetRandom rng(sim_internal::Mix64(options.seed) ^ sim_internal::Mix64(static_cast<uint64_t>(index) << 1));
          while (!RenderSet(rng, options, &chunk[index - first])) {
          }
        }
      },
      options.progress ? std::function<bool(int)>([&](int done) { return options.progress(double(done) / options.num_sets); })
                       : std::function<bool(int)>());
  if (!finished) {
    summary.SetCancelled();
    return summary;
  }
  *sets = ObservationSets();
  for (const std::vector<RenderedSet>& chunk : chunks) {
    for (const RenderedSet& set : chunk) {
      sets->normal.push_back(set.normal);
      sets->albedo.push_back(set.albedo);
      sets->light_set_kind.push_back(set.kind);
      sets->material_flags.push_back(set.flags);
      sets->light_dir.insert(sets->light_dir.end(), set.dir.begin(), set.dir.end());
      sets->value.insert(sets->value.end(), set.value.begin(), set.value.end());
      sets->offset.push_back(static_cast<int64_t>(sets->value.size()));
      summary.num_clipped += set.clipped;
    }
  }
  summary.num_sets = sets->num_sets();
  summary.num_samples = static_cast<int64_t>(sets->value.size());
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary.termination = Termination::kSuccess;
  return summary;
}

}  // namespace scanbench
