#include "app/sim/shading_models.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "app/sim/cloth_brdf.h"

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
  const double a2 = alpha * alpha;
  const double denom = nh * nh * (a2 - 1.0) + 1.0;
  const double d = a2 / (kPi * denom * denom);
  const double visibility =
      0.5 / (nl * std::sqrt(nv * nv * (1.0 - a2) + a2) + nv * std::sqrt(nl * nl * (1.0 - a2) + a2));
  return kPi * d * visibility * SchlickFresnel(f0, vh) * nl;
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

// Charlie's distribution (2 + 1/a) sin(th_h)^(1/a) / (2 pi), a = r^2 as glTF's spec.
double CharlieDistribution(double roughness, double nh) {
  const double alpha = std::max(roughness * roughness, 1e-3);
  const double inv_alpha = 1.0 / alpha;
  const double sin2 = std::max(0.0, 1.0 - nh * nh);
  return (2.0 + inv_alpha) * std::pow(sin2, 0.5 * inv_alpha) / (2.0 * kPi);
}

// The sheen visibility of Neubelt and Pettineo, 1 / (4 (n.l + n.v - n.l n.v)).
double SheenVisibility(double nl, double nv) { return 1.0 / (4.0 * (nl + nv - nl * nv)); }

// The table behind CharlieSheenAlbedo: E(mu, r) = integral of D V (n.l) over
// the hemisphere of lights, on a kTableSize^2 grid, by the midpoint rule.
constexpr int kTableSize = 24;
using AlbedoTable = std::array<double, kTableSize * kTableSize>;

AlbedoTable IntegrateCharlieAlbedo() {
  AlbedoTable table{};
  constexpr int kTheta = 64, kPhi = 64;
  for (int ir = 0; ir < kTableSize; ++ir) {
    const double roughness = 0.05 + 0.95 * ir / (kTableSize - 1);
    for (int im = 0; im < kTableSize; ++im) {
      const double mu = std::max(0.02, static_cast<double>(im) / (kTableSize - 1));
      const Eigen::Vector3d v(std::sqrt(1.0 - mu * mu), 0.0, mu);
      double sum = 0;
      for (int it = 0; it < kTheta; ++it) {
        // Uniform in cos(theta): the quadrature weight is d(cos) d(phi).
        const double cos_t = (it + 0.5) / kTheta, sin_t = std::sqrt(1.0 - cos_t * cos_t);
        for (int ip = 0; ip < kPhi; ++ip) {
          const double phi = 2.0 * kPi * (ip + 0.5) / kPhi;
          const Eigen::Vector3d l(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t);
          const Eigen::Vector3d h = (l + v).normalized();
          sum += CharlieDistribution(roughness, h.z()) * SheenVisibility(cos_t, mu) * cos_t;
        }
      }
      table[ir * kTableSize + im] = std::clamp(sum * (2.0 * kPi) / (kTheta * kPhi), 0.0, 1.0);
    }
  }
  return table;
}

}  // namespace

double CharlieSheenAlbedo(double mu, double roughness) {
  static const AlbedoTable table = IntegrateCharlieAlbedo();
  const double fm = std::clamp(mu, 0.0, 1.0) * (kTableSize - 1);
  const double fr = std::clamp((roughness - 0.05) / 0.95, 0.0, 1.0) * (kTableSize - 1);
  const int im = std::min(static_cast<int>(fm), kTableSize - 2), ir = std::min(static_cast<int>(fr), kTableSize - 2);
  const double wm = fm - im, wr = fr - ir;
  auto at = [&](int r, int m) { return table[r * kTableSize + m]; };
  return (1 - wr) * ((1 - wm) * at(ir, im) + wm * at(ir, im + 1)) +
         wr * ((1 - wm) * at(ir + 1, im) + wm * at(ir + 1, im + 1));
}

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
