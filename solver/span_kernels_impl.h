// The span kernels' source, compiled once per instruction set: each
// span_kernels_<isa>.cc defines SCANBENCH_ISA_NAMESPACE and SCANBENCH_ISA_ENUM
// and includes this file; solver/CMakeLists.txt gives each its -m flags.
//
// Only plain loops and the plain data of span_kernels.h here: an inline
// library function (std::max, an Eigen or std::vector member) instantiated in
// an AVX2 translation unit is a weak symbol that the linker may keep for the
// whole program, and would then run AVX2 code on a CPU without it.
//
// Why float: a span's sums run over the lights of one pixel (10 to a few
// dozen products of unit directions and O(1) samples), where float's 6e-8
// relative rounding moves the normal by 2e-6 deg on average (at most 5e-5)
// from double sums (docs/solver.md, "Kernels and CPU dispatch"), and float
// doubles the lanes of every vector. The sums are widened to double for the
// 3x3 solves.
#include <cstddef>
#include <cstdint>

#include "solver/kernel_math_impl.h"
#include "solver/span_kernels.h"

#ifndef SCANBENCH_ISA_NAMESPACE
#error "define SCANBENCH_ISA_NAMESPACE and SCANBENCH_ISA_ENUM before including span_kernels_impl.h"
#endif

