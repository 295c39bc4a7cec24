// Non-Lambertian textile materials of the simulated rig (issue #13, item 1).
//
// Every material splits its reflectance into a DIFFUSE part, which carries the
// thread's colour through the spectral camera, and a spectrally neutral
// SPECULAR part (sheen or gloss), which reflects the LED's own white. A
// reading of an LED of raw irradiance E_c (the rig's rgb_intensity times
// falloff and 1/d^2) is
//   value_c = E_c * (diffuse * albedo_c + specular)
// with, for BRDF f = diffuse_c / pi + f_spec and shading normal n,
//   diffuse = (1 - F) * (n.l),   specular = pi * f_spec * (n.l);
// for kLambert diffuse = n.l and specular = 0, today's model exactly.
//
// kCloth: the seed's cloth BRDF (seed 000, "Cloth Shading", eq. 21-23):
// Ashikhmin and Premoze's (2007) velvet "inverted Gaussian" distribution
//   D(h) = (1 + A exp(-cot^2 th_h / a^2) / sin^4 th_h) / (pi (1 + A a^2)),  A = 4,
// a Schlick Fresnel F(v.h) and, as the seed does, NO shadowing/masking term and
// the smoother denominator 4 (n.l + n.v - (n.l)(n.v)):
//   f = (1 - F) c_diff / pi + F D / (4 (n.l + n.v - (n.l)(n.v))).
// kSatin: the same Fresnel-weighted diffuse plus an anisotropic GGX lobe
// (Heitz 2014 Smith masking-shadowing) whose roughness along the thread
// tangent differs from across it.
#pragma once

#include <optional>
#include <span>
#include <string>

#include <Eigen/Core>

#include "solver/engine_shading.h"  // SchlickFresnel

namespace scanbench {

enum class SurfaceMaterial {
  kLambert,  // diffuse only (the rig before issue #13; the solver's model)
  kCloth,    // the seed's velvet-distribution cloth BRDF + diffuse
  kSatin,    // diffuse + anisotropic GGX lobe along the thread
};

// "lambert", "cloth", "satin" (the CLI's --material names).
const char* SurfaceMaterialName(SurfaceMaterial material);
std::optional<SurfaceMaterial> SurfaceMaterialFromName(const std::string& name);

// One thread's specular parameters (TextileScene::ThreadBrdfOf).
struct ThreadBrdf {
  double specular_f0 = 0.04;     // Fresnel reflectance at normal incidence, white, [0, 1]
  double roughness = 0.5;        // kCloth: velvet width a; kSatin: GGX alpha along the thread, (0, 2]
  double roughness_across = 0.5; // kSatin: GGX alpha across the thread, (0, 2]; unused by kCloth
};

// diffuse and specular of the header comment.
struct MaterialResponse {
  double diffuse = 0;
  double specular = 0;
};

// Smith's Lambda of anisotropic GGX for direction w in the (t, b, n) frame,
// given the squared alphas (Heitz 2014, eq. 86).
double GgxLambda(const Eigen::Vector3d& w, double alpha_t2, double alpha_b2);

// The velvet distribution D(h) above; cos_h = n.h.
double VelvetDistribution(double cos_h, double alpha);

// Response of `material` at unit shading normal n, unit light l and view v,
// `tangent` a unit vector along the thread (only kSatin uses it; it need not
// be orthogonal to n). Zero when l or v is below the shading horizon. Never NaN.
MaterialResponse EvaluateMaterial(SurfaceMaterial material, const ThreadBrdf& brdf, const Eigen::Vector3d& n,
                                  const Eigen::Vector3d& tangent, const Eigen::Vector3d& l, const Eigen::Vector3d& v);

// The MEAN of EvaluateMaterial over `normals` (a pixel's footprint sub-samples:
// what a sensor pixel integrates over sub-pixel fibres); l, v and the half
// vector's Fresnel are shared. Zero for no normals.
MaterialResponse MeanMaterialResponse(SurfaceMaterial material, const ThreadBrdf& brdf,
                                      std::span<const Eigen::Vector3d> normals, const Eigen::Vector3d& tangent,
                                      const Eigen::Vector3d& l, const Eigen::Vector3d& v);

}  // namespace scanbench
