#include "calibration/color_checker.h"

#include <gtest/gtest.h>

#include "calibration/color_science.h"

namespace scanbench {
namespace {

// BabelColor's published average of 30 ColorChecker Classic charts, CIE xyY under D50 (2-degree observer),
// as distributed by colour-science (CCS_BABELCOLOR_AVERAGE, chromaticity_coordinates.py, BSD-3-Clause;
// BabelColor data (C) 2004-2012 Danny Pascale, used by permission). Chart order.
constexpr double kBabelColorAverageXyyD50[24][3] = {
    {0.4325, 0.3788, 0.1034}, {0.4191, 0.3748, 0.3525}, {0.2761, 0.3004, 0.1847}, {0.3700, 0.4501, 0.1335},
    {0.3020, 0.2877, 0.2324}, {0.2856, 0.3910, 0.4174}, {0.5291, 0.4075, 0.3117}, {0.2339, 0.2155, 0.1140},
    {0.5008, 0.3293, 0.1979}, {0.3326, 0.2556, 0.0644}, {0.3989, 0.4998, 0.4435}, {0.4962, 0.4428, 0.4358},
    {0.2040, 0.1696, 0.0579}, {0.3270, 0.5033, 0.2307}, {0.5709, 0.3298, 0.1268}, {0.4694, 0.4732, 0.6081},
    {0.4177, 0.2704, 0.2007}, {0.2151, 0.3037, 0.1903}, {0.3488, 0.3628, 0.9129}, {0.3451, 0.3596, 0.5885},
    {0.3446, 0.3590, 0.3595}, {0.3438, 0.3589, 0.1912}, {0.3423, 0.3576, 0.0893}, {0.3439, 0.3565, 0.0320},
};

Eigen::Vector3d XyzFromXyy(const double xyy[3]) {
  return {xyy[0] * xyy[2] / xyy[1], xyy[2], (1 - xyy[0] - xyy[1]) * xyy[2] / xyy[1]};
}

TEST(ColorChecker, OrderNamesAndNeutrals) {
  const std::vector<ColorCheckerPatch>& chart = ColorCheckerClassic();
  ASSERT_EQ(chart.size(), static_cast<size_t>(kColorCheckerRows * kColorCheckerColumns));
  EXPECT_EQ(chart[0].name, "dark skin");
  EXPECT_EQ(chart[5].name, "bluish green");    // top right
  EXPECT_EQ(chart[12].name, "blue");
  EXPECT_EQ(chart[18].name, "white 9.5 (.05 D)");  // bottom left
  EXPECT_EQ(chart[23].name, "black 2 (1.5 D)");    // bottom right
  for (size_t i = 0; i < chart.size(); ++i) {
    EXPECT_EQ(chart[i].neutral, i >= 18) << chart[i].name;
    EXPECT_TRUE(chart[i].reflectance.allFinite()) << chart[i].name;
    EXPECT_GE(chart[i].reflectance.minCoeff(), 0) << chart[i].name;
    EXPECT_LE(chart[i].reflectance.maxCoeff(), 1) << chart[i].name;
  }
  // The gray row darkens monotonically and is nearly neutral under D65.
  for (int i = 18; i < 24; ++i) {
    if (i > 18) {
      EXPECT_LT(chart[i].lab_d65.x(), chart[i - 1].lab_d65.x());
    }
    EXPECT_LT(std::hypot(chart[i].lab_d65.y(), chart[i].lab_d65.z()), 3.0) << chart[i].name;
  }
}

TEST(ColorChecker, SpectraReproduceBabelColorPublishedLab) {
  const std::vector<ColorCheckerPatch>& chart = ColorCheckerClassic();
  const Eigen::Vector3d white_d50 = XyzOfReflectance(Spectrum::Ones(), CieD50Spd());
  double worst = 0, mean = 0;
  for (int i = 0; i < 24; ++i) {
    const Eigen::Vector3d lab = LabFromXyz(XyzOfReflectance(chart[i].reflectance, CieD50Spd()), white_d50);
    const Eigen::Vector3d published = LabFromXyz(XyzFromXyy(kBabelColorAverageXyyD50[i]), D50WhiteXyz());
    const double delta_e = Ciede2000(lab, published);
    EXPECT_LT(delta_e, 1.0) << chart[i].name << " Lab " << lab.transpose() << " published " << published.transpose();
    worst = std::max(worst, delta_e);
    mean += delta_e / 24;
  }
  EXPECT_LT(mean, 0.3);  // measured 0.08: the spectra are the ones BabelColor's values were computed from
  RecordProperty("worst_delta_e_2000", std::to_string(worst));
}

TEST(ColorChecker, D65ColoursAgreeWithAdaptedPublishedValues) {
  // lab_d65 is computed spectrally under D65; the published D50 values, Bradford-adapted to D65, agree
  // within the error of a von Kries adaptation.
  const std::vector<ColorCheckerPatch>& chart = ColorCheckerClassic();
  const Eigen::Matrix3d adapt = BradfordAdaptation(D50WhiteXyz(), D65WhiteXyz());
  for (int i = 0; i < 24; ++i) {
    const ColorCheckerPatch& patch = chart[i];
    EXPECT_LT((patch.lab_d65 - LabFromLinearRec709(patch.linear_rec709)).norm(), 1e-12);
    const Eigen::Vector3d published_d65 = LabFromXyz(adapt * XyzFromXyy(kBabelColorAverageXyyD50[i]), D65WhiteXyz());
    EXPECT_LT(Ciede2000(patch.lab_d65, published_d65), 2.0) << patch.name;
  }
  // Known landmarks: the white patch reflects ~90 %, the black ~3 % (linear Rec.709 green).
  EXPECT_NEAR(chart[18].linear_rec709.y(), 0.90, 0.03);
  EXPECT_NEAR(chart[23].linear_rec709.y(), 0.031, 0.01);
}

}  // namespace
}  // namespace scanbench