namespace scanbench::tiled::SCANBENCH_ISA_NAMESPACE {
namespace {

// Pixels summed together (in the first-level cache): a whole number of
// vectors of the byte-wide sample marks for every ISA (64 per AVX-512
// register), or the vectoriser gives up on the loop.
constexpr int kBlock = 64;

using kernel_math::BitsOf;
using kernel_math::DoubleFromBits;
using kernel_math::ExpNonPositive;

// Per-light constants of the hot loop.
struct LightConstants {
  float w0, w1, w2, threshold;  // luminance weights, shadow level
  float ud0, ud1, ud2;          // uniform tile: light direction
  float ui0, ui1, ui2;          // uniform tile: 1 / intensity per channel
  float ui_even, ui_odd;        // uniform tile, Bayer: 1 / intensity of even / odd columns
};

// The per-pixel work of one light over a block: divide the samples by the
// light, decide whether they are usable and add them to the block's sums
// (`sum`, row r at r * kBlock). A function of restrict-qualified parameters
// with selects only, no branches, so that the compiler proves the arrays
// independent and vectorises.
template <bool kUniform, bool kBayer, bool kAlbedo>
inline void AccumulateLight(int n, const LightConstants c, const float* __restrict px,
                            const uint8_t* __restrict mark, const float* __restrict dx, const float* __restrict dy,
                            const float* __restrict dz, const float* __restrict v0, const float* __restrict v1,
                            const float* __restrict v2, const float* __restrict v_even,
                            const float* __restrict v_odd, float* __restrict lum_out, float* __restrict ok_out,
                            float* __restrict red_out, float* __restrict green_out, float* __restrict blue_out,
                            float* __restrict sum, float* __restrict clip) {
  // Not unrolled before the vectoriser sees it (GCC would turn a block's
  // iterations into straight-line scalar code).
#pragma GCC unroll 1
  for (int i = 0; i < n; ++i) {
    const float d0 = kUniform ? c.ud0 : dx[i];
    const float d1 = kUniform ? c.ud1 : dy[i];
    const float d2 = kUniform ? c.ud2 : dz[i];
    float raw, divided, r = 0, g = 0, b = 0, usable;
    if constexpr (kBayer) {
      const float sample = px[i];
      const float odd = static_cast<float>(i & 1);  // blocks start at even columns
      const float inverse = kUniform ? c.ui_even + odd * (c.ui_odd - c.ui_even) : v_even[i] + odd * (v_odd[i] - v_even[i]);
      raw = sample;
      divided = sample * inverse;
      usable = (sample - sample == 0.0f && inverse > 0.0f) ? 1.0f : 0.0f;
    } else {
      const float s0 = px[3 * i], s1 = px[3 * i + 1], s2 = px[3 * i + 2];
      const float i0v = kUniform ? c.ui0 : v0[i];
      const float i1v = kUniform ? c.ui1 : v1[i];
      const float i2v = kUniform ? c.ui2 : v2[i];
      r = s0 * i0v;
      g = s1 * i1v;
      b = s2 * i2v;
      raw = c.w0 * s0 + c.w1 * s1 + c.w2 * s2;
      divided = c.w0 * r + c.w1 * g + c.w2 * b;
      usable = (raw - raw == 0.0f && i0v > 0.0f && i1v > 0.0f && i2v > 0.0f) ? 1.0f : 0.0f;
    }
    const float marked_valid = mark[i] != 0 ? 1.0f : 0.0f;
    const float unmarked = 1.0f - marked_valid;
    clip[i] = clip[i] > unmarked ? clip[i] : unmarked;
    const float weight = raw > c.threshold ? usable * marked_valid : 0.0f;
    const float lum_used = weight > 0.0f ? divided : 0.0f;
    const float wd0 = weight * d0, wd1 = weight * d1, wd2 = weight * d2;
    sum[kG00 * kBlock + i] += wd0 * d0;
    sum[kG01 * kBlock + i] += wd0 * d1;
    sum[kG02 * kBlock + i] += wd0 * d2;
    sum[kG11 * kBlock + i] += wd1 * d1;
    sum[kG12 * kBlock + i] += wd1 * d2;
    sum[kG22 * kBlock + i] += wd2 * d2;
    sum[kB0 * kBlock + i] += d0 * lum_used;
    sum[kB1 * kBlock + i] += d1 * lum_used;
    sum[kB2 * kBlock + i] += d2 * lum_used;
    sum[kCount * kBlock + i] += weight;
    lum_out[i] = lum_used;
    ok_out[i] = weight;
    if constexpr (kAlbedo) {
      const float r_used = weight > 0.0f ? r : 0.0f, g_used = weight > 0.0f ? g : 0.0f;
      const float b_used = weight > 0.0f ? b : 0.0f;
      red_out[i] = r_used;
      green_out[i] = g_used;
      blue_out[i] = b_used;
      sum[kR0 * kBlock + i] += d0 * r_used;
      sum[kR1 * kBlock + i] += d1 * r_used;
      sum[kR2 * kBlock + i] += d2 * r_used;
      sum[kGr0 * kBlock + i] += d0 * g_used;
      sum[kGr1 * kBlock + i] += d1 * g_used;
      sum[kGr2 * kBlock + i] += d2 * g_used;
      sum[kBl0 * kBlock + i] += d0 * b_used;
      sum[kBl1 * kBlock + i] += d1 * b_used;
      sum[kBl2 * kBlock + i] += d2 * b_used;
    }
  }
}

// The next row's samples (and marks) of a block: a light's row is a short
// run in memory, too short for the hardware prefetcher. Asked for one light
// and block at a time, between the sums, so that the requests spread over
// the row's work instead of queueing up at its start.
template <bool kBayer>
inline void PrefetchBlock(const float* next_pixels, const uint8_t* next_marks, int i0, int n) {
  const char* first = reinterpret_cast<const char*>(next_pixels + (kBayer ? i0 : 3 * i0));
  const ptrdiff_t bytes = static_cast<ptrdiff_t>(n) * (kBayer ? 1 : 3) * static_cast<ptrdiff_t>(sizeof(float));
  for (ptrdiff_t offset = 0; offset < bytes; offset += 64) __builtin_prefetch(first + offset);
  __builtin_prefetch(first + bytes - 1);  // the last line, where the block does not start on one
  __builtin_prefetch(next_marks + i0);
  __builtin_prefetch(next_marks + i0 + n - 1);
}

// All lights over the block of pixels [i0, i0 + n), then the sums widened
// into acc.
template <bool kUniform, bool kBayer, bool kAlbedo, bool kFull>
inline void AccumulateBlock(const AccumulateArgs& a, int i0, int tail) {
  const int n = kFull ? kBlock : tail;
  const ptrdiff_t cap = a.capacity;
  float sum[kNumAcc * kBlock];
  float clip[kBlock];
  for (int j = 0; j < kNumAcc * kBlock; ++j) sum[j] = 0.0f;
  for (int i = 0; i < kBlock; ++i) clip[i] = 0.0f;
  LightConstants c{};
  c.w0 = a.w0, c.w1 = a.w1, c.w2 = a.w2, c.threshold = a.threshold;
  for (int k = 0; k < a.num_lights; ++k) {
    const ptrdiff_t plane = 3 * k * cap + i0;
    const float* sd = a.shared_dir + 3 * k;
    const float* si = a.shared_inv + 3 * k;
    c.ud0 = sd[0], c.ud1 = sd[1], c.ud2 = sd[2];
    c.ui0 = si[0], c.ui1 = si[1], c.ui2 = si[2];
    c.ui_even = si[a.even_channel], c.ui_odd = si[a.odd_channel];
    const float* dir = a.dir + plane;
    const float* inv = a.inv + plane;
    float* rgb = a.rgb + plane;
    if (a.next_pixels != nullptr) PrefetchBlock<kBayer>(a.next_pixels[k], a.next_marks[k], i0, n);
    AccumulateLight<kUniform, kBayer, kAlbedo>(
        n, c, a.pixels[k] + (kBayer ? i0 : 3 * i0), a.marks[k] + i0, dir, dir + cap, dir + 2 * cap, inv,
        inv + cap, inv + 2 * cap, inv + a.even_channel * cap, inv + a.odd_channel * cap, a.lum + k * cap + i0,
        a.ok + k * cap + i0, rgb, rgb + cap, rgb + 2 * cap, sum, clip);
  }
  for (int r = 0; r < kNumAcc; ++r) {
    double* __restrict out = a.acc + r * cap + i0;
    for (int i = 0; i < n; ++i) out[i] = static_cast<double>(sum[r * kBlock + i]);
  }
  for (int i = 0; i < n; ++i) a.clipped[i0 + i] = clip[i];
}

template <bool kUniform, bool kBayer, bool kAlbedo>
void AccumulateAll(const AccumulateArgs& a) {
  int i0 = 0;
  for (; i0 + kBlock <= a.count; i0 += kBlock) AccumulateBlock<kUniform, kBayer, kAlbedo, true>(a, i0, kBlock);
  // The tail takes the same arithmetic per pixel: its results equal a full block's.
  if (i0 < a.count) AccumulateBlock<kUniform, kBayer, kAlbedo, false>(a, i0, a.count - i0);
}

void Accumulate(const AccumulateArgs& a) {
  // Bayer pixels carry one channel: no RGB albedo sums there.
  if (a.bayer) {
    a.uniform ? AccumulateAll<true, true, false>(a) : AccumulateAll<false, true, false>(a);
  } else if (a.albedo) {
    a.uniform ? AccumulateAll<true, false, true>(a) : AccumulateAll<false, false, true>(a);
  } else {
    a.uniform ? AccumulateAll<true, false, false>(a) : AccumulateAll<false, false, false>(a);
  }
}

inline void RmsResiduals(int count, const double* __restrict residual2, const double* __restrict used,
                         const double* __restrict albedo, double* __restrict rms) {
  for (int i = 0; i < count; ++i) {
    const double lights = used[i] > 1.0 ? used[i] : 1.0;
    const double value = __builtin_sqrt(residual2[i] / lights) / albedo[i];
    rms[i] = albedo[i] > 0 ? value : 0.0;
  }
}

// Exact, no cancellation: the samples are read again rather than expanding
// the squared residual in the accumulated sums.
void Residuals(const ResidualArgs& a) {
  const ptrdiff_t cap = a.capacity;
  const int count = a.count;
  double* __restrict residual2 = a.residual2;
  const double* __restrict s0 = a.scaled;
  const double* __restrict s1 = a.scaled + cap;
  const double* __restrict s2 = a.scaled + 2 * cap;
  for (int i = 0; i < count; ++i) residual2[i] = 0.0;
  for (int k = 0; k < a.num_lights; ++k) {
    const float* __restrict lum = a.lum + k * cap;
    const float* __restrict ok = a.ok + k * cap;
    if (a.uniform) {
      const double ud0 = a.shared_dir[3 * k], ud1 = a.shared_dir[3 * k + 1], ud2 = a.shared_dir[3 * k + 2];
      for (int i = 0; i < count; ++i) {
        const double r = ud0 * s0[i] + ud1 * s1[i] + ud2 * s2[i] - lum[i];
        residual2[i] += ok[i] * (r * r);
      }
    } else {
      const float* __restrict dx = a.dir + 3 * k * cap;
      const float* __restrict dy = dx + cap;
      const float* __restrict dz = dx + 2 * cap;
      for (int i = 0; i < count; ++i) {
        const double r = dx[i] * s0[i] + dy[i] * s1[i] + dz[i] * s2[i] - lum[i];
        residual2[i] += ok[i] * (r * r);
      }
    }
  }
  RmsResiduals(count, residual2, a.used, a.albedo, a.rms);
}

// The per-pixel body of Solve, over n pixels: restrict-qualified plain
// arrays and selects only, so that it vectorises. The inverse is formed as
// NormalEquationsSolve::InvertGram did (cofactors over the determinant).
template <bool kInvert, bool kAlbedo>
inline void SolvePixels(int n, ptrdiff_t cap, const SolveArgs& a, const double* __restrict acc,
                        const double* __restrict given, const double* __restrict ready, double* __restrict status,
                        double* __restrict s0, double* __restrict s1, double* __restrict s2, double* __restrict n0,
                        double* __restrict n1, double* __restrict n2, double* __restrict length_out,
                        double* __restrict a0, double* __restrict a1, double* __restrict a2) {
  const double min_albedo = a.min_albedo;
  double shared[6] = {0, 0, 0, 0, 0, 0};
  if (!kInvert) {
    for (int e = 0; e < 6; ++e) shared[e] = a.shared_inverse[e];
  }
  const double solved = a.solved, no_signal = a.no_signal, facing_away = a.facing_away;
  // Every array is a separate buffer (the restrict qualifiers say so, but GCC
  // 12 still counts alias checks between the planes of one buffer).
#pragma GCC ivdep
#pragma GCC unroll 1
  for (int i = 0; i < n; ++i) {
    double m00, m01, m02, m11, m12, m22;
    if constexpr (kInvert) {
      const double g00 = acc[kG00 * cap + i], g01 = acc[kG01 * cap + i], g02 = acc[kG02 * cap + i];
      const double g11 = acc[kG11 * cap + i], g12 = acc[kG12 * cap + i], g22 = acc[kG22 * cap + i];
      const double c00 = g11 * g22 - g12 * g12, c01 = g02 * g12 - g01 * g22, c02 = g01 * g12 - g02 * g11;
      const double c11 = g00 * g22 - g02 * g02, c12 = g01 * g02 - g00 * g12, c22 = g00 * g11 - g01 * g01;
      const double det = g00 * c00 + g01 * c01 + g02 * c02;
      const double inv_det = 1.0 / det;
      m00 = c00 * inv_det, m01 = c01 * inv_det, m02 = c02 * inv_det;
      m11 = c11 * inv_det, m12 = c12 * inv_det, m22 = c22 * inv_det;
    } else {
      const bool own = ready[i] > 1.5;
      m00 = own ? given[0 * cap + i] : shared[0], m01 = own ? given[1 * cap + i] : shared[1];
      m02 = own ? given[2 * cap + i] : shared[2], m11 = own ? given[3 * cap + i] : shared[3];
      m12 = own ? given[4 * cap + i] : shared[4], m22 = own ? given[5 * cap + i] : shared[5];
    }
    const double b0 = acc[kB0 * cap + i], b1 = acc[kB1 * cap + i], b2 = acc[kB2 * cap + i];
    const double x = m00 * b0 + m01 * b1 + m02 * b2;
    const double y = m01 * b0 + m11 * b1 + m12 * b2;
    const double z = m02 * b0 + m12 * b1 + m22 * b2;
    const double length = __builtin_sqrt(x * x + y * y + z * z);
    // NaN and infinity fail the first test (length - length is NaN). Bitwise
    // &: a short-circuit would be a branch.
    const bool signal = (length - length == 0) & (length >= min_albedo) & (length != 0);
    const bool up = z > 0;
    const bool is_ready = ready[i] != 0;
    const bool ok = is_ready & signal & up;
    const double code = signal ? (up ? solved : facing_away) : no_signal;
    status[i] = is_ready ? code : -1.0;
    const double inv_length = 1.0 / length;
    s0[i] = ok ? x : 0.0, s1[i] = ok ? y : 0.0, s2[i] = ok ? z : 0.0;
    n0[i] = ok ? x * inv_length : 0.0, n1[i] = ok ? y * inv_length : 0.0, n2[i] = ok ? z * inv_length : 1.0;
    length_out[i] = ok ? length : 0.0;
    if constexpr (kAlbedo) {
      double channel[3];
      for (int c = 0; c < 3; ++c) {
        const double r0 = acc[(kR0 + 3 * c) * cap + i], r1 = acc[(kR0 + 3 * c + 1) * cap + i];
        const double r2 = acc[(kR0 + 3 * c + 2) * cap + i];
        const double cx = m00 * r0 + m01 * r1 + m02 * r2;
        const double cy = m01 * r0 + m11 * r1 + m12 * r2;
        const double cz = m02 * r0 + m12 * r1 + m22 * r2;
        channel[c] = __builtin_sqrt(cx * cx + cy * cy + cz * cz);
      }
      a0[i] = ok ? channel[0] : 0.0, a1[i] = ok ? channel[1] : 0.0, a2[i] = ok ? channel[2] : 0.0;
    }
  }
}

template <bool kInvert, bool kAlbedo>
void SolveAll(const SolveArgs& a) {
  const ptrdiff_t cap = a.capacity;
  SolvePixels<kInvert, kAlbedo>(a.count, cap, a, a.acc, a.inverse, a.ready, a.status, a.scaled, a.scaled + cap,
                                a.scaled + 2 * cap, a.normal, a.normal + cap, a.normal + 2 * cap,
                                a.luminance_albedo, a.rgb_albedo, a.rgb_albedo + cap, a.rgb_albedo + 2 * cap);
}

void Solve(const SolveArgs& a) {
  if (a.invert_gram) {
    a.albedo ? SolveAll<true, true>(a) : SolveAll<true, false>(a);
  } else {
    a.albedo ? SolveAll<false, true>(a) : SolveAll<false, false>(a);
  }
}

// ConditionNumberFromGram's first route, per pixel (see ConditionArgs): the
// same expressions in the same order; a lane stops where the scalar loop
// would return.
inline void ConditionPixels(int n, ptrdiff_t cap, const double* __restrict acc, double* __restrict condition_out,
                            double* __restrict fallback_out) {
  constexpr double kTolerance = 1e-9;
  constexpr double kInfinity = __builtin_inf();
  // Flags are doubles (1 or 0) combined by products: GCC 12 vectorises no
  // select or logical operation between comparisons' results here.
#pragma GCC ivdep
#pragma GCC unroll 1
  for (int i = 0; i < n; ++i) {
    const double g00 = acc[kG00 * cap + i], g01 = acc[kG01 * cap + i], g02 = acc[kG02 * cap + i];
    const double g11 = acc[kG11 * cap + i], g12 = acc[kG12 * cap + i], g22 = acc[kG22 * cap + i];
    const double trace = g00 + g11 + g22;
    const double minors = g00 * g11 + g00 * g22 + g11 * g22 - g01 * g01 - g02 * g02 - g12 * g12;
    const double det =
        g00 * (g11 * g22 - g12 * g12) - g01 * (g01 * g22 - g12 * g02) + g02 * (g01 * g12 - g11 * g02);
    const double scale = trace * trace * trace;
    const double regular = (trace > 0 ? 1.0 : 0.0) * (det - det == 0 ? 1.0 : 0.0) * (det > 1e-30 * scale ? 1.0 : 0.0);
    const double a01 = __builtin_fabs(g01), a02 = __builtin_fabs(g02), a12 = __builtin_fabs(g12);
    const double r0 = g00 + a01 + a02, r1 = a01 + g11 + a12, r2 = a02 + a12 + g22;
    const double r01 = r0 < r1 ? r1 : r0;
    const double gershgorin = r01 < r2 ? r2 : r01;
    double t = gershgorin < trace ? gershgorin : trace;
    double active = 1.0, converged = 0.0;
#pragma GCC unroll 8
    for (int iteration = 0; iteration < 8; ++iteration) {
      const double d = (3 * t - 2 * trace) * t + minors;
      const double go = active * (d != 0 ? 1.0 : 0.0) * (d - d == 0 ? 1.0 : 0.0);
      const double step = (((t - trace) * t + minors) * t - det) / d;
      const double next = t - step;
      const double settled = __builtin_fabs(step) > kTolerance * __builtin_fabs(next) ? 0.0 : 1.0;
      t = go != 0 ? next : t;
      converged = converged + go * settled;
      active = go * (1.0 - settled);
    }
    const double lambda_max = t;
    // The other two roots: sum trace - r, product det / r.
    const double sum = trace - lambda_max, product = det / lambda_max;
    const double discriminant = sum * sum - 4 * product;
    const double root = __builtin_sqrt(discriminant > 0.0 ? discriminant : 0.0);
    const double high = 0.5 * (sum + root);
    const double lambda_min = high > 0 ? product / high : 0.0;
    const double good = (lambda_min > 1e-15 * lambda_max ? 1.0 : 0.0) * (lambda_max - lambda_max == 0 ? 1.0 : 0.0);
    const double value = good != 0 ? __builtin_sqrt(lambda_max / lambda_min) : kInfinity;
    const double settled_here = converged * (lambda_max > 0 ? 1.0 : 0.0);
    condition_out[i] = regular != 0 ? value : kInfinity;
    fallback_out[i] = regular != 0 ? 1.0 - settled_here : 0.0;
  }
}

void Conditions(const ConditionArgs& a) { ConditionPixels(a.count, a.capacity, a.acc, a.condition, a.fallback); }

// Probe's rules per light and pixel (LightRulesArgs), branch-free. A float
// x is finite where x - x == 0.
inline void LightRulesOfLight(int n, const LightRulesArgs& a, const float* __restrict d0, const float* __restrict d1,
                              const float* __restrict d2, float* __restrict v0, float* __restrict v1,
                              float* __restrict v2, uint8_t* __restrict bad) {
  const double w0 = a.w0, w1 = a.w1, w2 = a.w2, min_intensity = a.min_intensity;
  const bool bayer = a.bayer;
#pragma GCC unroll 1
  for (int i = 0; i < n; ++i) {
    const float in0 = v0[i], in1 = v1[i], in2 = v2[i];
    const bool finite = (d0[i] - d0[i] == 0.0f) & (d1[i] - d1[i] == 0.0f) & (d2[i] - d2[i] == 0.0f) &
                        (in0 - in0 == 0.0f) & (in1 - in1 == 0.0f) & (in2 - in2 == 0.0f);
    const double luminance_intensity = w0 * in0 + w1 * in1 + w2 * in2;
    const bool rgb_usable = (luminance_intensity >= min_intensity) & (in0 > 0.0f) & (in1 > 0.0f) & (in2 > 0.0f);
    const bool usable = finite & (bayer | rgb_usable);
    v0[i] = usable & (in0 > 0.0f) & (in0 >= min_intensity) ? 1.0f / in0 : 0.0f;
    v1[i] = usable & (in1 > 0.0f) & (in1 >= min_intensity) ? 1.0f / in1 : 0.0f;
    v2[i] = usable & (in2 > 0.0f) & (in2 >= min_intensity) ? 1.0f / in2 : 0.0f;
    bad[i] = finite ? bad[i] : uint8_t{1};
  }
}

void LightRules(const LightRulesArgs& a) {
  const ptrdiff_t stride = a.stride;
  for (int k = 0; k < a.num_lights; ++k) {
    const float* d = a.dirs + 3 * k * stride;
    float* v = a.inv + 3 * k * stride;
    LightRulesOfLight(a.count, a, d, d + stride, d + 2 * stride, v, v + stride, v + 2 * stride, a.bad);
  }
}

// ln c for c > 0 finite (normal), to about 1e-15 relative, branch-free: c =
// m 2^e with m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh(z), z = (m - 1) /
// (m + 1), |z| <= 0.172, summed to z^17 (the next term is below 1e-14 of the
// sum). The exponent becomes a double through the 2^52 trick, since SSE2 and
// AVX2 have no vector int64-to-double conversion.
inline double LnPositive(double c) {
  const uint64_t bits = BitsOf(c);
  const double biased_exponent = DoubleFromBits((bits >> 52) | 0x4330000000000000ull) - 4503599627370496.0;
  const double m1 = DoubleFromBits((bits & 0x000FFFFFFFFFFFFFull) | 0x3FF0000000000000ull);  // [1, 2)
  const bool high = m1 > 1.4142135623730951;
  const double m = high ? 0.5 * m1 : m1;
  const double exponent = biased_exponent - 1023.0 + (high ? 1.0 : 0.0);
  const double z = (m - 1) / (m + 1), z2 = z * z;
  double series = 1.0 / 17;
  series = 1.0 / 15 + z2 * series;
  series = 1.0 / 13 + z2 * series;
  series = 1.0 / 11 + z2 * series;
  series = 1.0 / 9 + z2 * series;
  series = 1.0 / 7 + z2 * series;
  series = 1.0 / 5 + z2 * series;
  series = 1.0 / 3 + z2 * series;
  series = 1.0 + z2 * series;
  return 2 * z * series + exponent * 0.69314718055994531;
}

// One LED over the span, in double (the surface points are hundreds of mm
// from the LEDs, the directions are differences of those), rounded to float
// at the end. Branch-free, restrict-qualified parameters: the compiler
// vectorises it.
inline void PointLight(int count, const double* light, const double* __restrict sx, const double* __restrict sy,
                       const double* __restrict sz, float* __restrict dx,
                       float* __restrict dy, float* __restrict dz, float* __restrict ir, float* __restrict ig,
                       float* __restrict ib) {
  const double px = light[kLightX], py = light[kLightY], pz = light[kLightZ];
  const double ax = light[kAxisX], ay = light[kAxisY], az = light[kAxisZ];
  const double mu = light[kMu], reference2 = light[kReference2];
  const double red = light[kRed], green = light[kGreen], blue = light[kBlue];
  // pow(0, mu) is 1 for mu = 0 and 0 above (and exp(0 ln c) is exactly 1
  // elsewhere). Chosen here: a select on mu inside the loop stops GCC 12's
  // vectoriser.
  const double at_zero = mu == 0 ? 1.0 : 0.0;
#pragma GCC unroll 1
  for (int i = 0; i < count; ++i) {
    const double tx = px - sx[i], ty = py - sy[i], tz = pz - sz[i];
    const double distance2 = tx * tx + ty * ty + tz * tz;
    // One division per light and pixel (and one in the ln): the direction
    // and the inverse square from 1 / distance.
    const double inv_distance = 1.0 / __builtin_sqrt(distance2);
    const double lx = tx * inv_distance, ly = ty * inv_distance, lz = tz * inv_distance;
    // Angle off the LED's axis, measured from the LED towards the point; NaN
    // (a non-finite point) counts as 0, like the clamp of Evaluate.
    const double cosine = -(lx * ax + ly * ay + lz * az);
    const double positive = cosine > 0 ? cosine : 1.0;  // keeps the ln finite where it is not used
    const double power = ExpNonPositive(mu * LnPositive(positive));
    const double angular = cosine > 0 ? power : at_zero;
    const double falloff = angular * reference2 * (inv_distance * inv_distance);
    dx[i] = static_cast<float>(lx), dy[i] = static_cast<float>(ly), dz[i] = static_cast<float>(lz);
    ir[i] = static_cast<float>(red * falloff), ig[i] = static_cast<float>(green * falloff);
    ib[i] = static_cast<float>(blue * falloff);
  }
}

// The points of a block, planar: GCC 12 does not vectorise the light loop
// when it reads the interleaved floats into doubles itself.
inline void Deinterleave(int n, const float* __restrict points, double* __restrict x, double* __restrict y,
                         double* __restrict z) {
  for (int i = 0; i < n; ++i) x[i] = points[3 * i], y[i] = points[3 * i + 1], z[i] = points[3 * i + 2];
}

void PointLights(const PointLightArgs& a) {
  const ptrdiff_t stride = a.stride;
  double x[kBlock], y[kBlock], z[kBlock];
  for (int i0 = 0; i0 < a.count; i0 += kBlock) {
    const int n = a.count - i0 < kBlock ? a.count - i0 : kBlock;
    Deinterleave(n, a.points + 3 * i0, x, y, z);
    for (int k = 0; k < a.num_lights; ++k) {
      float* dirs = a.dirs + 3 * k * stride + i0;
      float* intensities = a.intensities + 3 * k * stride + i0;
      PointLight(n, a.lights + k * kPointLightValues, x, y, z, dirs, dirs + stride, dirs + 2 * stride, intensities,
                 intensities + stride, intensities + 2 * stride);
    }
  }
}

// Each node column's values at the row: (1 - fy) top + fy bottom, in double.
inline void BlendColumn(int n, double fy, const float* __restrict top, const float* __restrict bottom,
                        double* __restrict out) {
  for (int q = 0; q < n; ++q) out[q] = (1 - fy) * top[q] + fy * bottom[q];
}

// A cell's start and step per value, from its two ends.
inline void CellLine(int n, double scale, const double* __restrict left, const double* __restrict right,
                     float* __restrict start, float* __restrict step) {
  for (int q = 0; q < n; ++q) {
    start[q] = static_cast<float>(left[q]);
    step[q] = static_cast<float>((right[q] - left[q]) * scale);
  }
}

inline void FillLine(int n, float start, float step, float* __restrict out) {
  for (int t = 0; t < n; ++t) out[t] = start + step * static_cast<float>(t);
}

// FillLine of a whole cell of kLightCellWidth pixels (every cell but the
// last of a tile): a trip count the compiler knows, so whole vectors and no
// loop set-up or tail per call; the same operations, so the same floats.
constexpr int kLightCellWidth = 16;  // tiled::kLightCell (tile_lights.h)
inline void FillCell(float start, float step, float* __restrict out) {
  // Kept a loop for the vectoriser (unrolled first, GCC makes it 16 scalar
  // products and shuffles).
#pragma GCC unroll 1
  for (int t = 0; t < kLightCellWidth; ++t) out[t] = start + step * static_cast<float>(t);
}

// Each value's plane filled cell after cell (one contiguous run of the row
// per value), from every cell's start and step made first.
void Interpolate(const InterpolateArgs& a) {
  const int n = a.num_values, cells = a.num_cells;
  const ptrdiff_t cap = a.capacity;
  double* dir_columns = a.scratch;
  double* inv_columns = dir_columns + static_cast<ptrdiff_t>(a.num_columns) * n;
  float* lines = reinterpret_cast<float*>(inv_columns + static_cast<ptrdiff_t>(a.num_columns) * n);
  // [c * n + q] per cell c and value q.
  float* dir_start = lines;
  float* dir_step = dir_start + static_cast<ptrdiff_t>(cells) * n;
  float* inv_start = dir_step + static_cast<ptrdiff_t>(cells) * n;
  float* inv_step = inv_start + static_cast<ptrdiff_t>(cells) * n;
  for (int j = 0; j < a.num_columns; ++j) {
    BlendColumn(n, a.fy, a.top_dirs[j], a.bottom_dirs[j], dir_columns + j * n);
    BlendColumn(n, a.fy, a.top_inv[j], a.bottom_inv[j], inv_columns + j * n);
  }
  for (int c = 0; c < cells; ++c) {
    const int right = c + 1 < a.num_columns ? c + 1 : a.num_columns - 1;
    CellLine(n, a.cell_scale[c], dir_columns + c * n, dir_columns + right * n, dir_start + c * n, dir_step + c * n);
    CellLine(n, a.cell_scale[c], inv_columns + c * n, inv_columns + right * n, inv_start + c * n, inv_step + c * n);
  }
  for (int q = 0; q < n; ++q) {
    float* dir_plane = a.dirs + q * cap;
    float* inv_plane = a.inv + q * cap;
    for (int c = 0; c < cells; ++c) {
      const int begin = a.cell_begin[c], count = a.cell_count[c];
      const ptrdiff_t at = static_cast<ptrdiff_t>(c) * n + q;
      if (count == kLightCellWidth) {
        FillCell(dir_start[at], dir_step[at], dir_plane + begin);
        FillCell(inv_start[at], inv_step[at], inv_plane + begin);
      } else {
        FillLine(count, dir_start[at], dir_step[at], dir_plane + begin);
        FillLine(count, inv_start[at], inv_step[at], inv_plane + begin);
      }
    }
  }
}

inline void StoreTriple(int n, const double* __restrict v0, const double* __restrict v1,
                        const double* __restrict v2, float* __restrict out) {
  for (int i = 0; i < n; ++i) {
    out[3 * i] = static_cast<float>(v0[i]);
    out[3 * i + 1] = static_cast<float>(v1[i]);
    out[3 * i + 2] = static_cast<float>(v2[i]);
  }
}

inline void StoreSolvedTriple(int n, uint8_t solved, const uint8_t* __restrict status, const double* __restrict v0,
                              const double* __restrict v1, const double* __restrict v2, float* __restrict out) {
  for (int i = 0; i < n; ++i) {
    const bool ok = status[i] == solved;
    out[3 * i] = ok ? static_cast<float>(v0[i]) : 0.0f;
    out[3 * i + 1] = ok ? static_cast<float>(v1[i]) : 0.0f;
    out[3 * i + 2] = ok ? static_cast<float>(v2[i]) : 0.0f;
  }
}

inline int StoreCodes(int n, const StoreArgs& a, const uint8_t* __restrict status, const int* __restrict used,
                      uint8_t* __restrict status_out, uint8_t* __restrict lights_out, uint8_t* __restrict path_out) {
  const uint8_t solved = a.solved, light_path = a.light_path, no_path = a.no_path;
  int solved_count = 0;
  for (int i = 0; i < n; ++i) {
    const bool ok = status[i] == solved;
    status_out[i] = status[i];
    lights_out[i] = static_cast<uint8_t>(used[i] < 0 ? 0 : used[i] > 255 ? 255 : used[i]);
    path_out[i] = ok ? light_path : no_path;
    solved_count += ok ? 1 : 0;
  }
  return solved_count;
}

inline void StoreConfidence(int n, uint8_t solved, const uint8_t* __restrict status,
                            const double* __restrict condition, const double* __restrict residual,
                            float* __restrict condition_out, float* __restrict residual_out) {
  const double float_max = __FLT_MAX__;
  for (int i = 0; i < n; ++i) {
    const bool ok = status[i] == solved;
    condition_out[i] = static_cast<float>(condition[i] < float_max ? condition[i] : float_max);
    residual_out[i] = ok ? static_cast<float>(residual[i] < 1e30 ? residual[i] : 1e30) : 0.0f;
  }
}

int Store(const StoreArgs& a) {
  const int n = a.count;
  const ptrdiff_t cap = a.capacity;
  StoreTriple(n, a.normal, a.normal + cap, a.normal + 2 * cap, a.normal_out);
  if (a.mosaic_out != nullptr) {
    const uint8_t solved = a.solved;
    const uint8_t* __restrict status = a.status;
    const double* __restrict length = a.luminance_albedo;
    float* __restrict out = a.mosaic_out;
    for (int i = 0; i < n; ++i) out[i] = status[i] == solved ? static_cast<float>(length[i]) : 0.0f;
  }
  if (a.albedo_out != nullptr) {
    StoreSolvedTriple(n, a.solved, a.status, a.albedo, a.albedo + cap, a.albedo + 2 * cap, a.albedo_out);
  }
  const int solved_count = StoreCodes(n, a, a.status, a.lights_used, a.status_out, a.lights_out, a.path_out);
  if (a.condition_out != nullptr) {
    StoreConfidence(n, a.solved, a.status, a.condition, a.residual, a.condition_out, a.residual_out);
  }
  if (a.specular_out != nullptr) {
    const uint8_t solved = a.solved, unsupported = a.unsupported, not_solved = a.not_solved;
    const uint8_t* __restrict status = a.status;
    float* __restrict specular = a.specular_out;
    uint8_t* __restrict specular_status = a.specular_status_out;
    for (int i = 0; i < 2 * n; ++i) specular[i] = 0.0f;
    for (int i = 0; i < n; ++i) specular_status[i] = status[i] == solved ? unsupported : not_solved;
  }
  return solved_count;
}

}  // namespace

const SpanKernels kKernels{SCANBENCH_ISA_ENUM, &Accumulate, &Residuals,  &PointLights,
                           &Solve,             &Conditions, &LightRules, &Interpolate, &Store};

}  // namespace scanbench::tiled::SCANBENCH_ISA_NAMESPACE
