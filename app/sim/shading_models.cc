#include "app/sim/shading_models.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "app/sim/cloth_brdf.h"
#include "solver/engine_shading.h"

namespace scanbench {
namespace {

constexpr double kPi = std::numbers::pi;

double Pow5(double x) {
  const double x2 = x * x;
  return x2 * x2 * x;
}

// Burley's diffuse factor (1 + (F90 - 1)(1 - n.l)^5)(1 + (F90 - 1)(1 - n.v)^5).
double BurleyFactor(double roughness, double nl, double nv, double lh) {
  const double f90 = 0.5 + 2.0 * roughness * lh * lh;
  return (1.0 + (f90 - 1.0) * Pow5(1.0 - nl)) * (1.0 + (f90 - 1.0) * Pow5(1.0 - nv));
}

// pi D V F (n.l) of isotropic GGX with the height-correlated Smith visibility.
double IsotropicGgx(double alpha, double f0, double nl, double nv, double nh, double vh) {
  return kPi * GgxDistribution(alpha, nh) * GgxVisibility(alpha, nl, nv) * SchlickFresnel(f0, vh) * nl;
}

// pi F D G / (4 n.l n.v) (n.l) of anisotropic GGX (as the satin of cloth_brdf.cc).
double AnisotropicGgx(const ShadingModel& model, const Eigen::Vector3d& n, const Eigen::Vector3d& l,
                      const Eigen::Vector3d& v, const Eigen::Vector3d& h, double nl, double nv) {
  Eigen::Vector3d t = model.tangent - model.tangent.dot(n) * n;
  if (!(t.squaredNorm() > 1e-12)) t = n.unitOrthogonal();
  t.normalize();
  const Eigen::Vector3d b = n.cross(t);
  const double at = model.alpha, ab = model.alpha_across;
  const double at2 = at * at, ab2 = ab * ab;
  const Eigen::Vector3d hl(h.dot(t), h.dot(b), n.dot(h));
  const Eigen::Vector3d ll(l.dot(t), l.dot(b), nl);
  const Eigen::Vector3d vl(v.dot(t), v.dot(b), nv);
  const double e = hl.x() * hl.x() / at2 + hl.y() * hl.y() / ab2 + hl.z() * hl.z();
  const double d = 1.0 / (kPi * at * ab * e * e);
  const double g = 1.0 / (1.0 + GgxLambda(ll, at2, ab2) + GgxLambda(vl, at2, ab2));
  return kPi * SchlickFresnel(model.specular_f0, v.dot(h)) * d * g / (4.0 * nv);
}

}  // namespace

double ShadedValue(const ShadingModel& model, const Eigen::Vector3d& n, const Eigen::Vector3d& l,
                   const Eigen::Vector3d& v) {
  const double nl = n.dot(l), nv = n.dot(v);
  if (!(nl > 0) || !(nv > 0)) return 0.0;
  const Eigen::Vector3d sum = l + v;
  const double sum_norm = sum.norm();
  if (!(sum_norm > 1e-12)) return 0.0;
  const Eigen::Vector3d h = sum / sum_norm;
  const double nh = std::clamp(n.dot(h), 0.0, 1.0), vh = std::clamp(v.dot(h), 0.0, 1.0);

  // The base: diffuse plus specular.
  double diffuse = model.albedo * nl;
  if (model.diffuse == DiffuseModel::kBurley) diffuse *= BurleyFactor(model.diffuse_roughness, nl, nv, vh);
  double specular = 0;
  if (model.specular == SpecularModel::kGgx) {
    specular = IsotropicGgx(model.alpha, model.specular_f0, nl, nv, nh, vh);
  } else if (model.specular == SpecularModel::kAnisotropicGgx) {
    specular = AnisotropicGgx(model, n, l, v, h, nl, nv);
  }
  if (model.specular != SpecularModel::kNone) diffuse *= 1.0 - model.specular_f0;
  double base = diffuse + specular;

  // The sheen on top, and what it takes from the base.
  switch (model.sheen) {
    case SheenModel::kNone: return base;
    case SheenModel::kVelvet: {
      const double fresnel = SchlickFresnel(model.sheen_color, vh);
      return base * (1.0 - fresnel) +
             kPi * fresnel * VelvetDistribution(nh, model.sheen_roughness) * SheenVisibility(nl, nv) * nl;
    }
    case SheenModel::kCharlie: {
      const double scaling = std::min(1.0 - model.sheen_color * CharlieSheenAlbedo(nv, model.sheen_roughness),
                                      1.0 - model.sheen_color * CharlieSheenAlbedo(nl, model.sheen_roughness));
      const double sheen =
          kPi * model.sheen_color * CharlieDistribution(model.sheen_roughness, nh) * SheenVisibility(nl, nv) * nl;
      return base * std::max(0.0, scaling) + sheen;
    }
    case SheenModel::kFuzz: {
      // Single scattering in a thin isotropic layer of optical thickness d
      // (albedo c_f, phase 1 / 4 pi): f = c_f (1 - exp(-d (1/n.l + 1/n.v))) / (4 pi (n.l + n.v));
      // the base is seen through it, dimmed by exp(-d (1/n.l + 1/n.v)).
      const double path = model.fuzz_density * (1.0 / nl + 1.0 / nv);
      const double transmitted = std::exp(-path);
      const double layer = model.sheen_color * (1.0 - transmitted) / (4.0 * (nl + nv)) * nl;
      return base * transmitted + layer;
    }
  }
  return base;
}

}  // namespace scanbench
