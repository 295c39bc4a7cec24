#include "solver/light_field.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "solver/span_kernels.h"

namespace scanbench {
namespace {

bool AllFinite(const Eigen::Vector3d& v) { return v.allFinite(); }

std::invalid_argument LightError(int index, const std::string& field, const std::string& rule) {
  return std::invalid_argument("light " + std::to_string(index) + ": " + field + " " + rule);
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

HeldSurfacePoints::HeldSurfacePoints(ImageF points) : points_(std::move(points)) {
  if (points_.channels() != 3) {
    throw std::invalid_argument("point light field: surface points have " + std::to_string(points_.channels()) +
                                " channels; 3 required");
  }
}

PointLightField::PointLightField(std::vector<PointLight> lights, ImageF surface_points,
                                 std::optional<Eigen::Vector3d> camera_centre)
    : PointLightField(std::move(lights), std::make_unique<HeldSurfacePoints>(std::move(surface_points)),
                      camera_centre) {}

PointLightField::PointLightField(std::vector<PointLight> lights,
                                 std::unique_ptr<const SurfacePoints> surface_points,
                                 std::optional<Eigen::Vector3d> camera_centre)
    : lights_(std::move(lights)), surface_points_(std::move(surface_points)), camera_centre_(camera_centre) {
  if (!surface_points_) throw std::invalid_argument("point light field: no surface points");
  if (camera_centre_ && !AllFinite(*camera_centre_)) {
    throw std::invalid_argument("point light field: camera_centre must be finite");
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
  const Eigen::Vector3d point = surface_points_->Point(x, y).cast<double>();
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

// The model of Evaluate in the solver's per-ISA span kernels
// (span_kernels_impl.h: a vectorised loop per LED, cos^mu as exp(mu ln cos)
// with both inline): the same floats within a few ulp of the doubles
// (tests/solver/light_field_test.cc), and the same in every ISA.
void PointLightField::EvaluateSpan(int x0, int y, int count, int stride, float* light_dirs,
                                   float* rgb_intensities) const {
  // The LEDs as the kernel reads them, per call: a few dozen values, no
  // allocation for up to 32 LEDs.
  constexpr int kLocalLights = 32;
  double local[kLocalLights * tiled::kPointLightValues];
  std::vector<double> heap;
  double* packed = local;
  if (num_lights() > kLocalLights) {
    heap.resize(lights_.size() * tiled::kPointLightValues);
    packed = heap.data();
  }
  for (size_t k = 0; k < lights_.size(); ++k) {
    const PointLight& light = lights_[k];
    const double values[tiled::kPointLightValues] = {
        light.position.x(),      light.position.y(),      light.position.z(), light.axis.x(), light.axis.y(),
        light.axis.z(),          light.mu,                light.reference_distance * light.reference_distance,
        light.rgb_intensity.x(), light.rgb_intensity.y(), light.rgb_intensity.z()};
    std::copy(values, values + tiled::kPointLightValues, packed + k * tiled::kPointLightValues);
  }
  tiled::PointLightArgs args;
  args.count = count;
  args.num_lights = num_lights();
  args.stride = stride;
  std::vector<float> scratch;  // only for points made on request
  args.points = surface_points_->Span(x0, y, count, &scratch);
  args.lights = packed;
  args.dirs = light_dirs;
  args.intensities = rgb_intensities;
  tiled::SpanKernelsFor(ActiveKernelIsa()).point_lights(args);
}

void PointLightField::ViewDirection(int x, int y, float* view_dir) const {
  Eigen::Vector3d view = Eigen::Vector3d::UnitZ();
  if (camera_centre_) {
    const Eigen::Vector3d point = surface_points_->Point(x, y).cast<double>();
    const Eigen::Vector3d to_camera = *camera_centre_ - point;
    const double distance = to_camera.norm();
    if (distance > 0 && std::isfinite(distance)) view = to_camera / distance;
  }
  for (int c = 0; c < 3; ++c) view_dir[c] = static_cast<float>(view[c]);
}

}  // namespace scanbench
