#include "solver/tiled_solve.h"

#include <algorithm>
#include <limits>

namespace scanbench::tiled {
namespace {

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

// All lights of one span: the rows' addresses and the per-span constants,
// then the hot loop of the job's instruction set (span_kernels_impl.h).
template <bool kUniform, bool kBayer, bool kAlbedo>
void AccumulateSpan(const SolveJob& job, const SharedLights& shared, int x0, int count, int y, SpanBuffers* b) {
  const PhotometricSolverOptions& options = *job.options;
  constexpr int kChannels = kBayer ? 1 : 3;
  for (int k = 0; k < job.num_lights; ++k) {
    b->rows[k] = (*job.images)[k]->row(y) + static_cast<size_t>(x0) * kChannels;
    b->marks[k] = job.sample_valid->empty() ? b->ones.data() : (*job.sample_valid)[k]->row(y) + x0;
  }
  PrefetchNextRow(job, x0, count, y, kChannels);
  AccumulateArgs a;
  a.count = count;
  a.num_lights = job.num_lights;
  a.capacity = b->capacity;
  a.uniform = kUniform;
  a.bayer = kBayer;
  a.albedo = kAlbedo;
  a.pixels = b->rows.data();
  a.marks = b->marks.data();
  a.w0 = static_cast<float>(options.luminance_weights[0]);
  a.w1 = static_cast<float>(options.luminance_weights[1]);
  a.w2 = static_cast<float>(options.luminance_weights[2]);
  // With no shadow level every finite sample counts (also 0 and negatives).
  a.threshold = options.min_sample_value > 0 ? static_cast<float>(options.min_sample_value)
                                             : -std::numeric_limits<float>::infinity();
  a.shared_dir = shared.dir.data();
  a.shared_inv = shared.inv.data();
  // Bayer: the colour channel of even and odd columns of this row.
  a.even_channel = job.cfa_channels[(y & 1) * 2 + (x0 & 1)];
  a.odd_channel = job.cfa_channels[(y & 1) * 2 + ((x0 + 1) & 1)];
  a.dir = b->dir.data();
  a.inv = b->inv.data();
  a.lum = b->lum.data();
  a.ok = b->ok.data();
  a.rgb = b->rgb.data();
  a.clipped = b->clipped.data();
  a.acc = b->acc.data();
  KernelsOf(job).accumulate(a);
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
  rows.assign(num_lights, nullptr);
  marks.assign(num_lights, nullptr);
  acc.assign(static_cast<size_t>(kNumAcc) * capacity, 0.0);
  light_bad.assign(capacity, 0);
  clipped.assign(capacity, 0.0f);
  all_lights_condition.assign(capacity, 0.0);
}

const SpanKernels& KernelsOf(const SolveJob& job) {
  return job.kernels != nullptr ? *job.kernels : SpanKernelsFor(ActiveKernelIsa());
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
