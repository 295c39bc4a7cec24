#include "app/gui/relight_shading.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/field_error.h"

namespace scanbench {

void RelightShading::Check() const {
  // Below 0.02 the GGX peak (1 / (pi alpha²)) exceeds 10^6: a single pixel flashes, nothing shows.
  if (!(roughness >= 0.02 && roughness <= 1))
    throw FieldError("RelightShading", "roughness", roughness, "must be in [0.02, 1]");
  if (!(f0 >= 0 && f0 <= 1)) throw FieldError("RelightShading", "f0", f0, "must be in [0, 1]");
}

double SchlickSmithG1(double n_dot_x, double roughness) {
  if (n_dot_x <= 0) return 0;
  const double k = (roughness + 1) * (roughness + 1) / 8;
  return n_dot_x / (n_dot_x * (1 - k) + k);
}

double SmithSchlickGeometry(double n_dot_l, double n_dot_v, double roughness) {
  return SchlickSmithG1(n_dot_l, roughness) * SchlickSmithG1(n_dot_v, roughness);
}

double SphericalGaussianSchlickFresnel(double f0, double v_dot_h) {
  return f0 + (1 - f0) * std::exp2((-5.55473 * v_dot_h - 6.98316) * v_dot_h);
}

double GgxSpecularBrdf(const Eigen::Vector3d& normal, const Eigen::Vector3d& light, const Eigen::Vector3d& view,
                       double roughness, double f0) {
  const double n_dot_l = normal.dot(light), n_dot_v = normal.dot(view);
  if (n_dot_l <= 0 || n_dot_v <= 0) return 0;
  const Eigen::Vector3d half = (light + view).normalized();
  const double d = GgxDistribution(roughness * roughness, std::max(0.0, normal.dot(half)));
  const double f = SphericalGaussianSchlickFresnel(f0, std::clamp(view.dot(half), 0.0, 1.0));
  const double g = SmithSchlickGeometry(n_dot_l, n_dot_v, roughness);
  return d * f * g / (4 * n_dot_l * n_dot_v);
}

Eigen::Vector3d ShadeRelight(const Eigen::Vector3d& albedo, const Eigen::Vector3d& normal, const Eigen::Vector3d& light,
                             const Eigen::Vector3d& view, const RelightShading& shading) {
  const double n_dot_l = std::max(0.0, normal.dot(light));
  Eigen::Vector3d radiance = albedo * n_dot_l;
  if (shading.specular && n_dot_l > 0) {
    radiance.array() +=
        std::numbers::pi * GgxSpecularBrdf(normal, light, view, shading.roughness, shading.f0) * n_dot_l;
  }
  return radiance;
}

}  // namespace scanbench
