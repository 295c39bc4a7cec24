#include "solver/light_field.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace scanbench {
namespace {

bool AllFinite(const Eigen::Vector3d& v) { return v.allFinite(); }

std::invalid_argument LightError(int index, const std::string& field, const std::string& rule) {
  return std::invalid_argument("light " + std::to_string(index) + ": " + field + " " + rule);
}

// ln(c) for c > 0 finite, to about 1e-15 relative: c = m 2^e with m in
// [sqrt(1/2), sqrt(2)), then ln m = 2 atanh(z), z = (m - 1) / (m + 1) and
// |z| <= 0.172, summed to z^17 (the next term is below 1e-14 of the sum).
// Plain arithmetic that the span loop keeps inline, where glibc's log is a
// call per LED and pixel.
double LogPositive(double c) {
  int exponent = 0;
  double m = std::frexp(c, &exponent);  // [0.5, 1)
  if (m < 0.70710678118654752) m *= 2, --exponent;
  const double z = (m - 1) / (m + 1), z2 = z * z;
  double series = 1.0 / 17;
  for (int odd = 15; odd >= 1; odd -= 2) series = 1.0 / odd + z2 * series;
  return 2 * z * series + exponent * 0.69314718055994531;
}

}  // namespace

void LightField::EvaluateSpan(int x0, int y, int count, int stride, float* light_dirs,
                              float* rgb_intensities) const {
  const int values = 3 * num_lights();
  std::vector<float> dirs(values), intensities(values);
  for (int i = 0; i < count; ++i) {
    Evaluate(x0 + i, y, dirs.data(), intensities.data());
    for (int j = 0; j < values; ++j) {
      light_dirs[static_cast<size_t>(j) * stride + i] = dirs[j];
      rgb_intensities[static_cast<size_t>(j) * stride + i] = intensities[j];
    }
  }
}

DirectionalLightField::DirectionalLightField(int width, int height, std::vector<Eigen::Vector3d> light_dirs,
                                             std::vector<Eigen::Vector3d> rgb_intensities)
    : width_(width), height_(height), light_dirs_(std::move(light_dirs)),
      rgb_intensities_(std::move(rgb_intensities)) {
  if (light_dirs_.size() != rgb_intensities_.size()) {
    throw std::invalid_argument("directional light field: " + std::to_string(light_dirs_.size()) +
                                " directions but " + std::to_string(rgb_intensities_.size()) +
                                " intensities; they must match");
  }
  for (size_t k = 0; k < light_dirs_.size(); ++k) {
    if (!AllFinite(light_dirs_[k]) || light_dirs_[k].norm() < 1e-12) {
      throw LightError(static_cast<int>(k), "direction", "must be finite and non-zero");
    }
    if (!AllFinite(rgb_intensities_[k]) || (rgb_intensities_[k].array() < 0).any()) {
      throw LightError(static_cast<int>(k), "rgb_intensity", "must be finite and >= 0");
    }
    light_dirs_[k].normalize();
  }
}

void DirectionalLightField::Evaluate(int /*x*/, int /*y*/, float* light_dirs, float* rgb_intensities) const {
  for (size_t k = 0; k < light_dirs_.size(); ++k) {
    for (int c = 0; c < 3; ++c) {
      light_dirs[3 * k + c] = static_cast<float>(light_dirs_[k][c]);
      rgb_intensities[3 * k + c] = static_cast<float>(rgb_intensities_[k][c]);
    }
  }
}

PointLightField::PointLightField(std::vector<PointLight> lights, ImageF surface_points,
                                 std::optional<Eigen::Vector3d> camera_centre)
    : lights_(std::move(lights)), surface_points_(std::move(surface_points)), camera_centre_(camera_centre) {
  if (camera_centre_ && !AllFinite(*camera_centre_)) {
    throw std::invalid_argument("point light field: camera_centre must be finite");
  }
  if (surface_points_.channels() != 3) {
    throw std::invalid_argument("point light field: surface points have " +
                                std::to_string(surface_points_.channels()) + " channels; 3 required");
  }
  for (size_t k = 0; k < lights_.size(); ++k) {
    PointLight& light = lights_[k];
    const int index = static_cast<int>(k);
    if (!AllFinite(light.position)) throw LightError(index, "position", "must be finite");
    if (!AllFinite(light.axis) || light.axis.norm() < 1e-12) {
      throw LightError(index, "axis", "must be finite and non-zero");
    }
    if (!(light.mu >= 0) || !std::isfinite(light.mu)) {
      throw LightError(index, "mu = " + std::to_string(light.mu), "must be finite and >= 0");
    }
    if (!AllFinite(light.rgb_intensity) || (light.rgb_intensity.array() < 0).any()) {
      throw LightError(index, "rgb_intensity", "must be finite and >= 0");
    }
    if (!(light.reference_distance > 0)) {
      throw LightError(index, "reference_distance = " + std::to_string(light.reference_distance), "must be > 0");
    }
    light.axis.normalize();
  }
}

