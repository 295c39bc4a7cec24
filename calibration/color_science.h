// Colorimetry: CIE XYZ, linear Rec.709 (sRGB primaries), ACEScg, CIELAB, CIEDE2000 and the sRGB transfer
// curve. XYZ is CIE 1931 2-degree with Y of the white = 1 throughout. Matrices are derived from the
// primaries' chromaticities (not typed in), so each space's white maps exactly to (1, 1, 1).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace scanbench {

// The primaries and white of an RGB colour space, CIE 1931 xy.
struct Chromaticities {
  double red_x, red_y, green_x, green_y, blue_x, blue_y, white_x, white_y;
};

Chromaticities Rec709Chromaticities();  // (0.64,0.33) (0.30,0.60) (0.15,0.06), D65 (0.3127,0.3290)
Chromaticities AcescgChromaticities();  // AP1 (0.713,0.293) (0.165,0.830) (0.128,0.044), (0.32168,0.33767)

// XYZ (Y = 1) of the chromaticity (x, y).
Eigen::Vector3d XyzFromChromaticity(double x, double y);
// The normalised primary matrix: XYZ = M * rgb, white rgb (1, 1, 1) -> the white's XYZ with Y = 1.
Eigen::Matrix3d XyzFromRgb(const Chromaticities& space);

// Linear Rec.709 = linear sRGB primaries, D65 white (IEC 61966-2-1; ITU-R BT.709).
Eigen::Matrix3d XyzFromLinearRec709();
Eigen::Matrix3d LinearRec709FromXyz();
// ACEScg (AP1 primaries, ACES white ~D60) from linear Rec.709 (D65), Bradford-adapted: the ACES CSC matrices.
Eigen::Matrix3d AcescgFromLinearRec709();
Eigen::Matrix3d LinearRec709FromAcescg();

// The white of Rec.709, xy (0.3127, 0.3290) with Y = 1: (0.950456, 1, 1.089058). (The tabulated CIE D65
// through the 1931 observer reads (0.95047, 1, 1.08883); using the xy white keeps Rec.709 neutrals at
// a* = b* = 0.)
Eigen::Vector3d D65WhiteXyz();
// The ICC D50 white (0.9642, 1, 0.8249), the white of published ColorChecker Lab values.
Eigen::Vector3d D50WhiteXyz();

// Chromatic adaptation XYZ -> XYZ by the Bradford cone response (linear von Kries in the Bradford space).
Eigen::Matrix3d BradfordAdaptation(const Eigen::Vector3d& from_white_xyz, const Eigen::Vector3d& to_white_xyz);

// CIE 1976 L*a*b* (L* in [0, 100]) relative to white_xyz, and its inverse.
Eigen::Vector3d LabFromXyz(const Eigen::Vector3d& xyz, const Eigen::Vector3d& white_xyz);
Eigen::Vector3d XyzFromLab(const Eigen::Vector3d& lab, const Eigen::Vector3d& white_xyz);
Eigen::Vector3d LabFromLinearRec709(const Eigen::Vector3d& rgb_linear_rec709);  // D65 white
Eigen::Vector3d LinearRec709FromLab(const Eigen::Vector3d& lab_d65);             // D65 white

// CIEDE2000 colour difference with kL = kC = kH = 1 (Sharma, Wu & Dalal 2005).
double Ciede2000(const Eigen::Vector3d& lab1, const Eigen::Vector3d& lab2);

