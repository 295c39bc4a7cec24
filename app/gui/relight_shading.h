// The relight preview's shading, as pure functions (no Qt): Lambertian
// diffuse plus an optional specular lobe after Unreal Engine 4's shading
// model (Karis, "Real Shading in Unreal Engine 4", SIGGRAPH 2013): GGX
// distribution with alpha = roughness², Smith geometry in Schlick's form
// with k = (roughness + 1)² / 8, and Schlick's Fresnel with the spherical-
// Gaussian power. Vectors are unit, in the tangent (table) frame.
#pragma once

#include <Eigen/Core>

#include "solver/engine_shading.h"

namespace scanbench {

struct RelightShading {
  bool specular = false;   // add the GGX lobe to the Lambertian term
  double roughness = 0.5;  // perceptual roughness, [0.02, 1]; alpha = roughness²
  double f0 = 0.04;        // specular reflectance at normal incidence, [0, 1]; 0.04 = a common dielectric (fibre)

  // Throws std::invalid_argument (FieldError) naming the field, its value and the rule.
  void Check() const;
};

// D(h) of GGX: GgxDistribution(alpha = roughness², n·h) of solver/engine_shading.h.
// G1(x) = (n·x) / ((n·x)(1 - k) + k), k = (roughness + 1)² / 8; 0 for n·x <= 0.
double SchlickSmithG1(double n_dot_x, double roughness);
// G = G1(l) G1(v).
double SmithSchlickGeometry(double n_dot_l, double n_dot_v, double roughness);
// F = F0 + (1 - F0) 2^((-5.55473 (v·h) - 6.98316) (v·h)): UE4's spherical-Gaussian
// approximation of Schlick's (1 - v·h)^5 (the exact one: solver/engine_shading.h).
double SphericalGaussianSchlickFresnel(double f0, double v_dot_h);
// The specular BRDF D F G / (4 (n·l)(n·v)), per steradian; 0 when the light
// or the viewer is below the surface.
double GgxSpecularBrdf(const Eigen::Vector3d& normal, const Eigen::Vector3d& light, const Eigen::Vector3d& view,
                       double roughness, double f0);

// Linear RGB radiance towards `view` for a distant light of irradiance pi
// (so that a white Lambertian surface facing the light gives 1):
// albedo max(0, n·l) + [specular] pi f_spec (n·l), the lobe uncoloured.
Eigen::Vector3d ShadeRelight(const Eigen::Vector3d& albedo, const Eigen::Vector3d& normal, const Eigen::Vector3d& light,
                             const Eigen::Vector3d& view, const RelightShading& shading);

}  // namespace scanbench