void PointLightField::Evaluate(int x, int y, float* light_dirs, float* rgb_intensities) const {
  const Eigen::Vector3d point(surface_points_(x, y, 0), surface_points_(x, y, 1), surface_points_(x, y, 2));
  for (size_t k = 0; k < lights_.size(); ++k) {
    const PointLight& light = lights_[k];
    const Eigen::Vector3d to_light = light.position - point;
    const double distance = to_light.norm();
    const Eigen::Vector3d light_dir = to_light / distance;
    // Angle off the LED's axis is measured from the LED towards the point.
    const double cos_off_axis = std::max(0.0, -light_dir.dot(light.axis));
    const double falloff = std::pow(cos_off_axis, light.mu) *
                           (light.reference_distance * light.reference_distance) / (distance * distance);
    for (int c = 0; c < 3; ++c) {
      light_dirs[3 * k + c] = static_cast<float>(light_dir[c]);
      rgb_intensities[3 * k + c] = static_cast<float>(light.rgb_intensity[c] * falloff);
    }
  }
}

// The model of Evaluate in plain loops over the span, one light at a time
// (no Eigen temporaries, no virtual call per pixel), and cos^mu as
// exp(mu ln cos) with an inline ln (LogPositive) instead of std::pow: the same floats within a few ulp of
// the doubles (tests/solver/light_field_test.cc).
void PointLightField::EvaluateSpan(int x0, int y, int count, int stride, float* light_dirs,
                                   float* rgb_intensities) const {
  const float* points = surface_points_.row(y) + static_cast<size_t>(x0) * 3;
  for (size_t k = 0; k < lights_.size(); ++k) {
    const PointLight& light = lights_[k];
    const double px = light.position.x(), py = light.position.y(), pz = light.position.z();
    const double ax = light.axis.x(), ay = light.axis.y(), az = light.axis.z();
    const double mu = light.mu, reference2 = light.reference_distance * light.reference_distance;
    const double r = light.rgb_intensity.x(), g = light.rgb_intensity.y(), b = light.rgb_intensity.z();
    const size_t plane = 3 * k * static_cast<size_t>(stride);
    float* __restrict dx = light_dirs + plane;
    float* __restrict dy = dx + stride;
    float* __restrict dz = dx + 2 * stride;
    float* __restrict ir = rgb_intensities + plane;
    float* __restrict ig = ir + stride;
    float* __restrict ib = ir + 2 * stride;
    for (int i = 0; i < count; ++i) {
      const double tx = px - points[3 * i], ty = py - points[3 * i + 1], tz = pz - points[3 * i + 2];
      const double distance2 = tx * tx + ty * ty + tz * tz;
      const double distance = std::sqrt(distance2);
      const double lx = tx / distance, ly = ty / distance, lz = tz / distance;
      const double cos_off_axis = std::max(0.0, -(lx * ax + ly * ay + lz * az));
      // pow(0, mu) is 1 for mu = 0 and 0 above; exp(mu log 0) is NaN at mu = 0.
      const double angular =
          mu == 0 ? 1.0 : (cos_off_axis > 0 ? std::exp(mu * LogPositive(cos_off_axis)) : 0.0);
      const double falloff = angular * reference2 / distance2;
      dx[i] = static_cast<float>(lx), dy[i] = static_cast<float>(ly), dz[i] = static_cast<float>(lz);
      ir[i] = static_cast<float>(r * falloff), ig[i] = static_cast<float>(g * falloff);
      ib[i] = static_cast<float>(b * falloff);
    }
  }
}

void PointLightField::ViewDirection(int x, int y, float* view_dir) const {
  Eigen::Vector3d view = Eigen::Vector3d::UnitZ();
  if (camera_centre_) {
    const Eigen::Vector3d point(surface_points_(x, y, 0), surface_points_(x, y, 1), surface_points_(x, y, 2));
    const Eigen::Vector3d to_camera = *camera_centre_ - point;
    const double distance = to_camera.norm();
    if (distance > 0 && std::isfinite(distance)) view = to_camera / distance;
  }
  for (int c = 0; c < 3; ++c) view_dir[c] = static_cast<float>(view[c]);
}

}  // namespace scanbench
