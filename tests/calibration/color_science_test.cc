#include "calibration/color_science.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "solver/cpu_dispatch.h"
#include "solver/kernel_math_impl.h"

namespace scanbench {
namespace {

void ExpectMatrixNear(const Eigen::Matrix3d& actual, const Eigen::Matrix3d& expected, double tolerance) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(actual(r, c), expected(r, c), tolerance) << "(" << r << ", " << c << ")";
  }
}

TEST(ColorScience, Rec709MatrixEqualsIec61966) {
  Eigen::Matrix3d iec;  // IEC 61966-2-1:1999, equation (F.7), four decimals
  iec << 0.4124, 0.3576, 0.1805,  //
      0.2126, 0.7152, 0.0722,     //
      0.0193, 0.1192, 0.9505;
  ExpectMatrixNear(XyzFromLinearRec709(), iec, 1e-4);
  Eigen::Matrix3d iec_inverse;  // equation (F.8): rounded from a different derivation, hence 1e-3
  iec_inverse << 3.2406, -1.5372, -0.4986,  //
      -0.9689, 1.8758, 0.0415,              //
      0.0557, -0.2040, 1.0570;
  ExpectMatrixNear(LinearRec709FromXyz(), iec_inverse, 1e-3);
}

TEST(ColorScience, XyzRec709RoundTripAndWhite) {
  std::mt19937 random(12);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d rgb(unit(random), unit(random), unit(random));
    EXPECT_LT((LinearRec709FromXyz() * (XyzFromLinearRec709() * rgb) - rgb).norm(), 1e-12);
  }
  EXPECT_LT((LinearRec709FromXyz() * D65WhiteXyz() - Eigen::Vector3d::Ones()).norm(), 1e-12);
  EXPECT_NEAR(D65WhiteXyz().x(), 0.95047, 2e-5);
  EXPECT_NEAR(D65WhiteXyz().z(), 1.08883, 3e-4);  // the xy white vs the tabulated D65 white
  const Eigen::Vector3d lab_white = LabFromLinearRec709(Eigen::Vector3d::Ones());
  EXPECT_NEAR(lab_white.x(), 100, 1e-9);
  EXPECT_NEAR(lab_white.y(), 0, 1e-9);
  EXPECT_NEAR(lab_white.z(), 0, 1e-9);
  // A neutral gray stays neutral.
  const Eigen::Vector3d lab_gray = LabFromLinearRec709(Eigen::Vector3d::Constant(0.18));
  EXPECT_NEAR(lab_gray.x(), 49.496, 1e-3);
  EXPECT_NEAR(lab_gray.y(), 0, 1e-9);
  EXPECT_NEAR(lab_gray.z(), 0, 1e-9);
}

TEST(ColorScience, LabRoundTrip) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int i = 0; i < 100; ++i) {
    // Includes dark colours, below the cube-root knee of CIELAB.
    const Eigen::Vector3d rgb = Eigen::Vector3d(unit(random), unit(random), unit(random)) * (i % 2 ? 1.0 : 0.005);
    EXPECT_LT((LinearRec709FromLab(LabFromLinearRec709(rgb)) - rgb).norm(), 1e-12);
  }
}

