// The colour kernels' source, compiled once per instruction set: each
// color_kernels_<isa>.cc defines SCANBENCH_ISA_NAMESPACE and
// SCANBENCH_ISA_ENUM and includes this file; calibration/CMakeLists.txt gives
// each its -m flags. Only plain loops and plain data here (no Eigen, no
// library inline function: see solver/span_kernels_impl.h for why).
//
// Why double: CIELAB's a* and b* are 500 and 200 times differences of cube
// roots near 0.5, and CIEDE2000 differences of chromas near 100; float's 6e-8
// would move a value by about 1e-5, the whole of the evaluation's allowance.
// So AVX-512 runs 8 pairs a vector, AVX2 4, the baseline 2.
#include <cstddef>
#include <cstdint>

#include "calibration/color_kernels.h"
#include "solver/kernel_math_impl.h"

#ifndef SCANBENCH_ISA_NAMESPACE
#error "define SCANBENCH_ISA_NAMESPACE and SCANBENCH_ISA_ENUM before including color_kernels_impl.h"
#endif

namespace scanbench::color_kernels::SCANBENCH_ISA_NAMESPACE {
namespace {

using kernel_math::Atan2;
using kernel_math::CbrtPositive;
using kernel_math::ExpNonPositive;
using kernel_math::SinSmall;

// Pairs per block (planar doubles in the first-level cache: 6 x 512 bytes).
constexpr int kBlock = 64;
constexpr double kDegreesPerRadian = 57.295779513082321;
constexpr double kRadiansPerDegree = 0.017453292519943295;
constexpr double k25To7 = 6103515625.0;  // 25^7, exactly

// CIELAB's f(t): the cube root above (6/29)^3, the linear toe below.
inline double LabF(double t) {
  constexpr double kDelta3 = (6.0 / 29.0) * (6.0 / 29.0) * (6.0 / 29.0);
  const double root = CbrtPositive(t > kDelta3 ? t : 1.0);  // the root's input kept normal where unused
  return t > kDelta3 ? root : t * (1.0 / (3 * (6.0 / 29.0) * (6.0 / 29.0))) + 4.0 / 29.0;
}

inline double Pow7(double x) {
  const double x2 = x * x, x4 = x2 * x2;
  return x4 * x2 * x;
}

// One block: rgb (planar, [c * kBlock + i], first colour then second) to
// delta E and the deferral marks. Selects only, no branches: GCC vectorises
// the loop whole.
inline void Ciede2000Block(int n, const Ciede2000Args& a, const double* __restrict rgb, double* __restrict out,
                           uint8_t* __restrict defer) {
  const double m00 = a.xyz_over_white_from_rgb[0], m01 = a.xyz_over_white_from_rgb[1],
               m02 = a.xyz_over_white_from_rgb[2], m10 = a.xyz_over_white_from_rgb[3],
               m11 = a.xyz_over_white_from_rgb[4], m12 = a.xyz_over_white_from_rgb[5],
               m20 = a.xyz_over_white_from_rgb[6], m21 = a.xyz_over_white_from_rgb[7],
               m22 = a.xyz_over_white_from_rgb[8];
  const double cos30 = a.cos30, sin30 = a.sin30, cos6 = a.cos6, sin6 = a.sin6, cos63 = a.cos63, sin63 = a.sin63;
  const double min_chroma = a.min_chroma, opposite = -1.0 + a.opposite_hue;
  const double wrap_low = a.wrap_degrees, wrap_high = 360.0 - a.wrap_degrees;
  const double* __restrict r1 = rgb;
  const double* __restrict g1 = rgb + kBlock;
  const double* __restrict b1 = rgb + 2 * kBlock;
  const double* __restrict r2 = rgb + 3 * kBlock;
  const double* __restrict g2 = rgb + 4 * kBlock;
  const double* __restrict b2 = rgb + 5 * kBlock;
#pragma GCC unroll 1
  for (int i = 0; i < n; ++i) {
    // L*a*b* of both colours.
    const double x1 = m00 * r1[i] + m01 * g1[i] + m02 * b1[i];
    const double y1 = m10 * r1[i] + m11 * g1[i] + m12 * b1[i];
    const double z1 = m20 * r1[i] + m21 * g1[i] + m22 * b1[i];
    const double x2 = m00 * r2[i] + m01 * g2[i] + m02 * b2[i];
    const double y2 = m10 * r2[i] + m11 * g2[i] + m12 * b2[i];
    const double z2 = m20 * r2[i] + m21 * g2[i] + m22 * b2[i];
    // Not finite (or absurdly large): the scalar form decides what it gives.
    const bool finite = (__builtin_fabs(x1) < 1e30) & (__builtin_fabs(y1) < 1e30) & (__builtin_fabs(z1) < 1e30) &
                        (__builtin_fabs(x2) < 1e30) & (__builtin_fabs(y2) < 1e30) & (__builtin_fabs(z2) < 1e30);
    const double fx1 = LabF(x1), fy1 = LabF(y1), fz1 = LabF(z1);
    const double fx2 = LabF(x2), fy2 = LabF(y2), fz2 = LabF(z2);
    const double l1 = 116.0 * fy1 - 16.0, la1 = 500.0 * (fx1 - fy1), lb1 = 200.0 * (fy1 - fz1);
    const double l2 = 116.0 * fy2 - 16.0, la2 = 500.0 * (fx2 - fy2), lb2 = 200.0 * (fy2 - fz2);
    // FastCiede2000 (color_science.cc), step by step.
    const double c1 = __builtin_sqrt(la1 * la1 + lb1 * lb1);
    const double c2 = __builtin_sqrt(la2 * la2 + lb2 * lb2);
    const double c_bar7 = Pow7((c1 + c2) * 0.5);
    const double g = 0.5 * (1.0 - __builtin_sqrt(c_bar7 / (c_bar7 + k25To7)));
    const double a1p = (1.0 + g) * la1;
    const double a2p = (1.0 + g) * la2;
    const double c1p = __builtin_sqrt(a1p * a1p + lb1 * lb1);
    const double c2p = __builtin_sqrt(a2p * a2p + lb2 * lb2);
    const bool chroma = (c1p > min_chroma) & (c2p > min_chroma);
    // Unit hue vectors (kept finite where the chroma is 0: deferred anyway).
    const double inv1 = 1.0 / (chroma ? c1p : 1.0), inv2 = 1.0 / (chroma ? c2p : 1.0);
    const double u1a = a1p * inv1, u1b = lb1 * inv1, u2a = a2p * inv2, u2b = lb2 * inv2;
    const double cos_dh = u1a * u2a + u1b * u2b;
    const double sin_dh = u1a * u2b - u1b * u2a;
    const double du_a = u2a - u1a, du_b = u2b - u1b;
    const double big_hp = __builtin_sqrt(c1p * c2p) * __builtin_sqrt(du_a * du_a + du_b * du_b);
    const double delta_big_hp = sin_dh < 0 ? -big_hp : big_hp;
    const bool far_apart = cos_dh < 0;
    const double turn = sin_dh < 0 ? -1.0 : 1.0;
    const double ma = far_apart ? turn * du_b : u1a + u2a;
    const double mb = far_apart ? -turn * du_a : u1b + u2b;
    const double h_rad = Atan2(mb, ma);
    const double h_barp = h_rad < 0 ? h_rad * kDegreesPerRadian + 360.0 : h_rad * kDegreesPerRadian;
    const double m_norm2 = ma * ma + mb * mb;
    const double inv_m = 1.0 / __builtin_sqrt(m_norm2 > 0 ? m_norm2 : 1.0);
    const double cosh1 = ma * inv_m, sinh1 = mb * inv_m;
    const double cosh2 = cosh1 * cosh1 - sinh1 * sinh1, sinh2 = 2.0 * sinh1 * cosh1;
    const double cosh3 = cosh2 * cosh1 - sinh2 * sinh1, sinh3 = sinh2 * cosh1 + cosh2 * sinh1;
    const double cosh4 = cosh2 * cosh2 - sinh2 * sinh2, sinh4 = 2.0 * sinh2 * cosh2;
    const double t = 1.0 - 0.17 * (cosh1 * cos30 + sinh1 * sin30) + 0.24 * cosh2 +
                     0.32 * (cosh3 * cos6 - sinh3 * sin6) - 0.20 * (cosh4 * cos63 + sinh4 * sin63);
    const double delta_lp = l2 - l1;
    const double delta_cp = c2p - c1p;
    const double l_barp = (l1 + l2) * 0.5;
    const double c_barp = (c1p + c2p) * 0.5;
    const double hue_offset = (h_barp - 275.0) * (1.0 / 25.0);
    const double delta_theta = 30.0 * ExpNonPositive(-hue_offset * hue_offset);
    const double c_barp7 = Pow7(c_barp);
    const double r_c = 2.0 * __builtin_sqrt(c_barp7 / (c_barp7 + k25To7));
    // WeightedDifference.
    const double l50 = (l_barp - 50.0) * (l_barp - 50.0);
    const double s_l = 1.0 + 0.015 * l50 / __builtin_sqrt(20.0 + l50);
    const double s_c = 1.0 + 0.045 * c_barp;
    const double s_h = 1.0 + 0.015 * c_barp * t;
    const double r_t = -SinSmall(2.0 * delta_theta * kRadiansPerDegree) * r_c;
    const double dl = delta_lp / s_l;
    const double dc = delta_cp / s_c;
    const double dh = delta_big_hp / s_h;
    const double sum = dl * dl + dc * dc + dh * dh + r_t * dc * dh;
    out[i] = __builtin_sqrt(sum > 0 ? sum : 0.0);
    const bool deferred =
        !finite | !chroma | (cos_dh < opposite) | (h_barp < wrap_low) | (h_barp > wrap_high);
    defer[i] = deferred ? 1 : 0;
  }
}

void Ciede2000FromLinearRec709(const Ciede2000Args& a) {
  alignas(64) double rgb[6 * kBlock];
  for (size_t first = 0; first < a.count; first += kBlock) {
    const int n = a.count - first < kBlock ? static_cast<int>(a.count - first) : kBlock;
    const float* __restrict p1 = a.rgb1 + 3 * first;
    const float* __restrict p2 = a.rgb2 + 3 * first;
    for (int i = 0; i < n; ++i) {
      rgb[i] = p1[3 * i];
      rgb[kBlock + i] = p1[3 * i + 1];
      rgb[2 * kBlock + i] = p1[3 * i + 2];
      rgb[3 * kBlock + i] = p2[3 * i];
      rgb[4 * kBlock + i] = p2[3 * i + 1];
      rgb[5 * kBlock + i] = p2[3 * i + 2];
    }
    Ciede2000Block(n, a, rgb, a.delta_e + first, a.defer + first);
  }
}

}  // namespace

const ColorKernels kKernels{SCANBENCH_ISA_ENUM, &Ciede2000FromLinearRec709};

}  // namespace scanbench::color_kernels::SCANBENCH_ISA_NAMESPACE
