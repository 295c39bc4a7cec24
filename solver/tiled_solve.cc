#include "solver/tiled_solve.h"

#include <algorithm>
#include <limits>

namespace scanbench::tiled {
namespace {

// Per-light constants of the hot loop (uniform lights, weights, threshold).
struct SpanConstants {
  float w0, w1, w2;                 // luminance weights
  float threshold;                  // shadow level; -infinity keeps every finite sample
  float ud0, ud1, ud2;              // uniform tile: light direction
  float ui0, ui1, ui2;              // uniform tile: 1 / intensity per channel
  float ui_even, ui_odd;            // uniform tile, Bayer: 1 / intensity of even / odd columns
};

// The hot loop for one light over a span of pixels: divide the samples by the
// light, decide whether they are usable and add them to the normal equations.
// A free function with restrict-qualified parameters and no branches (selects
// only), so that the compiler proves the arrays independent and vectorises.
template <bool kUniform, bool kBayer, bool kAlbedo>
void AccumulateLightSpan(int count, const SpanConstants c, const float* __restrict plane0,
                         const float* __restrict plane1, const float* __restrict plane2,
                         const float* __restrict valid, const float* __restrict dx, const float* __restrict dy,
                         const float* __restrict dz, const float* __restrict i0, const float* __restrict i1,
                         const float* __restrict i2, const float* __restrict i_even, const float* __restrict i_odd,
                         float* __restrict clipped, float* __restrict lum, float* __restrict ok,
                         float* __restrict red, float* __restrict green, float* __restrict blue,
                         double* __restrict g00, double* __restrict g01, double* __restrict g02,
                         double* __restrict g11, double* __restrict g12, double* __restrict g22,
                         double* __restrict b0, double* __restrict b1, double* __restrict b2,
                         double* __restrict used, double* __restrict rr0, double* __restrict rr1,
                         double* __restrict rr2, double* __restrict gg0, double* __restrict gg1,
                         double* __restrict gg2, double* __restrict bb0, double* __restrict bb1,
                         double* __restrict bb2) {
  for (int i = 0; i < count; ++i) {
    const float d0 = kUniform ? c.ud0 : dx[i];
    const float d1 = kUniform ? c.ud1 : dy[i];
    const float d2 = kUniform ? c.ud2 : dz[i];
    float raw, divided, r = 0, g = 0, b = 0;
    float usable;  // 1 or 0
    if constexpr (kBayer) {
      const float sample = plane0[i];
      const float odd = static_cast<float>(i & 1);
      const float inverse =
          kUniform ? c.ui_even + odd * (c.ui_odd - c.ui_even) : i_even[i] + odd * (i_odd[i] - i_even[i]);
      raw = sample;
      divided = sample * inverse;
      usable = (sample - sample == 0.0f && inverse > 0.0f) ? 1.0f : 0.0f;
    } else {
      const float s0 = plane0[i], s1 = plane1[i], s2 = plane2[i];
      const float v0 = kUniform ? c.ui0 : i0[i];
      const float v1 = kUniform ? c.ui1 : i1[i];
      const float v2 = kUniform ? c.ui2 : i2[i];
      r = s0 * v0;
      g = s1 * v1;
      b = s2 * v2;
      raw = c.w0 * s0 + c.w1 * s1 + c.w2 * s2;
      divided = c.w0 * r + c.w1 * g + c.w2 * b;
      usable = (raw - raw == 0.0f && v0 > 0.0f && v1 > 0.0f && v2 > 0.0f) ? 1.0f : 0.0f;
    }
    const float marked_valid = valid[i];
    clipped[i] = std::max(clipped[i], 1.0f - marked_valid);
    const float weight = raw > c.threshold ? usable * marked_valid : 0.0f;
    const float lum_used = weight > 0.0f ? divided : 0.0f;
    const double wd0 = weight * d0, wd1 = weight * d1, wd2 = weight * d2;
    g00[i] += wd0 * d0;
    g01[i] += wd0 * d1;
    g02[i] += wd0 * d2;
    g11[i] += wd1 * d1;
    g12[i] += wd1 * d2;
    g22[i] += wd2 * d2;
    b0[i] += double(d0) * lum_used;
    b1[i] += double(d1) * lum_used;
    b2[i] += double(d2) * lum_used;
    used[i] += weight;
    lum[i] = lum_used;
    ok[i] = weight;
    if constexpr (kAlbedo) {
      const float r_used = weight > 0.0f ? r : 0.0f, g_used = weight > 0.0f ? g : 0.0f;
      const float b_used = weight > 0.0f ? b : 0.0f;
      red[i] = r_used;
      green[i] = g_used;
      blue[i] = b_used;
      rr0[i] += double(d0) * r_used;
      rr1[i] += double(d1) * r_used;
      rr2[i] += double(d2) * r_used;
      gg0[i] += double(d0) * g_used;
      gg1[i] += double(d1) * g_used;
      gg2[i] += double(d2) * g_used;
      bb0[i] += double(d0) * b_used;
      bb1[i] += double(d1) * b_used;
      bb2[i] += double(d2) * b_used;
    }
  }
}

// The next row of every light's span is a separate short run in memory, too
// short for the hardware prefetcher: ask for it now, use it next row.
void PrefetchNextRow(const SolveJob& job, int x0, int count, int y, int channels) {
  if (y + 1 >= job.field->height()) return;
  const size_t bytes = static_cast<size_t>(count) * channels * sizeof(float);
  for (int k = 0; k < job.num_lights; ++k) {
    const char* next = reinterpret_cast<const char*>((*job.images)[k]->row(y + 1) + static_cast<size_t>(x0) * channels);
    for (size_t offset = 0; offset < bytes; offset += 64) __builtin_prefetch(next + offset);
  }
}

// All lights of one span: planar copies of each light's samples (the hot loop
// then reads unit-stride floats only), then the hot loop.
template <bool kUniform, bool kBayer, bool kAlbedo>
void AccumulateSpan(const SolveJob& job, const SharedLights& shared, int x0, int count, int y, SpanBuffers* b) {
  const PhotometricSolverOptions& options = *job.options;
  const int n = b->capacity;
  constexpr int kChannels = kBayer ? 1 : 3;
  std::fill(b->acc.begin(), b->acc.end(), 0.0);
  std::fill(b->clipped.begin(), b->clipped.begin() + count, 0.0f);
  SpanConstants c{};
  c.w0 = static_cast<float>(options.luminance_weights[0]);
  c.w1 = static_cast<float>(options.luminance_weights[1]);
  c.w2 = static_cast<float>(options.luminance_weights[2]);
  // With no shadow level every finite sample counts (also 0 and negatives).
  c.threshold = options.min_sample_value > 0 ? static_cast<float>(options.min_sample_value)
                                             : -std::numeric_limits<float>::infinity();
  // Bayer: the colour channel of even and odd columns of this row.
  const int even_channel = job.cfa_channels[(y & 1) * 2 + (x0 & 1)];
  const int odd_channel = job.cfa_channels[(y & 1) * 2 + ((x0 + 1) & 1)];
  PrefetchNextRow(job, x0, count, y, kChannels);
  double* acc = b->acc.data();
  float* plane0 = b->planes.data();
  float* plane1 = b->planes.data() + n;
  float* plane2 = b->planes.data() + 2 * n;
  float* valid = b->planes.data() + 3 * n;
  for (int k = 0; k < job.num_lights; ++k) {
    const float* pixels = (*job.images)[k]->row(y) + static_cast<size_t>(x0) * kChannels;
    const uint8_t* marks = job.sample_valid->empty() ? b->ones.data() : (*job.sample_valid)[k]->row(y) + x0;
    if constexpr (kBayer) {
      std::copy(pixels, pixels + count, plane0);
    } else {
      for (int i = 0; i < count; ++i) {
        plane0[i] = pixels[3 * i];
        plane1[i] = pixels[3 * i + 1];
        plane2[i] = pixels[3 * i + 2];
      }
    }
    for (int i = 0; i < count; ++i) valid[i] = marks[i] != 0 ? 1.0f : 0.0f;
    c.ud0 = shared.dir[3 * k], c.ud1 = shared.dir[3 * k + 1], c.ud2 = shared.dir[3 * k + 2];
    c.ui0 = shared.inv[3 * k], c.ui1 = shared.inv[3 * k + 1], c.ui2 = shared.inv[3 * k + 2];
    c.ui_even = shared.inv[3 * k + even_channel], c.ui_odd = shared.inv[3 * k + odd_channel];
    auto light = [&](int channel) { return &b->dir[static_cast<size_t>(3 * k + channel) * n]; };
    auto inverse = [&](int channel) { return &b->inv[static_cast<size_t>(3 * k + channel) * n]; };
    auto rgb = [&](int channel) { return &b->rgb[static_cast<size_t>(3 * k + channel) * n]; };
    auto sum = [&](int row) { return acc + static_cast<size_t>(row) * n; };
    AccumulateLightSpan<kUniform, kBayer, kAlbedo>(
        count, c, plane0, plane1, plane2, valid, light(0), light(1), light(2), inverse(0), inverse(1), inverse(2),
        inverse(even_channel), inverse(odd_channel), b->clipped.data(), &b->lum[static_cast<size_t>(k) * n],
        &b->ok[static_cast<size_t>(k) * n], rgb(0), rgb(1), rgb(2), sum(kG00), sum(kG01), sum(kG02), sum(kG11),
        sum(kG12), sum(kG22), sum(kB0), sum(kB1), sum(kB2), sum(kCount), sum(kR0), sum(kR1), sum(kR2), sum(kGr0),
        sum(kGr1), sum(kGr2), sum(kBl0), sum(kBl1), sum(kBl2));
  }
}

}  // namespace

SpanBuffers::SpanBuffers(int lights, int span_capacity) : num_lights(lights), capacity(span_capacity) {
  const size_t k3n = static_cast<size_t>(3) * num_lights * capacity;
  const size_t kn = static_cast<size_t>(num_lights) * capacity;
  dir.assign(k3n, 0.0f);
  inv.assign(k3n, 0.0f);
  lum.assign(kn, 0.0f);
  rgb.assign(k3n, 0.0f);
  ok.assign(kn, 0.0f);
  ones.assign(capacity, 1);
  planes.assign(static_cast<size_t>(4) * capacity, 0.0f);
  acc.assign(static_cast<size_t>(kNumAcc) * capacity, 0.0);
  light_bad.assign(capacity, 0);
  clipped.assign(capacity, 0.0f);
  all_lights_condition.assign(capacity, 0.0);
}

AccumulateSpanFn ChooseAccumulator(bool bayer, bool with_albedo, bool uniform_lights) {
  // Bayer pixels carry one channel: no RGB albedo solves there.
  if (bayer) return uniform_lights ? &AccumulateSpan<true, true, false> : &AccumulateSpan<false, true, false>;
  if (with_albedo) return uniform_lights ? &AccumulateSpan<true, false, true> : &AccumulateSpan<false, false, true>;
  return uniform_lights ? &AccumulateSpan<true, false, false> : &AccumulateSpan<false, false, false>;
}

void GatherSamples(const Span& span, int i, bool with_rgb, PixelSamples* samples) {
  const SpanBuffers& b = *span.buffers;
  const int n = b.capacity;
  const bool uniform = span.lights == TileLights::kUniform;
  samples->Clear();
  for (int k = 0; k < b.num_lights; ++k) {
    const size_t at = static_cast<size_t>(k) * n + i;
    if (!(b.ok[at] > 0)) continue;
    double d[3];
    for (int c = 0; c < 3; ++c) {
      d[c] = uniform ? span.shared->dir[3 * k + c] : b.dir[static_cast<size_t>(3 * k + c) * n + i];
    }
    const double value = b.lum[at];
    double rgb[3] = {0, 0, 0};
    if (with_rgb) {
      for (int c = 0; c < 3; ++c) rgb[c] = b.rgb[static_cast<size_t>(3 * k + c) * n + i];
    }
    samples->Add(d[0], d[1], d[2], value, rgb[0], rgb[1], rgb[2]);
  }
}

}  // namespace scanbench::tiled
