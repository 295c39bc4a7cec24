#include "calibration/spectra.h"

#include <cmath>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "calibration/spectral_table.h"

namespace scanbench {
namespace {

int PeakIndex(const Spectrum& s) {
  int index = 0;
  s.maxCoeff(&index);
  return index;
}

// McCamy's (1992) approximation of the correlated colour temperature from CIE 1931 xy, K.
double McCamyCct(const Eigen::Vector2d& xy) {
  const double n = (xy.x() - 0.3320) / (0.1858 - xy.y());
  return 449 * n * n * n + 3525 * n * n + 6823.3 * n + 5520.33;
}

TEST(Spectra, TablesAreCompleteAndFinite) {
  for (const Spectrum& s : Cie1931ColorMatchingFunctions()) EXPECT_TRUE(s.allFinite());
  EXPECT_TRUE(CieD65Spd().allFinite());
  EXPECT_TRUE(CieD50Spd().allFinite());
  EXPECT_TRUE(CieLedB5Spd().allFinite());
  for (const Spectrum& s : NikonD5100Sensitivities().rgb) {
    EXPECT_TRUE(s.allFinite());
    EXPECT_GE(s.minCoeff(), 0);
  }
  for (const Spectrum& s : Mallett2019Basis()) EXPECT_TRUE(s.allFinite());
  // Known samples: y-bar peaks at 555 nm with 1.0; D65 and D50 are normalised to 100 at 560 nm.
  const int i555 = static_cast<int>((555 - kSpectrumFirstNm) / kSpectrumStepNm);
  EXPECT_EQ(PeakIndex(Cie1931ColorMatchingFunctions()[1]), i555);
  EXPECT_NEAR(Cie1931ColorMatchingFunctions()[1](i555), 1.0, 1e-4);
  EXPECT_NEAR(CieD65Spd()(i555 + 1), 100.0, 1e-9);
  EXPECT_NEAR(CieD50Spd()(i555 + 1), 100.0, 1e-9);
  EXPECT_EQ(SpectrumWavelengthNm(kSpectrumSamples - 1), 780);
}

TEST(Spectra, MissingTableThrowsNamingIt) {
  try {
    ParseSpectralTable("no_such_table.csv", 1);
    FAIL() << "no throw";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("no_such_table.csv"), std::string::npos) << error.what();
  }
  // The right table with the wrong column count is refused too.
  EXPECT_THROW(ParseSpectralTable("cie_d65.csv", 3), std::runtime_error);
}

TEST(Spectra, IlluminantWhitePoints) {
  const Eigen::Vector2d d65 = ChromaticityOfIlluminant(CieD65Spd());
  EXPECT_NEAR(d65.x(), 0.3127, 1e-3);
  EXPECT_NEAR(d65.y(), 0.3290, 1e-3);
  const Eigen::Vector2d d50 = ChromaticityOfIlluminant(CieD50Spd());
  EXPECT_NEAR(d50.x(), 0.3457, 1e-3);
  EXPECT_NEAR(d50.y(), 0.3585, 1e-3);
  // CIE 015:2018 Table 11.x: LED-B5 at (0.3118, 0.3236), CCT 6598 K.
  const Eigen::Vector2d led = ChromaticityOfIlluminant(CieLedB5Spd());
  EXPECT_NEAR(led.x(), 0.3118, 1e-3);
  EXPECT_NEAR(led.y(), 0.3236, 1e-3);
  EXPECT_NEAR(McCamyCct(led), 6598, 60);
  // A perfect white reads Y = 1 under any light.
  EXPECT_NEAR(XyzOfReflectance(Spectrum::Ones(), CieLedB5Spd()).y(), 1.0, 1e-12);
}

TEST(Spectra, NikonD5100PeaksInOrder) {
  const SpectralSensitivities& camera = NikonD5100Sensitivities();
  const double red = SpectrumWavelengthNm(PeakIndex(camera.rgb[0]));
  const double green = SpectrumWavelengthNm(PeakIndex(camera.rgb[1]));
  const double blue = SpectrumWavelengthNm(PeakIndex(camera.rgb[2]));
  EXPECT_LT(blue, green);
  EXPECT_LT(green, red);
  EXPECT_GT(blue, 430);
  EXPECT_LT(blue, 480);
  EXPECT_GT(green, 500);
  EXPECT_LT(green, 560);
  EXPECT_GT(red, 580);
  EXPECT_LT(red, 630);
}

TEST(Spectra, CameraWhiteBalance) {
  const SpectralSensitivities& camera = NikonD5100Sensitivities();
  const Eigen::Vector3d white = WhiteBalancedCameraRgb(camera, CieLedB5Spd(), Spectrum::Ones());
  EXPECT_LT((white - Eigen::Vector3d::Ones()).norm(), 1e-12);
  const Eigen::Vector3d gray = WhiteBalancedCameraRgb(camera, CieLedB5Spd(), Spectrum::Constant(0.2));
  EXPECT_LT((gray - Eigen::Vector3d::Constant(0.2)).norm(), 1e-12);
  const Eigen::Vector3d relative = CameraWhiteRelativeToGreen(camera, CieLedB5Spd());
  EXPECT_DOUBLE_EQ(relative.y(), 1.0);
  // Behind a Bayer filter green gathers the most of a white LED.
  EXPECT_GT(relative.x(), 0.2);
  EXPECT_LT(relative.x(), 1.0);
  EXPECT_GT(relative.z(), 0.2);
  EXPECT_LT(relative.z(), 1.0);
  // A reddish reflectance reads red > green > blue in white-balanced camera RGB.
  const Eigen::Vector3d red = WhiteBalancedCameraRgb(camera, CieLedB5Spd(), ReflectanceFromLinearRec709({0.6, 0.1, 0.05}));
  EXPECT_GT(red.x(), red.y());
  EXPECT_GT(red.y(), red.z());
}

TEST(Spectra, Mallett2019RoundTripStaysPhysical) {
  const std::array<Spectrum, 3>& basis = Mallett2019Basis();
  EXPECT_LT((basis[0] + basis[1] + basis[2] - Spectrum::Ones()).cwiseAbs().maxCoeff(), 2e-5);  // as tabulated
  std::mt19937 random(2019);
  std::uniform_real_distribution<double> unit(0, 1);
  double worst = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d rgb(unit(random), unit(random), unit(random));
    const Spectrum reflectance = ReflectanceFromLinearRec709(rgb);
    EXPECT_GE(reflectance.minCoeff(), 0);
    EXPECT_LE(reflectance.maxCoeff(), 1);
    worst = std::max(worst, (LinearRec709OfReflectance(reflectance) - rgb).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-3);
  EXPECT_LT((LinearRec709OfReflectance(Spectrum::Ones()) - Eigen::Vector3d::Ones()).norm(), 1e-12);
  // Out-of-range and NaN input still gives a physical reflectance.
  const Spectrum wild = ReflectanceFromLinearRec709({2.0, -1.0, std::nan("")});
  EXPECT_TRUE(wild.allFinite());
  EXPECT_GE(wild.minCoeff(), 0);
  EXPECT_LE(wild.maxCoeff(), 1);
}

}  // namespace
}  // namespace scanbench