// Ciede2000 for many pixels (the solve's evaluation: one per sample pixel at
// 16 MP), about twice as fast and equal to it within 1e-12 (tested on the
// published pairs and on 1.2 M random ones: 2.4e-13 at most): no atan2 per
// colour, the hue difference and the mean hue's cosines from unit hue vectors
// (one atan2 for the mean hue, where the rotation term needs the angle),
// powers by multiplication. Where the formula jumps -- a chroma of 0, hues 180
// deg apart, a mean hue at the 0 / 360 deg wrap -- it calls Ciede2000 itself,
// so that both land on the same side.
double FastCiede2000(const Eigen::Vector3d& lab1, const Eigen::Vector3d& lab2);
// L*a*b* (D65) of linear Rec.709, equal to LabFromLinearRec709 within 1e-12
// (L*, a*, b* units; 3.9e-13 seen): CIELAB's cube root by Halley steps from an
// exponent-bit start instead of std::cbrt, the matrix and white folded into
// one constant matrix.
Eigen::Vector3d FastLabFromLinearRec709(const Eigen::Vector3d& rgb_linear_rec709);
// FastCiede2000(FastLabFromLinearRec709(rgb1), FastLabFromLinearRec709(rgb2)),
// for the solved albedo against the simulated truth: within 1e-12 of
// Ciede2000(LabFromLinearRec709(rgb1), LabFromLinearRec709(rgb2)) (6.3e-13
// seen), except when one colour is neutral: its a* b* are rounding noise of
// either Lab (1e-14) whose hue still enters CIEDE2000 scaled by sqrt(C1 C2),
// and the published formula itself moves by up to about 1e-7 between two such
// roundings (3.3e-7 seen against it; tests/calibration/color_science_test.cc).
double Ciede2000FromLinearRec709(const Eigen::Vector3d& rgb1_linear_rec709, const Eigen::Vector3d& rgb2_linear_rec709);

// Ciede2000FromLinearRec709 of `count` colour pairs: pair i is rgb1[3 i ..
// 3 i + 2] against rgb2[3 i .. 3 i + 2] (floats), its value goes to
// delta_e[i]. The solve's evaluation makes 11 M of them at 16 MP, so they run
// in double vector lanes (8 pairs a vector with AVX-512, 4 with AVX2, picked
// as the solver picks its kernels: solver/cpu_dispatch.h) with polynomial
// atan2, exp and sin: not bit for bit the scalar form, but within 1e-10 of the
// published formula (Ciede2000 of LabFromLinearRec709), and within 1e-5
// where a colour is neutral, where the published formula itself moves by
// 1e-7 to 1e-6 between roundings (tests/calibration/color_science_test.cc).
// Where the fast form calls the published formula, and for non-finite
// colours, the scalar Ciede2000FromLinearRec709 above gives the value. The
// calibration's fits use the scalar functions.
void Ciede2000FromLinearRec709(const float* rgb1, const float* rgb2, size_t count, double* delta_e);

// IEC 61966-2-1 sRGB transfer curve, linear -> encoded; clamps to [0, 1] (NaN reads 0).
double SrgbEncode(double linear);
// Its inverse, encoded -> linear; clamps to [0, 1] (NaN reads 0).
double SrgbDecode(double encoded);

// lround(SrgbEncode(linear) * (2^bits - 1)) of a float, exactly, without a pow
// per value (a 16 MP base colour is 48 M of them): the smallest float that
// reaches each code is found once, by bisection over the float bit patterns
// with SrgbEncode itself, and a guess from a table interpolated between the
// float octaves' steps is moved onto those thresholds. Exact because that
// quantisation never decreases as the float grows, which was checked for
// every float in [0, 1] at 8 and 16 bits (tests/calibration/color_science_test.cc
// checks the thresholds and a sample). Building one takes some 30 ms (16 bits).
class SrgbQuantizer {
 public:
  explicit SrgbQuantizer(int bits);  // [1, 16]
  // The shared 8- and 16-bit quantizers, built on first use.
  static const SrgbQuantizer& Of(int bits);
  int max_code() const { return max_code_; }
  uint16_t operator()(float linear) const;

 private:
  int max_code_ = 0;
  std::vector<float> lowest_;  // lowest_[k]: the smallest float whose code is >= k, k in [1, max_code]
  std::vector<float> node_;    // code * max at the floats whose low 16 bits are 0, for the guess
};

}  // namespace scanbench
