#include "calibration/color_science.h"

#include <algorithm>
#include <cstdint>
#include <bit>
#include <stdexcept>
#include <string>
#include <cmath>
#include <numbers>

#include <Eigen/LU>

#include "calibration/color_kernels.h"
#include "solver/cpu_dispatch.h"

namespace scanbench {
namespace {

constexpr double kPi = std::numbers::pi;

double Degrees(double radians) { return radians * 180.0 / kPi; }
double Radians(double degrees) { return degrees * kPi / 180.0; }

// CIELAB's f(t): cube root above (6/29)^3, the linear toe below it.
double LabF(double t) {
  constexpr double kDelta = 6.0 / 29.0;
  return t > kDelta * kDelta * kDelta ? std::cbrt(t) : t / (3 * kDelta * kDelta) + 4.0 / 29.0;
}

double LabFInverse(double f) {
  constexpr double kDelta = 6.0 / 29.0;
  return f > kDelta ? f * f * f : 3 * kDelta * kDelta * (f - 4.0 / 29.0);
}

// Hue angle in degrees, [0, 360); 0 for a zero vector, as Sharma et al. specify.
double HueDegrees(double b, double a) {
  if (a == 0 && b == 0) return 0;
  const double h = Degrees(std::atan2(b, a));
  return h < 0 ? h + 360 : h;
}

// CIEDE2000's last steps (Sharma, Wu & Dalal 2005, (17)-(22)): the
// weighting functions and the rotation term applied to the differences, from
// the means, T, delta theta and R_C; the one copy both forms end in.
double WeightedDifference(double delta_lp, double delta_cp, double delta_big_hp, double l_barp, double c_barp,
                          double t, double delta_theta, double r_c) {
  const double l50 = (l_barp - 50) * (l_barp - 50);
  const double s_l = 1 + 0.015 * l50 / std::sqrt(20 + l50);
  const double s_c = 1 + 0.045 * c_barp;
  const double s_h = 1 + 0.015 * c_barp * t;
  const double r_t = -std::sin(Radians(2 * delta_theta)) * r_c;
  const double dl = delta_lp / s_l;
  const double dc = delta_cp / s_c;
  const double dh = delta_big_hp / s_h;
  return std::sqrt(dl * dl + dc * dc + dh * dh + r_t * dc * dh);
}

}  // namespace

Chromaticities Rec709Chromaticities() { return {0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290}; }

Chromaticities AcescgChromaticities() { return {0.713, 0.293, 0.165, 0.830, 0.128, 0.044, 0.32168, 0.33767}; }

Eigen::Vector3d XyzFromChromaticity(double x, double y) { return {x / y, 1.0, (1 - x - y) / y}; }

Eigen::Matrix3d XyzFromRgb(const Chromaticities& space) {
  Eigen::Matrix3d primaries;
  primaries.col(0) = XyzFromChromaticity(space.red_x, space.red_y);
  primaries.col(1) = XyzFromChromaticity(space.green_x, space.green_y);
  primaries.col(2) = XyzFromChromaticity(space.blue_x, space.blue_y);
  // Scale each primary so that rgb (1, 1, 1) sums to the white.
  const Eigen::Vector3d scale = primaries.lu().solve(XyzFromChromaticity(space.white_x, space.white_y));
  return primaries * scale.asDiagonal();
}

Eigen::Matrix3d XyzFromLinearRec709() {
  static const Eigen::Matrix3d m = XyzFromRgb(Rec709Chromaticities());
  return m;
}

Eigen::Matrix3d LinearRec709FromXyz() {
  static const Eigen::Matrix3d m = XyzFromLinearRec709().inverse();
  return m;
}

Eigen::Matrix3d AcescgFromLinearRec709() {
  static const Eigen::Matrix3d m = [] {
    const Chromaticities ap1 = AcescgChromaticities();
    const Eigen::Matrix3d adapt = BradfordAdaptation(D65WhiteXyz(), XyzFromChromaticity(ap1.white_x, ap1.white_y));
    return Eigen::Matrix3d(XyzFromRgb(ap1).inverse() * adapt * XyzFromLinearRec709());
  }();
  return m;
}

Eigen::Matrix3d LinearRec709FromAcescg() {
  static const Eigen::Matrix3d m = AcescgFromLinearRec709().inverse();
  return m;
}

Eigen::Vector3d D65WhiteXyz() {
  const Chromaticities rec709 = Rec709Chromaticities();
  return XyzFromChromaticity(rec709.white_x, rec709.white_y);
}

Eigen::Vector3d D50WhiteXyz() { return {0.9642, 1.0, 0.8249}; }

Eigen::Matrix3d BradfordAdaptation(const Eigen::Vector3d& from_white_xyz, const Eigen::Vector3d& to_white_xyz) {
  Eigen::Matrix3d cone_from_xyz;
  cone_from_xyz << 0.8951, 0.2664, -0.1614,  //
      -0.7502, 1.7135, 0.0367,               //
      0.0389, -0.0685, 1.0296;
  const Eigen::Vector3d from = cone_from_xyz * from_white_xyz;
  const Eigen::Vector3d to = cone_from_xyz * to_white_xyz;
  return cone_from_xyz.inverse() * to.cwiseQuotient(from).asDiagonal() * cone_from_xyz;
}

Eigen::Vector3d LabFromXyz(const Eigen::Vector3d& xyz, const Eigen::Vector3d& white_xyz) {
  const double fx = LabF(xyz.x() / white_xyz.x());
  const double fy = LabF(xyz.y() / white_xyz.y());
  const double fz = LabF(xyz.z() / white_xyz.z());
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

Eigen::Vector3d XyzFromLab(const Eigen::Vector3d& lab, const Eigen::Vector3d& white_xyz) {
  const double fy = (lab.x() + 16) / 116;
  const double fx = fy + lab.y() / 500;
  const double fz = fy - lab.z() / 200;
  return {white_xyz.x() * LabFInverse(fx), white_xyz.y() * LabFInverse(fy), white_xyz.z() * LabFInverse(fz)};
}

Eigen::Vector3d LabFromLinearRec709(const Eigen::Vector3d& rgb_linear_rec709) {
  return LabFromXyz(XyzFromLinearRec709() * rgb_linear_rec709, D65WhiteXyz());
}

Eigen::Vector3d LinearRec709FromLab(const Eigen::Vector3d& lab_d65) {
  return LinearRec709FromXyz() * XyzFromLab(lab_d65, D65WhiteXyz());
}

double Ciede2000(const Eigen::Vector3d& lab1, const Eigen::Vector3d& lab2) {
  // Step numbers and names follow Sharma, Wu & Dalal (2005), equations (1)-(22).
  const double c1 = std::hypot(lab1.y(), lab1.z());
  const double c2 = std::hypot(lab2.y(), lab2.z());
  const double c_bar7 = std::pow((c1 + c2) / 2, 7);
  const double g = 0.5 * (1 - std::sqrt(c_bar7 / (c_bar7 + std::pow(25.0, 7))));
  const double a1p = (1 + g) * lab1.y();
  const double a2p = (1 + g) * lab2.y();
  const double c1p = std::hypot(a1p, lab1.z());
  const double c2p = std::hypot(a2p, lab2.z());
  const double h1p = HueDegrees(lab1.z(), a1p);
  const double h2p = HueDegrees(lab2.z(), a2p);

  const double delta_lp = lab2.x() - lab1.x();
  const double delta_cp = c2p - c1p;
  double delta_hp = 0;
  if (c1p * c2p != 0) {
    delta_hp = h2p - h1p;
    if (delta_hp > 180) delta_hp -= 360;
    if (delta_hp < -180) delta_hp += 360;
  }
  const double delta_big_hp = 2 * std::sqrt(c1p * c2p) * std::sin(Radians(delta_hp / 2));

  const double l_barp = (lab1.x() + lab2.x()) / 2;
  const double c_barp = (c1p + c2p) / 2;
  double h_barp = h1p + h2p;
  if (c1p * c2p != 0) {
    if (std::abs(h1p - h2p) <= 180) {
      h_barp = (h1p + h2p) / 2;
    } else {
      h_barp = h1p + h2p < 360 ? (h1p + h2p + 360) / 2 : (h1p + h2p - 360) / 2;
    }
  }
  const double t = 1 - 0.17 * std::cos(Radians(h_barp - 30)) + 0.24 * std::cos(Radians(2 * h_barp)) +
                   0.32 * std::cos(Radians(3 * h_barp + 6)) - 0.20 * std::cos(Radians(4 * h_barp - 63));
  const double delta_theta = 30 * std::exp(-std::pow((h_barp - 275) / 25, 2));
  const double c_barp7 = std::pow(c_barp, 7);
  const double r_c = 2 * std::sqrt(c_barp7 / (c_barp7 + std::pow(25.0, 7)));
  return WeightedDifference(delta_lp, delta_cp, delta_big_hp, l_barp, c_barp, t, delta_theta, r_c);
}

namespace {

// x^7 by three multiplications (std::pow is a library call).
double Pow7(double x) {
  const double x2 = x * x, x4 = x2 * x2;
  return x4 * x2 * x;
}
constexpr double k25To7 = 6103515625.0;  // 25^7, exactly

// The cube root of t, a positive finite double (CIELAB's f(t) above (6/29)^3):
// the exponent bits divided by three give a start within 4 %, and each step of
// Halley's iteration y <- y (y^3 + 2 t) / (2 y^3 + t) about triples the
// correct digits (relative error 4e-2, then about 1e-5, 1e-15, the last step
// at the rounding). About half std::cbrt's time; within 7.4e-16 relative of
// it on a million values of [0.009, 1.5] (43 % bit-equal).
double FastCbrt(double t) {
  constexpr uint64_t kOneBits = 0x3FF0000000000000ull;  // 1.0
  double y = std::bit_cast<double>(std::bit_cast<uint64_t>(t) / 3 + (kOneBits - kOneBits / 3));
  for (int step = 0; step < 3; ++step) {
    const double y3 = y * y * y;
    y *= (y3 + 2 * t) / (2 * y3 + t);
  }
  return y;
}

double FastLabF(double t) {
  constexpr double kDelta = 6.0 / 29.0;
  return t > kDelta * kDelta * kDelta ? FastCbrt(t) : t / (3 * kDelta * kDelta) + 4.0 / 29.0;
}

// Below this chroma (C', of a* b* in [-128, 127]) the hue's unit vector is
// not used: a zero chroma has no hue, and the published formula's convention
// for it (hue 0) is followed by calling it.
constexpr double kFastMinChroma = 1e-9;
// Hues closer than this to 180 deg apart (cos of their difference within this
// of -1, about 0.003 deg) or a mean hue within kFastWrapDegrees of the 0 / 360
// deg wrap: the formula jumps there (the mean hue's branch), so the published
// computation decides the side.
constexpr double kFastOppositeHue = 1e-9;
constexpr double kFastWrapDegrees = 1e-6;

// The cosines and sines of T's offsets (30, 6 and 63 deg).
struct HueAngles {
  double cos30, sin30, cos6, sin6, cos63, sin63;
};
const HueAngles& HueAnglesOfT() {
  static const HueAngles angles{std::cos(Radians(30)), std::sin(Radians(30)), std::cos(Radians(6)),
                                std::sin(Radians(6)),  std::cos(Radians(63)), std::sin(Radians(63))};
  return angles;
}

// XYZ / white of linear Rec.709: (diag(1 / white) * XyzFromLinearRec709).
const Eigen::Matrix3d& WhiteRelativeXyzFromLinearRec709() {
  static const Eigen::Matrix3d m = D65WhiteXyz().cwiseInverse().asDiagonal() * XyzFromLinearRec709();
  return m;
}

}  // namespace

double FastCiede2000(const Eigen::Vector3d& lab1, const Eigen::Vector3d& lab2) {
  const double a1 = lab1.y(), b1 = lab1.z(), a2 = lab2.y(), b2 = lab2.z();
  const double c1 = std::sqrt(a1 * a1 + b1 * b1);
  const double c2 = std::sqrt(a2 * a2 + b2 * b2);
  const double c_bar7 = Pow7((c1 + c2) / 2);
  const double g = 0.5 * (1 - std::sqrt(c_bar7 / (c_bar7 + k25To7)));
  const double a1p = (1 + g) * a1;
  const double a2p = (1 + g) * a2;
  const double c1p = std::sqrt(a1p * a1p + b1 * b1);
  const double c2p = std::sqrt(a2p * a2p + b2 * b2);
  if (!(c1p > kFastMinChroma && c2p > kFastMinChroma)) return Ciede2000(lab1, lab2);
  // Unit hue vectors u = (cos h', sin h').
  const double u1a = a1p / c1p, u1b = b1 / c1p, u2a = a2p / c2p, u2b = b2 / c2p;
  const double cos_dh = u1a * u2a + u1b * u2b;  // cos(h2' - h1')
  if (cos_dh < -1 + kFastOppositeHue) return Ciede2000(lab1, lab2);
  const double sin_dh = u1a * u2b - u1b * u2a;  // sin(h2' - h1')
  // dH' = 2 sqrt(C1' C2') sin(dh' / 2) with dh' in (-180, 180): |u2 - u1| is
  // 2 |sin(dh' / 2)|, and its sign is sin(dh')'s.
  const double du_a = u2a - u1a, du_b = u2b - u1b;
  const double delta_big_hp = std::copysign(std::sqrt(c1p * c2p) * std::sqrt(du_a * du_a + du_b * du_b), sin_dh);
  // The mean hue h' bar lies along u1 + u2 (their difference is under 180 deg),
  // which is also u2 - u1 turned by -90 deg (+90 for a negative dh'): the
  // latter where the hues are over 90 deg apart, where the sum is short and
  // its direction would lose digits.
  const bool far_apart = cos_dh < 0;
  const double turn = std::copysign(1.0, sin_dh);
  const double ma = far_apart ? turn * du_b : u1a + u2a;
  const double mb = far_apart ? -turn * du_a : u1b + u2b;
  double h_barp = Degrees(std::atan2(mb, ma));
  if (h_barp < 0) h_barp += 360;
  if (h_barp < kFastWrapDegrees || h_barp > 360 - kFastWrapDegrees) return Ciede2000(lab1, lab2);
  const double m_norm = std::sqrt(ma * ma + mb * mb);
  // cos and sin of h' bar and of its multiples, for T's four cosines.
  const double cos1 = ma / m_norm, sin1 = mb / m_norm;
  const double cos2 = cos1 * cos1 - sin1 * sin1, sin2 = 2 * sin1 * cos1;
  const double cos3 = cos2 * cos1 - sin2 * sin1, sin3 = sin2 * cos1 + cos2 * sin1;
  const double cos4 = cos2 * cos2 - sin2 * sin2, sin4 = 2 * sin2 * cos2;
  const HueAngles& k = HueAnglesOfT();
  const double t = 1 - 0.17 * (cos1 * k.cos30 + sin1 * k.sin30) + 0.24 * cos2 + 0.32 * (cos3 * k.cos6 - sin3 * k.sin6) -
                   0.20 * (cos4 * k.cos63 + sin4 * k.sin63);

  const double delta_lp = lab2.x() - lab1.x();
  const double delta_cp = c2p - c1p;
  const double l_barp = (lab1.x() + lab2.x()) / 2;
  const double c_barp = (c1p + c2p) / 2;
  const double hue_offset = (h_barp - 275) / 25;
  const double delta_theta = 30 * std::exp(-hue_offset * hue_offset);
  const double c_barp7 = Pow7(c_barp);
  const double r_c = 2 * std::sqrt(c_barp7 / (c_barp7 + k25To7));
  return WeightedDifference(delta_lp, delta_cp, delta_big_hp, l_barp, c_barp, t, delta_theta, r_c);
}

Eigen::Vector3d FastLabFromLinearRec709(const Eigen::Vector3d& rgb_linear_rec709) {
  const Eigen::Vector3d xyz = WhiteRelativeXyzFromLinearRec709() * rgb_linear_rec709;
  const double fx = FastLabF(xyz.x()), fy = FastLabF(xyz.y()), fz = FastLabF(xyz.z());
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

double Ciede2000FromLinearRec709(const Eigen::Vector3d& rgb1_linear_rec709, const Eigen::Vector3d& rgb2_linear_rec709) {
  return FastCiede2000(FastLabFromLinearRec709(rgb1_linear_rec709), FastLabFromLinearRec709(rgb2_linear_rec709));
}

namespace color_kernels {

const ColorKernels& ColorKernelsFor(KernelIsa isa) {
#ifdef SCANBENCH_ISA_VARIANTS
  return KernelsOfIsa(isa, isa_baseline::kKernels, &isa_avx2::kKernels, &isa_avx512::kKernels);
#else
  return KernelsOfIsa<ColorKernels>(isa, isa_baseline::kKernels, nullptr, nullptr);
#endif
}

}  // namespace color_kernels

void Ciede2000FromLinearRec709(const float* rgb1, const float* rgb2, size_t count, double* delta_e) {
  static const color_kernels::Ciede2000Args constants = [] {
    color_kernels::Ciede2000Args args;
    const Eigen::Matrix3d& m = WhiteRelativeXyzFromLinearRec709();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) args.xyz_over_white_from_rgb[3 * r + c] = m(r, c);
    }
    const HueAngles& k = HueAnglesOfT();
    args.cos30 = k.cos30, args.sin30 = k.sin30, args.cos6 = k.cos6, args.sin6 = k.sin6;
    args.cos63 = k.cos63, args.sin63 = k.sin63;
    args.min_chroma = kFastMinChroma, args.opposite_hue = kFastOppositeHue, args.wrap_degrees = kFastWrapDegrees;
    return args;
  }();
  const color_kernels::ColorKernels& kernels = color_kernels::ColorKernelsFor(ActiveKernelIsa());
  // A chunk at a time: the deferral marks on the stack.
  constexpr size_t kChunk = 1024;
  uint8_t defer[kChunk];
  for (size_t first = 0; first < count; first += kChunk) {
    color_kernels::Ciede2000Args args = constants;
    args.count = std::min(kChunk, count - first);
    args.rgb1 = rgb1 + 3 * first;
    args.rgb2 = rgb2 + 3 * first;
    args.delta_e = delta_e + first;
    args.defer = defer;
    kernels.ciede2000_from_linear_rec709(args);
    for (size_t i = 0; i < args.count; ++i) {
      if (defer[i] == 0) continue;
      const float* p1 = args.rgb1 + 3 * i;
      const float* p2 = args.rgb2 + 3 * i;
      args.delta_e[i] =
          Ciede2000FromLinearRec709(Eigen::Vector3d(p1[0], p1[1], p1[2]), Eigen::Vector3d(p2[0], p2[1], p2[2]));
    }
  }
}

double SrgbEncode(double linear) {
  if (!(linear > 0)) return 0;  // also NaN
  if (linear >= 1) return 1;
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
}

namespace {

uint32_t FloatBits(float value) { return std::bit_cast<uint32_t>(value); }
float FloatOfBits(uint32_t bits) { return std::bit_cast<float>(bits); }
constexpr uint32_t kOneBits = 0x3F800000;  // 1.0f; non-negative floats order as their bit patterns

}  // namespace

SrgbQuantizer::SrgbQuantizer(int bits) {
  if (bits < 1 || bits > 16) throw std::invalid_argument("SrgbQuantizer: bits = " + std::to_string(bits) + " must be in [1, 16]");
  max_code_ = (1 << bits) - 1;
  const double scale = max_code_;
  auto code_of = [scale](uint32_t float_bits) {
    return std::lround(SrgbEncode(static_cast<double>(FloatOfBits(float_bits))) * scale);
  };
  lowest_.assign(max_code_ + 1, 0.0f);
  for (int k = 1; k <= max_code_; ++k) {
    uint32_t below = 0, reaches = kOneBits;  // code_of(below) < k <= code_of(reaches)
    while (reaches - below > 1) {
      const uint32_t middle = below + (reaches - below) / 2;
      (code_of(middle) >= k ? reaches : below) = middle;
    }
    lowest_[k] = FloatOfBits(reaches);
  }
  node_.resize((kOneBits >> 16) + 2);
  for (uint32_t i = 0; i < node_.size(); ++i) {
    node_[i] = static_cast<float>(SrgbEncode(static_cast<double>(FloatOfBits(std::min(i << 16, kOneBits)))) * scale);
  }
}

const SrgbQuantizer& SrgbQuantizer::Of(int bits) {
  static const SrgbQuantizer eight(8), sixteen(16);
  if (bits == 8) return eight;
  if (bits == 16) return sixteen;
  throw std::invalid_argument("SrgbQuantizer::Of: bits = " + std::to_string(bits) + " must be 8 or 16");
}

uint16_t SrgbQuantizer::operator()(float linear) const {
  if (!(linear > 0)) return 0;  // also NaN
  if (linear >= 1) return static_cast<uint16_t>(max_code_);
  // Between two nodes the float is linear in its low 16 bits.
  const uint32_t bits = FloatBits(linear);
  const uint32_t node = bits >> 16;
  const float t = static_cast<float>(bits & 0xFFFF) * (1.0f / 65536.0f);
  const float guess = node_[node] + t * (node_[node + 1] - node_[node]);
  int code = std::clamp(static_cast<int>(guess + 0.5f), 0, max_code_);
  while (code < max_code_ && linear >= lowest_[code + 1]) ++code;
  while (code > 0 && linear < lowest_[code]) --code;
  return static_cast<uint16_t>(code);
}

double SrgbDecode(double encoded) {
  if (!(encoded > 0)) return 0;  // also NaN
  if (encoded >= 1) return 1;
  return encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
}

}  // namespace scanbench
