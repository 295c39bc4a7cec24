// Internal to the solver library: the hot loops of the tiled solve over one
// span, in plain-pointer form. They are compiled once per instruction set
// (span_kernels_baseline.cc, _avx2.cc, _avx512.cc include
// span_kernels_impl.h) and picked once per solve (SpanKernelsFor). Only plain
// data crosses this interface: the per-ISA translation units must not
// instantiate library templates (see span_kernels_impl.h).
#pragma once

#include <cstdint>

#include "solver/cpu_dispatch.h"

namespace scanbench::tiled {

// Rows (per pixel) of the accumulated normal equations in SpanBuffers::acc.
enum Acc : int {
  kG00, kG01, kG02, kG11, kG12, kG22,  // Gram matrix
  kB0, kB1, kB2,                       // L^T luminance
  kR0, kR1, kR2, kGr0, kGr1, kGr2, kBl0, kBl1, kBl2,  // L^T red, green, blue
  kCount,                              // samples used
  kNumAcc
};

// One span's samples into the normal equations (what AccumulateSpan in
// tiled_solve.h documents). Planar buffers are [(3k + c) * capacity + i] or
// [k * capacity + i], as SpanBuffers.
struct AccumulateArgs {
  int count = 0, num_lights = 0, capacity = 0;
  bool uniform = false, bayer = false, albedo = false;
  const float* const* pixels = nullptr;  // per light: the row from x0 (RGB interleaved or mosaic)
  const uint8_t* const* marks = nullptr; // per light: 0 = sample marked invalid
  float w0 = 0, w1 = 0, w2 = 0;          // luminance weights
  float threshold = 0;                   // shadow level; -infinity keeps every finite sample
  const float* shared_dir = nullptr;     // uniform tiles: 3 per light
  const float* shared_inv = nullptr;
  int even_channel = 0, odd_channel = 0; // Bayer: CFA channel of even and odd columns of the row
  const float* dir = nullptr;            // non-uniform tiles: planar lights
  const float* inv = nullptr;
  float* lum = nullptr;                  // out: intensity-divided luminance, 0 where unused
  float* ok = nullptr;                   // out: 1 where used
  float* rgb = nullptr;                  // out: intensity-divided RGB, 0 where unused (albedo only)
  float* clipped = nullptr;              // out: 1 where a sample was marked invalid
  double* acc = nullptr;                 // out: [a * capacity + i], a in tiled::Acc
};

// Sum over used samples of (light . scaled normal - luminance)^2 per pixel.
struct ResidualArgs {
  int count = 0, num_lights = 0, capacity = 0;
  bool uniform = false;
  const float* shared_dir = nullptr;  // uniform tiles
  const float* dir = nullptr;         // other tiles, planar
  const float* lum = nullptr;
  const float* ok = nullptr;
  const double* scaled = nullptr;     // [c * capacity + i]
  double* residual2 = nullptr;        // out, count values
};

struct SpanKernels {
  KernelIsa isa = KernelIsa::kBaseline;
  void (*accumulate)(const AccumulateArgs& args) = nullptr;
  void (*residuals)(const ResidualArgs& args) = nullptr;
};

// The kernels built for `isa` (which must be supported: KernelIsaSupported).
const SpanKernels& SpanKernelsFor(KernelIsa isa);

// One table per instruction set, defined in its own translation unit.
namespace isa_baseline { extern const SpanKernels kKernels; }
namespace isa_avx2 { extern const SpanKernels kKernels; }
namespace isa_avx512 { extern const SpanKernels kKernels; }

}  // namespace scanbench::tiled
