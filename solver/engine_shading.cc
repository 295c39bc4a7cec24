#include "solver/engine_shading.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <Eigen/Core>

namespace scanbench {
namespace {

constexpr double kPi = std::numbers::pi;

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

double SchlickFresnel(double f0, double cos_theta) {
  const double m = 1.0 - std::clamp(cos_theta, 0.0, 1.0);
  const double m2 = m * m;
  return f0 + (1.0 - f0) * m2 * m2 * m;
}

double GgxDistribution(double alpha, double cos_h) {
  const double a2 = alpha * alpha;
  const double denom = cos_h * cos_h * (a2 - 1.0) + 1.0;
  return a2 / (kPi * denom * denom);
}

double GgxVisibility(double alpha, double nl, double nv) {
  const double a2 = alpha * alpha;
  return 0.5 / (nl * std::sqrt(nv * nv * (1.0 - a2) + a2) + nv * std::sqrt(nl * nl * (1.0 - a2) + a2));
}

double CharlieDistribution(double roughness, double cos_h) {
  const double alpha = std::max(roughness * roughness, 1e-3);
  const double inv_alpha = 1.0 / alpha;
  const double sin2 = std::max(0.0, 1.0 - cos_h * cos_h);
  return (2.0 + inv_alpha) * std::pow(sin2, 0.5 * inv_alpha) / (2.0 * kPi);
}

double SheenVisibility(double nl, double nv) { return 1.0 / (4.0 * (nl + nv - nl * nv)); }

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

}  // namespace scanbench
