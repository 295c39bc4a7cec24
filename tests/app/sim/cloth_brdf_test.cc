#include "app/sim/cloth_brdf.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "app/sim/textile_scene.h"

namespace scanbench {
namespace {

constexpr double kPi = std::numbers::pi;

Eigen::Vector3d FromAngles(double theta_deg, double phi_deg) {
  const double t = theta_deg * kPi / 180.0, p = phi_deg * kPi / 180.0;
  return Eigen::Vector3d(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
}

// Directional albedo of a white-diffuse material seen from `view`:
// (1 / pi) * integral over the hemisphere of (diffuse + specular) d omega,
// midpoint rule in (cos theta, phi).
double DirectionalAlbedo(SurfaceMaterial material, const ThreadBrdf& brdf, const Eigen::Vector3d& view) {
  constexpr int kCos = 600, kPhi = 1200;
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  double sum = 0;
  for (int i = 0; i < kCos; ++i) {
    const double c = (i + 0.5) / kCos, s = std::sqrt(1 - c * c);
    for (int j = 0; j < kPhi; ++j) {
      const double phi = 2 * kPi * (j + 0.5) / kPhi;
      const Eigen::Vector3d l(s * std::cos(phi), s * std::sin(phi), c);
      const MaterialResponse r = EvaluateMaterial(material, brdf, n, Eigen::Vector3d::UnitY(), l, view);
      sum += r.diffuse + r.specular;
    }
  }
  return sum / kPi * (1.0 / kCos) * (2 * kPi / kPhi);
}

TEST(ClothBrdf, NamesRoundTripAndUnknownIsRefused) {
  for (SurfaceMaterial m : {SurfaceMaterial::kLambert, SurfaceMaterial::kCloth, SurfaceMaterial::kSatin}) {
    EXPECT_EQ(SurfaceMaterialFromName(SurfaceMaterialName(m)), m);
  }
  EXPECT_FALSE(SurfaceMaterialFromName("velvet").has_value());
}

TEST(ClothBrdf, VelvetDistributionIsNormalisedAndPeaksAtGrazingHalfVectors) {
  for (double alpha : {0.3, 0.6, 1.0}) {
    // integral of D(h) cos th_h over the hemisphere = 1 (the seed's c_norm).
    constexpr int kSteps = 20000;
    double sum = 0;
    for (int i = 0; i < kSteps; ++i) {
      const double c = (i + 0.5) / kSteps;
      sum += VelvetDistribution(c, alpha) * c;
    }
    EXPECT_NEAR(sum * 2 * kPi / kSteps, 1.0, 2e-3) << "alpha " << alpha;
    EXPECT_GT(VelvetDistribution(std::cos(80 * kPi / 180), alpha), 3 * VelvetDistribution(1.0, alpha));
  }
}

// Energy: no material reflects more than it receives, at normal and oblique
// incidence (by reciprocity the view direction plays the incident one).
TEST(ClothBrdf, NoMaterialReflectsMoreThanItReceives) {
  const ThreadBrdf cloth{0.3, 1.2, 1.2};
  const ThreadBrdf satin{0.3, 0.3, 0.1};
  for (double theta : {0.0, 30.0, 60.0, 80.0}) {
    const Eigen::Vector3d v = FromAngles(theta, 20.0);
    const double lambert = DirectionalAlbedo(SurfaceMaterial::kLambert, cloth, v);
    EXPECT_NEAR(lambert, 1.0, 2e-3) << "the quadrature itself, theta " << theta;
    const double c = DirectionalAlbedo(SurfaceMaterial::kCloth, cloth, v);
    const double s = DirectionalAlbedo(SurfaceMaterial::kSatin, satin, v);
    EXPECT_LE(c, 1.0) << "cloth, theta " << theta;
    EXPECT_LE(s, 1.0) << "satin, theta " << theta;
    EXPECT_GT(c, 0.5) << "cloth, theta " << theta;
    EXPECT_GT(s, 0.5) << "satin, theta " << theta;
  }
  // The scene's defaults too (satin's 0.07 alpha along the thread is sharper
  // than the range above; off normal view, where the quadrature resolves it).
  const TextileSceneOptions defaults;
  for (double theta : {30.0, 60.0, 80.0}) {
    const Eigen::Vector3d v = FromAngles(theta, 20.0);
    for (const ThreadBrdf& b : {defaults.cloth_warp, defaults.cloth_weft}) {
      EXPECT_LE(DirectionalAlbedo(SurfaceMaterial::kCloth, b, v), 1.0) << "cloth default, theta " << theta;
    }
    for (const ThreadBrdf& b : {defaults.satin_warp, defaults.satin_weft}) {
      EXPECT_LE(DirectionalAlbedo(SurfaceMaterial::kSatin, b, v), 1.0) << "satin default, theta " << theta;
    }
  }
}

// Cloth's sheen: per unit n.l, the reading rises as the light goes to grazing
// (camera overhead, as on the rig); Lambert's stays flat. Equal n.l compared
// between lambert and cloth at every light angle.
TEST(ClothBrdf, ClothSheenRisesTowardGrazingLightLambertDoesNot) {
  const ThreadBrdf brdf{0.2, 1.0, 1.0};
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ(), v = Eigen::Vector3d::UnitZ();
  constexpr double kAlbedo = 0.3;
  auto per_cos = [&](SurfaceMaterial m, double theta_l) {
    const Eigen::Vector3d l = FromAngles(theta_l, 0.0);
    const MaterialResponse r = EvaluateMaterial(m, brdf, n, Eigen::Vector3d::UnitY(), l, v);
    return (kAlbedo * r.diffuse + r.specular) / n.dot(l);
  };
  EXPECT_NEAR(per_cos(SurfaceMaterial::kLambert, 80.0), per_cos(SurfaceMaterial::kLambert, 10.0), 1e-12);
  double previous = 0;
  for (double theta : {10.0, 40.0, 60.0, 75.0, 85.0}) {
    const double value = per_cos(SurfaceMaterial::kCloth, theta);
    EXPECT_GT(value, previous) << "theta " << theta;
    previous = value;
  }
  EXPECT_GT(per_cos(SurfaceMaterial::kCloth, 85.0), 1.15 * per_cos(SurfaceMaterial::kCloth, 10.0));
}

// Satin's lobe is anisotropic: with the tangent along y, a half vector tilted
// along y keeps more of the lobe than one tilted along x; turning the light's
// azimuth by 90 deg changes the response.
TEST(ClothBrdf, SatinLobeIsLongerAlongTheThread) {
  const ThreadBrdf brdf{0.3, 0.3, 0.1};
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ(), v = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d along_y = FromAngles(30.0, 90.0), along_x = FromAngles(30.0, 0.0);
  const double spec_y = EvaluateMaterial(SurfaceMaterial::kSatin, brdf, n, Eigen::Vector3d::UnitY(), along_y, v).specular;
  const double spec_x = EvaluateMaterial(SurfaceMaterial::kSatin, brdf, n, Eigen::Vector3d::UnitY(), along_x, v).specular;
  EXPECT_GT(spec_y, 5 * spec_x);
  // A weft thread (tangent x) turns the lobe with it.
  const double weft_x = EvaluateMaterial(SurfaceMaterial::kSatin, brdf, n, Eigen::Vector3d::UnitX(), along_x, v).specular;
  EXPECT_NEAR(weft_x, spec_y, 1e-9 * spec_y);
  // Cloth is isotropic.
  const double cloth_y = EvaluateMaterial(SurfaceMaterial::kCloth, brdf, n, Eigen::Vector3d::UnitY(), along_y, v).specular;
  const double cloth_x = EvaluateMaterial(SurfaceMaterial::kCloth, brdf, n, Eigen::Vector3d::UnitY(), along_x, v).specular;
  EXPECT_NEAR(cloth_y, cloth_x, 1e-12);
}

TEST(ClothBrdf, BelowTheHorizonIsDarkAndNeverNaN) {
  const ThreadBrdf brdf{0.3, 0.3, 0.1};
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  for (SurfaceMaterial m : {SurfaceMaterial::kLambert, SurfaceMaterial::kCloth, SurfaceMaterial::kSatin}) {
    const MaterialResponse below = EvaluateMaterial(m, brdf, n, Eigen::Vector3d::UnitY(), FromAngles(100, 0), n);
    EXPECT_EQ(below.diffuse, 0.0);
    EXPECT_EQ(below.specular, 0.0);
    // Light and view opposite at grazing: h degenerates.
    const MaterialResponse opposite =
        EvaluateMaterial(m, brdf, n, Eigen::Vector3d::UnitY(), FromAngles(89.999, 0), FromAngles(89.999, 180));
    EXPECT_TRUE(std::isfinite(opposite.diffuse) && std::isfinite(opposite.specular));
    // Tangent along the normal: a frame is still found.
    const MaterialResponse along_n = EvaluateMaterial(m, brdf, n, n, FromAngles(30, 0), n);
    EXPECT_TRUE(std::isfinite(along_n.diffuse) && std::isfinite(along_n.specular));
  }
}

}  // namespace
}  // namespace scanbench
