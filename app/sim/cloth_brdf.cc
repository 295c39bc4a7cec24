#include "app/sim/cloth_brdf.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <span>

#include <Eigen/Geometry>

namespace scanbench {
namespace {

constexpr double kPi = std::numbers::pi;
// Ashikhmin's amplitude of the inverted Gaussian, which the seed keeps.
constexpr double kVelvetAmplitude = 4.0;

}  // namespace

double GgxLambda(const Eigen::Vector3d& w, double alpha_t2, double alpha_b2) {
  const double wn2 = std::max(w.z() * w.z(), 1e-12);
  const double a2_tan2 = (alpha_t2 * w.x() * w.x() + alpha_b2 * w.y() * w.y()) / wn2;
  return 0.5 * (std::sqrt(1.0 + a2_tan2) - 1.0);
}

const char* SurfaceMaterialName(SurfaceMaterial material) {
  switch (material) {
    case SurfaceMaterial::kLambert: return "lambert";
    case SurfaceMaterial::kCloth: return "cloth";
    case SurfaceMaterial::kSatin: return "satin";
  }
  return "unknown";
}

std::optional<SurfaceMaterial> SurfaceMaterialFromName(const std::string& name) {
  for (SurfaceMaterial m : {SurfaceMaterial::kLambert, SurfaceMaterial::kCloth, SurfaceMaterial::kSatin}) {
    if (name == SurfaceMaterialName(m)) return m;
  }
  return std::nullopt;
}

double VelvetDistribution(double cos_h, double alpha) {
  const double c2 = std::clamp(cos_h * cos_h, 0.0, 1.0);
  const double s2 = 1.0 - c2;
  const double norm = 1.0 / (kPi * (1.0 + kVelvetAmplitude * alpha * alpha));
  // At th_h -> 0 the exponential vanishes faster than sin^4: the offset alone.
  if (s2 < 1e-12) return norm;
  const double cot2 = c2 / s2;
  return norm * (1.0 + kVelvetAmplitude * std::exp(-cot2 / (alpha * alpha)) / (s2 * s2));
}

MaterialResponse EvaluateMaterial(SurfaceMaterial material, const ThreadBrdf& brdf, const Eigen::Vector3d& n,
                                  const Eigen::Vector3d& tangent, const Eigen::Vector3d& l, const Eigen::Vector3d& v) {
  return MeanMaterialResponse(material, brdf, std::span<const Eigen::Vector3d>(&n, 1), tangent, l, v);
}

MaterialResponse MeanMaterialResponse(SurfaceMaterial material, const ThreadBrdf& brdf,
                                      std::span<const Eigen::Vector3d> normals, const Eigen::Vector3d& tangent,
                                      const Eigen::Vector3d& l, const Eigen::Vector3d& v) {
  MaterialResponse out;
  if (normals.empty()) return out;
  const double inverse_count = 1.0 / static_cast<double>(normals.size());
  if (material == SurfaceMaterial::kLambert) {
    for (const Eigen::Vector3d& n : normals) out.diffuse += std::max(0.0, n.dot(l));
    out.diffuse *= inverse_count;
    return out;
  }
  const Eigen::Vector3d sum = l + v;
  const double sum_norm = sum.norm();
  if (!(sum_norm > 1e-12)) return out;
  // The half vector and its Fresnel depend on l and v only: once for all normals.
  const Eigen::Vector3d h = sum / sum_norm;
  const double fresnel = SchlickFresnel(brdf.specular_f0, v.dot(h));
  const double f0 = brdf.specular_f0;
  const double at = brdf.roughness, ab = brdf.roughness_across;
  const double at2 = at * at, ab2 = ab * ab, inv_at2 = 1.0 / at2, inv_ab2 = 1.0 / ab2;
  const double lobe_scale = fresnel / (4.0 * at * ab);  // pi F D G / (4 nv) = this * G / (e^2 nv)
  for (const Eigen::Vector3d& n : normals) {
    const double nl = n.dot(l);
    const double nv = n.dot(v);
    if (!(nl > 0) || !(nv > 0)) continue;
    if (material == SurfaceMaterial::kCloth) {
      out.diffuse += (1.0 - fresnel) * nl;
      const double d = VelvetDistribution(n.dot(h), brdf.roughness);
      out.specular += kPi * fresnel * d / (4.0 * (nl + nv - nl * nv)) * nl;
      continue;
    }
    // kSatin: a sharp lobe takes most of the light at grazing view, where
    // (1 - F(v.h)) would leave the diffuse part whole: the diffuse weight is the
    // light that passes the interface both ways instead, (1 - F(n.l))(1 - F(n.v)),
    // renormalised to (1 - f0) at normal incidence (keeps the albedo <= 1).
    if (f0 < 1) out.diffuse += (1.0 - SchlickFresnel(f0, nl)) * (1.0 - SchlickFresnel(f0, nv)) / (1.0 - f0) * nl;
    // The tangent frame (t along the thread, b across, n).
    Eigen::Vector3d t = tangent - tangent.dot(n) * n;
    if (!(t.squaredNorm() > 1e-12)) t = n.unitOrthogonal();
    t.normalize();
    const Eigen::Vector3d b = n.cross(t);
    const Eigen::Vector3d hl(h.dot(t), h.dot(b), n.dot(h));
    const Eigen::Vector3d ll(l.dot(t), l.dot(b), nl);
    const Eigen::Vector3d vl(v.dot(t), v.dot(b), nv);
    // D = 1 / (pi at ab e^2); the specular part is pi F D G / (4 nl nv) * nl.
    const double e = hl.x() * hl.x() * inv_at2 + hl.y() * hl.y() * inv_ab2 + hl.z() * hl.z();
    const double g = 1.0 / (1.0 + GgxLambda(ll, at2, ab2) + GgxLambda(vl, at2, ab2));
    out.specular += lobe_scale * g / (e * e * nv);
  }
  out.diffuse *= inverse_count;
  out.specular *= inverse_count;
  return out;
}

}  // namespace scanbench
