// Branch-free scalar maths for the per-ISA kernels (solver/span_kernels_impl.h's
// kind: plain loops that GCC vectorises for each instruction set), shared by
// the kernels that include it. Everything is in an anonymous namespace: each
// per-ISA translation unit gets its own copy, so no inline function compiled
// for AVX2 or AVX-512 becomes a weak symbol the linker could keep for the
// baseline code (see span_kernels_impl.h).
#pragma once

#include <cstdint>

namespace scanbench::kernel_math {
namespace {

// Bit casts between double and its bits: loops of these still vectorise
// (GCC turns the copies into lane reinterpretations).
inline double DoubleFromBits(uint64_t bits) {
  double value;
  __builtin_memcpy(&value, &bits, sizeof value);
  return value;
}
inline uint64_t BitsOf(double value) {
  uint64_t bits;
  __builtin_memcpy(&bits, &value, sizeof bits);
  return bits;
}

// Round to the nearest integer (ties to even) of |x| < 2^51, as a double: the
// 1.5 * 2^52 trick (SSE2 and AVX2 have no vector double-to-int64 conversion).
// The low bits of x + kRoundShift then hold the integer (two's complement).
constexpr double kRoundShift = 6755399441055744.0;

// 2^n for an integer n in [-1022, 1023] given as a double, built in the exponent bits.
inline double Pow2(double n) { return DoubleFromBits((BitsOf(n + kRoundShift) + 1023) << 52); }

// e^y for y <= 0, to about 1e-14 relative, branch-free; y below -700 gives
// e^-700 (1e-304, 0 as a float). y = n ln 2 + r with n rounded by the 1.5 *
// 2^52 trick (round to nearest), |r| <= ln 2 / 2 (ln 2 in two parts, so r is
// exact to 1e-16 for any n), e^r by its Taylor series to r^12 (the rest is
// below 1e-14), 2^n built in the exponent bits.
inline double ExpNonPositive(double y) {
  const double x = y < -700.0 ? -700.0 : y;
  const double shifted = x * 1.4426950408889634 + kRoundShift;
  const double n = shifted - kRoundShift;
  const double r = (x - n * 0.693147180369123816490) - n * 1.90821492927058770002e-10;
  double p = 1.0 / 479001600;
  p = 1.0 / 39916800 + r * p;
  p = 1.0 / 3628800 + r * p;
  p = 1.0 / 362880 + r * p;
  p = 1.0 / 40320 + r * p;
  p = 1.0 / 5040 + r * p;
  p = 1.0 / 720 + r * p;
  p = 1.0 / 120 + r * p;
  p = 1.0 / 24 + r * p;
  p = 1.0 / 6 + r * p;
  p = 0.5 + r * p;
  p = 1.0 + r * p;
  p = 1.0 + r * p;
  // The low bits of `shifted` hold n (two's complement); n + 1023 is in
  // [13, 1023] here, a normal exponent.
  return p * DoubleFromBits((BitsOf(shifted) + 1023) << 52);
}

// ExpNonPositive in float (the network kernels' softmax), to about 2e-7 relative: y = n ln 2 + r, |r| <= ln 2 / 2,
// e^r by its Taylor series to r^7, 2^n built in the exponent bits; y below -87 gives 0.
inline float ExpNonPositiveF(float y) {
  const float x = y < -87.0f ? -87.0f : y;
  const float shift = 12582912.0f;  // 1.5 * 2^23: rounds to an integer in the low mantissa bits
  const float shifted = x * 1.44269504f + shift;
  const float n = shifted - shift;
  const float r = (x - n * 0.693145752f) - n * 1.42860677e-6f;
  float p = 1.0f / 5040;
  p = 1.0f / 720 + r * p;
  p = 1.0f / 120 + r * p;
  p = 1.0f / 24 + r * p;
  p = 1.0f / 6 + r * p;
  p = 0.5f + r * p;
  p = 1.0f + r * p;
  p = 1.0f + r * p;
  int bits_n;
  __builtin_memcpy(&bits_n, &shifted, sizeof bits_n);
  const int exponent_bits = ((bits_n & 0x7FFFFF) - 0x400000 + 127) << 23;  // n + 127 in the exponent
  float scale;
  __builtin_memcpy(&scale, &exponent_bits, sizeof scale);
  return y < -87.0f ? 0.0f : p * scale;
}

// The cube root of t > 0 (normal, finite), to about 5e-16 relative,
// branch-free: t = m 2^e with m in [1, 2); e = 3 q + s with s in {0, 1, 2};
// the root of x = m 2^s in [1, 8) from a quadratic (within 4.7 %) and three
// steps of Halley's iteration y <- y (y^3 + 2 x) / (2 y^3 + x), each of which
// about triples the correct digits; then times 2^q, exactly.
inline double CbrtPositive(double t) {
  const uint64_t bits = BitsOf(t);
  const double e = DoubleFromBits((bits >> 52) | 0x4330000000000000ull) - 4503599627370496.0 - 1023.0;
  const double m = DoubleFromBits((bits & 0x000FFFFFFFFFFFFFull) | 0x3FF0000000000000ull);
  // floor(e / 3) = round((e - 1) / 3) for an integer e.
  const double q = ((e - 1.0) * (1.0 / 3.0) + kRoundShift) - kRoundShift;
  const double s = e - 3.0 * q;
  const double x = m * (s > 1.5 ? 4.0 : s > 0.5 ? 2.0 : 1.0);
  double y = 0.8208312163657436 + x * (0.23742467276200943 + x * -0.011593381976926255);
  // Three steps written out: a loop inside the caller's loop stops the vectoriser.
  double y3 = y * y * y;
  y *= (y3 + 2.0 * x) / (2.0 * y3 + x);
  y3 = y * y * y;
  y *= (y3 + 2.0 * x) / (2.0 * y3 + x);
  y3 = y * y * y;
  y *= (y3 + 2.0 * x) / (2.0 * y3 + x);
  return y * Pow2(q);
}


// atan(t) for t in [0, 1], to about 2e-16, branch-free: above tan(15 deg),
// atan(t) = 30 deg + atan((t sqrt 3 - 1) / (t + sqrt 3)), which brings the
// argument within tan(15 deg) = 0.268, where the series t - t^3 / 3 + ... is
// summed to t^23 (the next term is below 1e-15 of the sum).
inline double AtanUnit(double t) {
  constexpr double kSqrt3 = 1.7320508075688772;
  const bool reduce = t > 0.2679491924311227;
  const double u = reduce ? (t * kSqrt3 - 1.0) / (t + kSqrt3) : t;
  const double u2 = u * u;
  double p = -1.0 / 23;
  p = 1.0 / 21 + u2 * p;
  p = -1.0 / 19 + u2 * p;
  p = 1.0 / 17 + u2 * p;
  p = -1.0 / 15 + u2 * p;
  p = 1.0 / 13 + u2 * p;
  p = -1.0 / 11 + u2 * p;
  p = 1.0 / 9 + u2 * p;
  p = -1.0 / 7 + u2 * p;
  p = 1.0 / 5 + u2 * p;
  p = -1.0 / 3 + u2 * p;
  p = 1.0 + u2 * p;
  return (reduce ? 0.52359877559829887 : 0.0) + u * p;
}

// atan2(y, x) in radians, (-pi, pi], branch-free, to about 4e-16 absolute;
// 0 for (0, 0). Like std::atan2 but for the sign of zero: y = -0 reads as +0.
inline double Atan2(double y, double x) {
  constexpr double kPi = 3.141592653589793;
  const double ax = x < 0 ? -x : x, ay = y < 0 ? -y : y;
  const bool steep = ay > ax;
  const double num = steep ? ax : ay, den = steep ? ay : ax;
  const double a0 = AtanUnit(den > 0 ? num / den : 0.0);
  const double a1 = steep ? 0.5 * kPi - a0 : a0;
  const double a2 = x < 0 ? kPi - a1 : a1;
  return y < 0 ? -a2 : a2;
}

// sin(x) for |x| <= pi / 2 by its Taylor series to x^19 (the rest is below
// 1e-17 there), branch-free.
inline double SinSmall(double x) {
  const double x2 = x * x;
  double p = -1.0 / 121645100408832000.0;
  p = 1.0 / 355687428096000.0 + x2 * p;
  p = -1.0 / 1307674368000.0 + x2 * p;
  p = 1.0 / 6227020800.0 + x2 * p;
  p = -1.0 / 39916800.0 + x2 * p;
  p = 1.0 / 362880.0 + x2 * p;
  p = -1.0 / 5040.0 + x2 * p;
  p = 1.0 / 120.0 + x2 * p;
  p = -1.0 / 6.0 + x2 * p;
  p = 1.0 + x2 * p;
  return x * p;
}

}  // namespace
}  // namespace scanbench::kernel_math
