#include "calibration/color_science.h"

#include <algorithm>
#include <bit>
#include <stdexcept>
#include <string>
#include <cmath>
#include <numbers>

#include <Eigen/LU>

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
