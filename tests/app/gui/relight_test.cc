// The relight preview's shading (app/gui/relight_shading.h) against values
// worked out by hand from UE4's formulas, and the preview image built from it.
#include <QTest>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "app/gui/relight_shading.h"
#include "app/gui/result_images.h"

namespace scanbench {

namespace {
const Eigen::Vector3d kUp(0, 0, 1);
// 60 degrees from the normal in the x-z plane: h is then 30 degrees from n.
const Eigen::Vector3d kLight60(std::sqrt(3.0) / 2, 0, 0.5);

bool Near(double actual, double expected, double tolerance) { return std::abs(actual - expected) <= tolerance; }
}  // namespace

class RelightTest : public QObject {
  Q_OBJECT

 private slots:
  void DistributionAtThePeakIsOneOverPiAlphaSquared() {
    // n.h = 1: D = alpha² / (pi alpha⁴) = 1 / (pi alpha²); roughness 0.5 -> alpha² = 0.0625.
    QVERIFY(Near(GgxDistribution(1.0, 0.5), 1 / (std::numbers::pi * 0.0625), 1e-9));
    QVERIFY(Near(GgxDistribution(1.0, 0.5), 5.092958178940651, 1e-9));
    // n.h = cos 30°: (0.75 (0.0625 - 1) + 1)² = 0.296875² -> D = 0.0625 / (pi 0.088135) = 0.2257267.
    QVERIFY(Near(GgxDistribution(std::sqrt(3.0) / 2, 0.5), 0.22572667829099857, 1e-9));
    // Roughness 1 (alpha 1): D = 1/pi everywhere.
    QVERIFY(Near(GgxDistribution(0.3, 1.0), 1 / std::numbers::pi, 1e-12));
  }

  void GeometryIsSchlickWithKFromRemappedRoughness() {
    // k = (0.5 + 1)² / 8 = 0.28125; G1(0.5) = 0.5 / (0.5 * 0.71875 + 0.28125) = 0.780488.
    QVERIFY(Near(SchlickSmithG1(0.5, 0.5), 0.7804878048780488, 1e-12));
    QVERIFY(Near(SchlickSmithG1(1.0, 0.5), 1.0, 1e-12));
    QCOMPARE(SchlickSmithG1(-0.2, 0.5), 0.0);
    // Roughness 1: k = 0.5, G1(0.5) = 0.5 / 0.75.
    QVERIFY(Near(SmithSchlickGeometry(0.5, 1.0, 1.0), 2.0 / 3.0, 1e-12));
  }

  void FresnelUsesTheSphericalGaussianPower() {
    // v.h = 1: F = F0 + (1 - F0) 2^-12.53789 = 0.04 + 0.96 * 1.6816e-4.
    QVERIFY(Near(SchlickFresnel(0.04, 1.0), 0.04016143223543417, 1e-12));
    // v.h = cos 30°: exponent (-5.55473 * 0.866025 - 6.98316) * 0.866025 = -10.21363.
    QVERIFY(Near(SchlickFresnel(0.04, std::sqrt(3.0) / 2), 0.04080846046861902, 1e-12));
    // Grazing: everything reflects.
    QVERIFY(Near(SchlickFresnel(0.04, 0.0), 0.04 + 0.96 * std::exp2(0.0), 1e-12));
    QCOMPARE(SchlickFresnel(1.0, 0.3), 1.0);
  }

  void SpecularBrdfIsDfgOverFourNlNv() {
    // Light and viewer overhead: D F G / 4 = 5.092958 * 0.040161 * 1 / 4.
    QVERIFY(Near(GgxSpecularBrdf(kUp, kUp, kUp, 0.5, 0.04), 0.05113512369535629, 1e-12));
    // Light at 60°, viewer overhead: 0.225727 * 0.040808 * 0.780488 / (4 * 0.5 * 1).
    QVERIFY(Near(GgxSpecularBrdf(kUp, kLight60, kUp, 0.5, 0.04), 0.0035947544303418146, 1e-12));
    QVERIFY(Near(GgxSpecularBrdf(kUp, kLight60, kUp, 1.0, 0.04), 0.004329912135700614, 1e-12));
    // A light below the surface lights nothing.
    QCOMPARE(GgxSpecularBrdf(kUp, Eigen::Vector3d(0.6, 0, -0.8), kUp, 0.5, 0.04), 0.0);
  }

  void ShadingIsLambertPlusPiTimesTheLobe() {
    const Eigen::Vector3d albedo(0.5, 0.4, 0.2);
    RelightShading shading;
    QVERIFY(!shading.specular);  // the preview starts Lambertian
    const Eigen::Vector3d lambert = ShadeRelight(albedo, kUp, kLight60, kUp, shading);
    QVERIFY(lambert.isApprox(albedo * 0.5, 1e-12));
    shading.specular = true;
    shading.roughness = 0.5;
    shading.f0 = 0.04;
    const Eigen::Vector3d shaded = ShadeRelight(albedo, kUp, kLight60, kUp, shading);
    const double lobe = std::numbers::pi * 0.0035947544303418146 * 0.5;
    for (int c = 0; c < 3; ++c) QVERIFY(Near(shaded[c], albedo[c] * 0.5 + lobe, 1e-12));
    // Facing away from the light: black, with or without the lobe.
    QVERIFY(ShadeRelight(albedo, Eigen::Vector3d(-1, 0, 0), kLight60, kUp, shading).isZero());
  }

  void OptionsAreChecked() {
    RelightShading shading;
    shading.roughness = 0.0;
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, shading.Check());
    try {
      shading.Check();
    } catch (const std::invalid_argument& error) {
      QVERIFY2(QString(error.what()).contains("roughness = 0 must be in [0.02, 1]"), error.what());
    }
    shading.roughness = 0.5;
    shading.f0 = 1.5;
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, shading.Check());
    shading.f0 = std::nan("");
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, shading.Check());
  }

  void PreviewShowsTheHighlightWhereTheNormalIsTheHalfVector() {
    // Two pixels: one tilted to the half vector of a 60° light (mirror
    // direction), one flat. The lobe lifts the first far more than the second.
    RelightMaps maps;
    maps.normal = ImageF(2, 1, 3);
    maps.albedo = ImageF(2, 1, 3);
    const Eigen::Vector3d half = (kLight60 + kUp).normalized();
    for (int c = 0; c < 3; ++c) {
      maps.normal(0, 0, c) = float(half[c]);
      maps.normal(1, 0, c) = float(kUp[c]);
      maps.albedo(0, 0, c) = maps.albedo(1, 0, c) = 0.2f;
    }
    maps.albedo_scale = 1;
    const QImage matte = Relight(maps, kLight60.x(), kLight60.y(), kLight60.z());
    RelightShading glossy;
    glossy.specular = true;
    glossy.roughness = 0.3;
    const QImage shiny = Relight(maps, kLight60.x(), kLight60.y(), kLight60.z(), glossy);
    const int gain_at_mirror = qGreen(shiny.pixel(0, 0)) - qGreen(matte.pixel(0, 0));
    const int gain_off_mirror = qGreen(shiny.pixel(1, 0)) - qGreen(matte.pixel(1, 0));
    QVERIFY2(gain_at_mirror > 40, qPrintable(QString::number(gain_at_mirror)));
    QVERIFY2(gain_off_mirror < gain_at_mirror / 4, qPrintable(QString::number(gain_off_mirror)));
    glossy.roughness = 0.001;
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, Relight(maps, 0, 0, 1, glossy));
  }
};

}  // namespace scanbench

QTEST_GUILESS_MAIN(scanbench::RelightTest)
#include "relight_test.moc"