TEST(ColorScience, AcescgMatchesAcesCscMatrices) {
  // AP1 NPM from the ACES specification (S-2014-004, ACEScg).
  Eigen::Matrix3d ap1_npm;
  ap1_npm << 0.6624541811, 0.1340042065, 0.1561876870,  //
      0.2722287168, 0.6740817658, 0.0536895174,         //
      -0.0055746495, 0.0040607335, 1.0103391003;
  ExpectMatrixNear(XyzFromRgb(AcescgChromaticities()), ap1_npm, 1e-9);
  // AP0 NPM (S-2008-001, ACES2065-1) from the AP0 primaries and the same white.
  const Chromaticities ap0{0.7347, 0.2653, 0.0, 1.0, 0.0001, -0.0770, 0.32168, 0.33767};
  Eigen::Matrix3d ap0_npm;
  ap0_npm << 0.9525523959, 0.0, 0.0000936786,  //
      0.3439664498, 0.7281660966, -0.0721325464,   //
      0.0, 0.0, 1.0088251844;
  ExpectMatrixNear(XyzFromRgb(ap0), ap0_npm, 1e-9);
  // AP0 -> AP1 as published.
  Eigen::Matrix3d ap1_from_ap0;
  ap1_from_ap0 << 1.4514393161, -0.2365107469, -0.2149285693,  //
      -0.0765537734, 1.1762296998, -0.0996759264,              //
      0.0083161484, -0.0060324498, 0.9977163014;
  ExpectMatrixNear(XyzFromRgb(AcescgChromaticities()).inverse() * XyzFromRgb(ap0), ap1_from_ap0, 1e-9);
  // Linear sRGB (D65) -> ACEScg, Bradford, as in the ACES OpenColorIO config ("Utility - Linear - sRGB").
  Eigen::Matrix3d acescg_from_srgb;
  acescg_from_srgb << 0.613097402, 0.339523146, 0.047379451,  //
      0.070193722, 0.916353879, 0.013452398,                  //
      0.020615593, 0.109569773, 0.869814634;
  ExpectMatrixNear(AcescgFromLinearRec709(), acescg_from_srgb, 1e-4);
  // Adapted neutral stays neutral: white -> (1, 1, 1).
  EXPECT_LT((AcescgFromLinearRec709() * Eigen::Vector3d::Ones() - Eigen::Vector3d::Ones()).norm(), 1e-12);
  EXPECT_LT((LinearRec709FromAcescg() * AcescgFromLinearRec709() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

TEST(ColorScience, BradfordMapsWhiteToWhite) {
  const Eigen::Matrix3d adapt = BradfordAdaptation(D65WhiteXyz(), D50WhiteXyz());
  EXPECT_LT((adapt * D65WhiteXyz() - D50WhiteXyz()).norm(), 1e-12);
  // The published Bradford D65 -> D50 matrix (Lindbloom), to its 4 decimals... of its own whites.
  Eigen::Matrix3d lindbloom;
  lindbloom << 1.0478112, 0.0228866, -0.0501270,  //
      0.0295424, 0.9904844, -0.0170491,           //
      -0.0092345, 0.0150436, 0.7521316;
  ExpectMatrixNear(BradfordAdaptation(Eigen::Vector3d(0.95047, 1, 1.08883), Eigen::Vector3d(0.96422, 1, 0.82521)),
                   lindbloom, 1e-6);
}

struct Ciede2000Pair {
  double l1, a1, b1, l2, a2, b2, delta_e;
};

// Table 1 of Sharma, Wu & Dalal (2005), doi:10.1002/col.20070: all 34 pairs, delta E to 4 decimals.
constexpr Ciede2000Pair kSharmaWuDalalPairs[] = {
    {50.0000, 2.6772, -79.7751, 50.0000, 0.0000, -82.7485, 2.0425},
    {50.0000, 3.1571, -77.2803, 50.0000, 0.0000, -82.7485, 2.8615},
    {50.0000, 2.8361, -74.0200, 50.0000, 0.0000, -82.7485, 3.4412},
    {50.0000, -1.3802, -84.2814, 50.0000, 0.0000, -82.7485, 1.0000},
    {50.0000, -1.1848, -84.8006, 50.0000, 0.0000, -82.7485, 1.0000},
    {50.0000, -0.9009, -85.5211, 50.0000, 0.0000, -82.7485, 1.0000},
    {50.0000, 0.0000, 0.0000, 50.0000, -1.0000, 2.0000, 2.3669},
    {50.0000, -1.0000, 2.0000, 50.0000, 0.0000, 0.0000, 2.3669},
    {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0009, 7.1792},
    {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0010, 7.1792},
    {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0011, 7.2195},
    {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0012, 7.2195},
    {50.0000, -0.0010, 2.4900, 50.0000, 0.0009, -2.4900, 4.8045},
    {50.0000, -0.0010, 2.4900, 50.0000, 0.0010, -2.4900, 4.8045},
    {50.0000, -0.0010, 2.4900, 50.0000, 0.0011, -2.4900, 4.7461},
    {50.0000, 2.5000, 0.0000, 50.0000, 0.0000, -2.5000, 4.3065},
    {50.0000, 2.5000, 0.0000, 73.0000, 25.0000, -18.0000, 27.1492},
    {50.0000, 2.5000, 0.0000, 61.0000, -5.0000, 29.0000, 22.8977},
    {50.0000, 2.5000, 0.0000, 56.0000, -27.0000, -3.0000, 31.9030},
    {50.0000, 2.5000, 0.0000, 58.0000, 24.0000, 15.0000, 19.4535},
    {50.0000, 2.5000, 0.0000, 50.0000, 3.1736, 0.5854, 1.0000},
    {50.0000, 2.5000, 0.0000, 50.0000, 3.2972, 0.0000, 1.0000},
    {50.0000, 2.5000, 0.0000, 50.0000, 1.8634, 0.5757, 1.0000},
    {50.0000, 2.5000, 0.0000, 50.0000, 3.2592, 0.3350, 1.0000},
    {60.2574, -34.0099, 36.2677, 60.4626, -34.1751, 39.4387, 1.2644},
    {63.0109, -31.0961, -5.8663, 62.8187, -29.7946, -4.0864, 1.2630},
    {61.2901, 3.7196, -5.3901, 61.4292, 2.2480, -4.9620, 1.8731},
    {35.0831, -44.1164, 3.7933, 35.0232, -40.0716, 1.5901, 1.8645},
    {22.7233, 20.0904, -46.6940, 23.0331, 14.9730, -42.5619, 2.0373},
    {36.4612, 47.8580, 18.3852, 36.2715, 50.5065, 21.2231, 1.4146},
    {90.8027, -2.0831, 1.4410, 91.1528, -1.6435, 0.0447, 1.4441},
    {90.9257, -0.5406, -0.9208, 88.6381, -0.8985, -0.7239, 1.5381},
    {6.7747, -0.2908, -2.4247, 5.8714, -0.0985, -2.2286, 0.6377},
    {2.0776, 0.0795, -1.1350, 0.9033, -0.0636, -0.5514, 0.9082},
};

TEST(ColorScience, Ciede2000MatchesSharmaWuDalal2005) {
  int index = 0;
  for (const Ciede2000Pair& pair : kSharmaWuDalalPairs) {
    ++index;
    const Eigen::Vector3d lab1(pair.l1, pair.a1, pair.b1), lab2(pair.l2, pair.a2, pair.b2);
    EXPECT_NEAR(Ciede2000(lab1, lab2), pair.delta_e, 5e-5) << "pair " << index;
    EXPECT_NEAR(Ciede2000(lab2, lab1), pair.delta_e, 5e-5) << "pair " << index << " swapped";
  }
  EXPECT_EQ(index, 34);
  EXPECT_EQ(Ciede2000(Eigen::Vector3d(40, 10, -20), Eigen::Vector3d(40, 10, -20)), 0.0);
}

// FastCiede2000 on the published pairs: their figures, and Ciede2000's own within 1e-12.
TEST(ColorScience, FastCiede2000MatchesSharmaWuDalal2005) {
  int index = 0;
  for (const Ciede2000Pair& pair : kSharmaWuDalalPairs) {
    ++index;
    const Eigen::Vector3d lab1(pair.l1, pair.a1, pair.b1), lab2(pair.l2, pair.a2, pair.b2);
    EXPECT_NEAR(FastCiede2000(lab1, lab2), pair.delta_e, 5e-5) << "pair " << index;
    EXPECT_NEAR(FastCiede2000(lab2, lab1), pair.delta_e, 5e-5) << "pair " << index << " swapped";
    EXPECT_NEAR(FastCiede2000(lab1, lab2), Ciede2000(lab1, lab2), 1e-12) << "pair " << index;
    EXPECT_NEAR(FastCiede2000(lab2, lab1), Ciede2000(lab2, lab1), 1e-12) << "pair " << index << " swapped";
  }
  EXPECT_EQ(FastCiede2000(Eigen::Vector3d(40, 10, -20), Eigen::Vector3d(40, 10, -20)), 0.0);
}

// A random L*a*b* colour; every fourth a near-neutral one (chroma under 1e-6
// to 1), where the hue is least defined.
Eigen::Vector3d RandomLab(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> lightness(0, 100), ab(-128, 127), unit(0, 1);
  Eigen::Vector3d lab(lightness(rng), ab(rng), ab(rng));
  if (rng() % 4 == 0) lab.tail<2>() *= std::pow(10.0, -8 * unit(rng)) / 128;
  return lab;
}

// Rotates (a*, b*) by `degrees` (a pair whose hues differ by that).
Eigen::Vector3d RotatedHue(const Eigen::Vector3d& lab, double degrees) {
  const double r = degrees * std::numbers::pi / 180;
  return {lab.x(), std::cos(r) * lab.y() - std::sin(r) * lab.z(), std::sin(r) * lab.y() + std::cos(r) * lab.z()};
}

TEST(ColorScience, FastCiede2000EqualsCiede2000OnRandomColours) {
  std::mt19937_64 rng(20261203);
  std::uniform_real_distribution<double> small(-2, 2), near_zero(-1e-7, 1e-7);
  double max_difference = 0;
  int compared = 0;
  auto compare = [&](const Eigen::Vector3d& lab1, const Eigen::Vector3d& lab2) {
    const double reference = Ciede2000(lab1, lab2), fast = FastCiede2000(lab1, lab2);
    ASSERT_TRUE(std::isfinite(fast)) << lab1.transpose() << " / " << lab2.transpose();
    max_difference = std::max(max_difference, std::abs(fast - reference));
    ASSERT_NEAR(fast, reference, 1e-12) << lab1.transpose() << " / " << lab2.transpose();
    ++compared;
  };
  for (int i = 0; i < 200000; ++i) {
    const Eigen::Vector3d lab1 = RandomLab(rng);
    compare(lab1, RandomLab(rng));                                                  // any two colours
    compare(lab1, lab1 + Eigen::Vector3d(small(rng), small(rng), small(rng)));      // a close pair (the solve's)
    compare(lab1, RotatedHue(lab1, 180 + near_zero(rng)));                          // hues 180 deg apart
    compare(lab1, RotatedHue(lab1, 180 + 1e-3 * small(rng)));                       // just inside the fallback
    const Eigen::Vector3d on_axis(lab1.x(), std::abs(lab1.y()) + 1, near_zero(rng));  // mean hue at the wrap
    compare(on_axis, RotatedHue(on_axis, small(rng)));
    compare(on_axis, Eigen::Vector3d(on_axis.x(), on_axis.y(), -on_axis.z()));
  }
  // Zero chroma, both and either.
  compare(Eigen::Vector3d(50, 0, 0), Eigen::Vector3d(60, 0, 0));
  compare(Eigen::Vector3d(50, 0, 0), Eigen::Vector3d(50, 3, -4));
  compare(Eigen::Vector3d(50, 3, -4), Eigen::Vector3d(50, 0, 0));
  std::cout << compared << " pairs, largest |FastCiede2000 - Ciede2000| = " << max_difference << "\n";
}

// Within 1e-12 of the published formula on the published Lab, except where
// one colour is neutral: its a* b* are then rounding noise (1e-14, either
// Lab's), whose hue still enters the mean hue and the rotation term, which
// scale with sqrt(C1 C2): CIEDE2000 itself moves by up to about 1e-7 between
// two such roundings of the same grey (2e-8 seen here); there within 1e-6.
TEST(ColorScience, Ciede2000FromLinearRec709EqualsTheReference) {
  std::mt19937_64 rng(1554628252);
  std::uniform_real_distribution<double> reflectance(0, 1.2), small(-0.02, 0.02), negative(-0.05, 0.0);
  double max_lab = 0, max_delta_e = 0, max_delta_e_neutral = 0;
  for (int i = 0; i < 200000; ++i) {
    Eigen::Vector3d rgb(reflectance(rng), reflectance(rng), reflectance(rng));
    if (i % 10 == 0) rgb *= 1e-3;                          // dark: CIELAB's linear toe
    if (i % 10 == 1) rgb.setConstant(rgb.x());             // neutral: chroma 0 up to rounding
    if (i % 10 == 2) rgb.x() = negative(rng);              // out of gamut (a colour matrix can do that)
    const Eigen::Vector3d lab = LabFromLinearRec709(rgb), fast_lab = FastLabFromLinearRec709(rgb);
    max_lab = std::max(max_lab, (fast_lab - lab).cwiseAbs().maxCoeff());
    ASSERT_LT((fast_lab - lab).cwiseAbs().maxCoeff(), 1e-12) << rgb.transpose();
    const Eigen::Vector3d other = rgb + Eigen::Vector3d(small(rng), small(rng), small(rng));
    const double reference = Ciede2000(LabFromLinearRec709(rgb), LabFromLinearRec709(other));
    const double fast = Ciede2000FromLinearRec709(rgb, other);
    if (lab.tail<2>().norm() < 1e-9) {
      max_delta_e_neutral = std::max(max_delta_e_neutral, std::abs(fast - reference));
      ASSERT_NEAR(fast, reference, 1e-6) << rgb.transpose() << " / " << other.transpose();
    } else {
      max_delta_e = std::max(max_delta_e, std::abs(fast - reference));
      ASSERT_NEAR(fast, reference, 1e-12) << rgb.transpose() << " / " << other.transpose();
    }
  }
  std::cout << "largest |FastLab - Lab| = " << max_lab << ", |Ciede2000FromLinearRec709 - reference| = " << max_delta_e
            << ", with a neutral colour " << max_delta_e_neutral << "\n";
}

// Random float colour pairs of the kinds the evaluation meets and the fast
// form defers on: dark (CIELAB's linear toe), neutral, out of gamut, close
// pairs (a solve's miss), equal pairs, hues opposite about a grey, black, and
// now and then a non-finite value.
struct FloatPairs {
  std::vector<float> colours1, colours2;
};

FloatPairs RandomFloatPairs(size_t count, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> reflectance(0, 1.2f), small(-0.02f, 0.02f), negative(-0.05f, 0.0f);
  FloatPairs pairs{std::vector<float>(3 * count), std::vector<float>(3 * count)};
  for (size_t i = 0; i < count; ++i) {
    float* rgb1 = pairs.colours1.data() + 3 * i;
    float* rgb2 = pairs.colours2.data() + 3 * i;
    for (int c = 0; c < 3; ++c) rgb1[c] = reflectance(rng);
    if (i % 10 == 0) for (int c = 0; c < 3; ++c) rgb1[c] *= 1e-3f;  // dark
    if (i % 10 == 1) rgb1[1] = rgb1[2] = rgb1[0];                      // neutral
    if (i % 10 == 2) rgb1[0] = negative(rng);                          // out of gamut
    for (int c = 0; c < 3; ++c) rgb2[c] = rgb1[c] + small(rng);
    if (i % 10 == 3) for (int c = 0; c < 3; ++c) rgb2[c] = rgb1[c];   // equal
    if (i % 10 == 4) for (int c = 0; c < 3; ++c) rgb2[c] = 1.0f - rgb1[c];  // opposite hues about a grey
    if (i % 10 == 5) for (int c = 0; c < 3; ++c) rgb2[c] = reflectance(rng);  // any two colours
    if (i % 1000 == 6) for (int c = 0; c < 3; ++c) rgb1[c] = rgb2[c] = 0.0f;  // black
    if (i % 100000 == 7) rgb2[1] = std::numeric_limits<float>::infinity();
  }
  return pairs;
}

// The published formula of a float pair, as the evaluation's figure is defined.
double ReferenceDeltaE(const float* rgb1, const float* rgb2) {
  return Ciede2000(LabFromLinearRec709(Eigen::Vector3d(rgb1[0], rgb1[1], rgb1[2])),
                   LabFromLinearRec709(Eigen::Vector3d(rgb2[0], rgb2[1], rgb2[2])));
}

// The many-pairs form (double lanes with polynomial atan2, exp and sin; every
// instruction set this CPU runs, picked as the solver picks its kernels) is
// within 1e-5 of the published formula on 2 M random pairs each (the
// evaluation's allowance): 1e-10 where neither colour is neutral; where one
// is (chroma under 1e-6), the published formula itself moves by 1e-7 to 1e-6
// between two roundings of the grey's Lab
// (Ciede2000FromLinearRec709EqualsTheReference), so there only the allowance
// holds (1.1e-6 seen). Counts that leave a part block.
TEST(ColorScience, ManyPairsAreWithinTheReferenceOnEveryIsa) {
  const size_t count = 2000003;
  const FloatPairs pairs = RandomFloatPairs(count, 77);
  std::vector<double> reference(count);
  for (size_t i = 0; i < count; ++i) {
    reference[i] = ReferenceDeltaE(pairs.colours1.data() + 3 * i, pairs.colours2.data() + 3 * i);
  }
  for (const KernelIsa isa : SupportedKernelIsas()) {
    OverrideKernelIsa(isa);
    for (const size_t n : {count, size_t{1}, size_t{3}, size_t{63}, size_t{65}, size_t{1025}}) {
      std::vector<double> values(n + 1, -1.0);
      Ciede2000FromLinearRec709(pairs.colours1.data(), pairs.colours2.data(), n, values.data());
      double largest = 0, largest_neutral = 0;
      for (size_t i = 0; i < n; ++i) {
        const float* rgb1 = pairs.colours1.data() + 3 * i;
        const float* rgb2 = pairs.colours2.data() + 3 * i;
        if (!std::isfinite(reference[i])) {
          // Not finite in: what the scalar fast form gives (the kernel defers to it).
          const double scalar = Ciede2000FromLinearRec709(Eigen::Vector3d(rgb1[0], rgb1[1], rgb1[2]),
                                                          Eigen::Vector3d(rgb2[0], rgb2[1], rgb2[2]));
          ASSERT_EQ(std::isnan(values[i]), std::isnan(scalar)) << "pair " << i;
          continue;
        }
        const bool neutral = LabFromLinearRec709(Eigen::Vector3d(rgb1[0], rgb1[1], rgb1[2])).tail<2>().norm() < 1e-6 ||
                             LabFromLinearRec709(Eigen::Vector3d(rgb2[0], rgb2[1], rgb2[2])).tail<2>().norm() < 1e-6;
        const double difference = std::abs(values[i] - reference[i]);
        (neutral ? largest_neutral : largest) = std::max(neutral ? largest_neutral : largest, difference);
        ASSERT_LE(difference, neutral ? 1e-5 : 1e-10)
            << KernelIsaName(isa) << ", pair " << i << " of " << n << ": " << values[i] << " against " << reference[i];
      }
      EXPECT_EQ(values[n], -1.0) << "nothing written past the last pair";
      if (n == count) {
        std::cout << KernelIsaName(isa) << ": " << n << " pairs, largest |many-pairs - published| = " << largest
                  << ", with a neutral colour " << largest_neutral << "\n";
      }
    }
  }
  ClearKernelIsaOverride();
}

// The published pairs through the many-pairs form: each Lab made into linear
// Rec.709 (LinearRec709FromLab) and rounded to float; the many-pairs value
// against the published formula of the same float colours, and against the
// table's figure (4 decimals, plus what the float rounding of the colours moves).
TEST(ColorScience, ManyPairsMatchSharmaWuDalal2005OnEveryIsa) {
  std::vector<float> colours1, colours2;
  std::vector<double> published;
  for (const Ciede2000Pair& pair : kSharmaWuDalalPairs) {
    for (const bool swapped : {false, true}) {
      const Eigen::Vector3d lab1(pair.l1, pair.a1, pair.b1), lab2(pair.l2, pair.a2, pair.b2);
      const Eigen::Vector3d rgb1 = LinearRec709FromLab(swapped ? lab2 : lab1);
      const Eigen::Vector3d rgb2 = LinearRec709FromLab(swapped ? lab1 : lab2);
      for (int c = 0; c < 3; ++c) {
        colours1.push_back(static_cast<float>(rgb1[c]));
        colours2.push_back(static_cast<float>(rgb2[c]));
      }
      published.push_back(pair.delta_e);
    }
  }
  const size_t count = published.size();
  for (const KernelIsa isa : SupportedKernelIsas()) {
    OverrideKernelIsa(isa);
    std::vector<double> values(count);
    Ciede2000FromLinearRec709(colours1.data(), colours2.data(), count, values.data());
    for (size_t i = 0; i < count; ++i) {
      const double reference = ReferenceDeltaE(colours1.data() + 3 * i, colours2.data() + 3 * i);
      EXPECT_NEAR(values[i], reference, 1e-6) << KernelIsaName(isa) << ", pair " << i / 2 + 1;
      EXPECT_NEAR(values[i], published[i], 2e-3) << KernelIsaName(isa) << ", pair " << i / 2 + 1;
    }
  }
  ClearKernelIsaOverride();
}

// The kernels' own maths against the C library.
TEST(ColorScience, KernelMathIsWithinItsStatedError) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi), magnitude(-30, 30),
      unit(0, 1);
  double atan2_error = 0, cbrt_error = 0, exp_error = 0, sin_error = 0;
  for (int i = 0; i < 1000000; ++i) {
    const double r = std::pow(10.0, magnitude(rng) / 10), a = angle(rng);
    const double y = r * std::sin(a), x = r * std::cos(a);
    atan2_error = std::max(atan2_error, std::abs(kernel_math::Atan2(y, x) - std::atan2(y, x)));
    const double t = std::pow(10.0, magnitude(rng));
    cbrt_error = std::max(cbrt_error, std::abs(kernel_math::CbrtPositive(t) / std::cbrt(t) - 1));
    const double e = -130 * unit(rng);
    exp_error = std::max(exp_error, std::abs(kernel_math::ExpNonPositive(e) / std::exp(e) - 1));
    const double s = std::numbers::pi / 2 * (2 * unit(rng) - 1);
    sin_error = std::max(sin_error, std::abs(kernel_math::SinSmall(s) - std::sin(s)));
  }
  for (const double axis : {0.0, 1.0, -1.0}) {  // on the axes and at the diagonals
    for (const double other : {0.0, 1.0, -1.0}) {
      if (axis == 0 && other == 0) continue;
      atan2_error = std::max(atan2_error, std::abs(kernel_math::Atan2(axis, other) - std::atan2(axis, other)));
    }
  }
  EXPECT_EQ(kernel_math::Atan2(0.0, 0.0), 0.0);
  EXPECT_LT(atan2_error, 1e-15);
  EXPECT_LT(cbrt_error, 1e-15);
  EXPECT_LT(exp_error, 1e-14);
  EXPECT_LT(sin_error, 1e-15);
  std::cout << "largest errors: atan2 " << atan2_error << " rad, cbrt " << cbrt_error << " relative, exp " << exp_error
            << " relative, sin " << sin_error << "\n";
}

TEST(ColorScience, SrgbTransferCurveKnownValues) {
  EXPECT_EQ(SrgbEncode(0), 0);
  EXPECT_EQ(SrgbEncode(1), 1);
  EXPECT_EQ(SrgbEncode(-0.5), 0);
  EXPECT_EQ(SrgbEncode(2), 1);
  EXPECT_EQ(SrgbEncode(std::nan("")), 0);
  EXPECT_EQ(SrgbDecode(std::nan("")), 0);
  EXPECT_NEAR(SrgbEncode(0.0031308), 0.0404500, 1e-6);  // the knee, continuous
  EXPECT_NEAR(SrgbEncode(0.0031309), 0.0404512, 1e-6);
  EXPECT_NEAR(SrgbEncode(0.18), 0.461356, 1e-6);         // 18 % gray reads 118 of 255
  EXPECT_NEAR(SrgbEncode(0.5), 0.735357, 1e-6);
  EXPECT_NEAR(SrgbDecode(0.5), 0.214041, 1e-6);
  EXPECT_NEAR(SrgbDecode(0.04045), 0.0031308, 1e-7);
  EXPECT_NEAR(SrgbDecode(128.0 / 255), 0.215861, 1e-6);
  for (double v = 0; v <= 1; v += 0.01) EXPECT_NEAR(SrgbDecode(SrgbEncode(v)), v, 1e-12);
}

// The quantizer is lround(SrgbEncode(v) * max) without a pow per value: equal
// on either side of every code's threshold, on a random sample, at the
// knee and at the ends (a check over every float in [0, 1] was run once:
// docs/export.md, "Memory and time at 16 MP").
TEST(ColorScience, SrgbQuantizerEqualsTheRoundedCurve) {
  for (int bits : {8, 16}) {
    const SrgbQuantizer& quantize = SrgbQuantizer::Of(bits);
    const double max = (1 << bits) - 1;
    ASSERT_EQ(quantize.max_code(), (1 << bits) - 1);
    auto expected = [max](float v) { return std::lround(SrgbEncode(v) * max); };
    int checked_codes = 0;
    for (int k = 1; k <= quantize.max_code(); ++k) {
      // The first float whose rounded curve reaches k, and its float neighbours.
      float lo = 0.0f, hi = 1.0f;
      while (std::nextafter(lo, 2.0f) < hi) {
        const float mid = std::bit_cast<float>((std::bit_cast<uint32_t>(lo) + std::bit_cast<uint32_t>(hi)) / 2);
        (expected(mid) >= k ? hi : lo) = mid;
      }
      for (float v : {lo, hi, std::nextafter(lo, 0.0f), std::nextafter(hi, 2.0f)}) {
        ASSERT_EQ(quantize(v), expected(v)) << bits << " bits, v = " << v << " near code " << k;
      }
      ++checked_codes;
    }
    EXPECT_EQ(checked_codes, quantize.max_code());
    std::mt19937 random(17);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (int i = 0; i < 200000; ++i) {
      const float v = i % 2 ? unit(random) : unit(random) * 0.01f;
      ASSERT_EQ(quantize(v), expected(v)) << bits << " bits, v = " << v;
    }
    for (float v : {0.0f, -0.0f, -1.0f, 1.0f, 2.0f, 0.0031308f, 1e-30f, std::nanf("")}) {
      EXPECT_EQ(quantize(v), std::isnan(v) ? 0 : expected(v)) << bits << " bits, v = " << v;
    }
  }
}

}  // namespace
}  // namespace scanbench
