// One pixel's material in the shading models of the seeds and of the engines
// a scan is exported to, for the learned solver's training observations
// (app/sim/observation_sets.h, issue #33). The textile scene's own materials
// (app/sim/cloth_brdf.h) are two of these; here every lobe can be combined:
//   diffuse   Lambert, or Burley's Disney diffuse (retro-reflection at rough grazing)
//   specular  GGX with height-correlated Smith and Schlick's Fresnel (UE4's model,
//             seed 003), or anisotropic GGX (satin, brushed metal); a metal is a
//             high F0 with a dark diffuse term
//   sheen     the velvet distribution of The Order: 1886's cloth BRDF (seed 000),
//             Charlie sheen (Estevez and Kulla 2017) with KHR_materials_sheen's
//             albedo scaling of the layers below (seed 002), or a thin
//             single-scattering fuzz layer after Koenderink and Pont as in
//             Ghost of Tsushima (seed 001), which also dims the base it covers
//
// Every value is what one intensity-divided luminance sample of a unit
// irradiance reads: pi f (n.l), so a Lambertian surface of albedo rho reads
// rho (n.l), the photometric solver's model.
#pragma once

#include <Eigen/Core>

#include "solver/engine_shading.h"  // CharlieSheenAlbedo and the other lobes

namespace scanbench {

enum class DiffuseModel { kLambert, kBurley };
enum class SpecularModel { kNone, kGgx, kAnisotropicGgx };
enum class SheenModel { kNone, kVelvet, kCharlie, kFuzz };

struct ShadingModel {
  DiffuseModel diffuse = DiffuseModel::kLambert;
  double albedo = 0.5;              // diffuse reflectance, [0, 1]
  double diffuse_roughness = 0.5;   // Burley's roughness, [0, 1]

  SpecularModel specular = SpecularModel::kNone;
  double specular_f0 = 0.04;        // Fresnel reflectance at normal incidence, [0, 1]
  double alpha = 0.2;               // GGX alpha (along the tangent when anisotropic), [0.005, 1]
  double alpha_across = 0.2;        // anisotropic GGX alpha across the tangent, [0.005, 1]
  Eigen::Vector3d tangent = Eigen::Vector3d::UnitX();  // thread / brush direction, need not be orthogonal to n

  SheenModel sheen = SheenModel::kNone;
  double sheen_color = 0.5;         // velvet: its Fresnel F0; Charlie: sheen colour; fuzz: layer albedo, [0, 1]
  double sheen_roughness = 0.5;     // velvet width a, Charlie roughness r, [0.05, 1]; unused by fuzz
  double fuzz_density = 0.2;        // fuzz layer's optical thickness, [0, 2]
};

// pi f(l, v) (n.l) of `model` at unit shading normal n, light l and view v;
// 0 when l or v is below n's horizon. Never NaN.
double ShadedValue(const ShadingModel& model, const Eigen::Vector3d& n, const Eigen::Vector3d& l,
                   const Eigen::Vector3d& v);


}  // namespace scanbench
