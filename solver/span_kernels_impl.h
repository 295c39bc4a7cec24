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
}

}  // namespace

const SpanKernels kKernels{SCANBENCH_ISA_ENUM, &Accumulate, &Residuals};

}  // namespace scanbench::tiled::SCANBENCH_ISA_NAMESPACE
