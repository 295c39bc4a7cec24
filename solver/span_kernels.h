// Internal to the solver library: the hot loops of the tiled solve over one
// span (accumulation, the light usability rules, the point LEDs' falloff, the
// condition numbers, the 3x3 solves, the residuals), in plain-pointer form.
// They are compiled once per instruction set (span_kernels_baseline.cc,
// _avx2.cc, _avx512.cc include span_kernels_impl.h) and picked once per
// solve (SpanKernelsFor). Only plain
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
  // Per light: the same span of the next row (samples, then marks), asked
  // of the memory while this row's block of the light is summed; null: none.
  const float* const* next_pixels = nullptr;
  const uint8_t* const* next_marks = nullptr;
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
  // Then the RMS residual relative to the albedo, where albedo > 0:
  // sqrt(residual2 / max(1, used)) / albedo, else 0.
  const double* used = nullptr;       // samples used (acc's kCount row)
  const double* albedo = nullptr;     // luminance albedo, 0 unless solved
  double* rms = nullptr;              // out, count values
};

// The closed-form solve of a span's normal equations at the pixels marked
// ready (enough lights, condition number within the limit: decided by the
// caller): scaled = inverse(Gram) * L^T luminance, then the status from its
// length and direction, the unit normal and the RGB albedo (the lengths of
// inverse(Gram) * L^T channel).
struct SolveArgs {
  int count = 0, capacity = 0;
  bool albedo = false;        // the RGB albedo too (acc rows kR0..kBl2)
  bool invert_gram = false;   // invert each pixel's accumulated Gram matrix (cofactors); else read `inverse`
  double min_albedo = 0;      // shorter scaled normals have no signal
  int solved = 0, no_signal = 0, facing_away = 0;  // the PixelStatus codes to write
  const double* acc = nullptr;      // [a * capacity + i], a in tiled::Acc
  // Unless invert_gram: the symmetric inverse's 00, 01, 02, 11, 12, 22 of a
  // pixel marked 2 in `ready` at [e * capacity + i], else `shared_inverse`'s.
  const double* inverse = nullptr;
  const double* shared_inverse = nullptr;  // 6 values
  const double* ready = nullptr;    // 1: solve the pixel (2: with its own inverse), 0: not
  double* status = nullptr;         // out: the status code where ready, -1 elsewhere
  double* scaled = nullptr;         // out: [c * capacity + i], luminance scaled normal; 0 unless solved
  double* normal = nullptr;         // out: [c * capacity + i], unit; (0, 0, 1) unless solved
  double* luminance_albedo = nullptr;  // out: length of the scaled normal; 0 unless solved
  double* rgb_albedo = nullptr;        // out: [c * capacity + i]; 0 unless solved (and asked for)
};

// The condition number of each pixel's accumulated Gram matrix, as
// ConditionNumberFromGram (solver/pixel_solvers.h) computes it along its
// first route (Newton from above to the largest eigenvalue, 8 steps at
// most): the same operations, so the same values. Pixels that route does not
// settle are flagged for the scalar function.
struct ConditionArgs {
  int count = 0, capacity = 0;
  const double* acc = nullptr;  // [a * capacity + i], a in tiled::Acc
  double* condition = nullptr;  // out
  double* fallback = nullptr;   // out: 1 where `condition` is not set (call ConditionNumberFromGram), else 0
};

// The usability rules of TileLightSampler::Probe over a span's planar
// lights, in place: intensities become their inverses (0 where unusable).
struct LightRulesArgs {
  int count = 0, num_lights = 0, stride = 0;
  bool bayer = false;               // each raw pixel needs only its own channel
  double w0 = 0, w1 = 0, w2 = 0;    // luminance weights
  double min_intensity = 0;         // min_light_intensity
  const float* dirs = nullptr;      // [(3k + c) * stride + i]
  float* inv = nullptr;             // in: intensities; out: 1 / intensity or 0
  uint8_t* bad = nullptr;           // out: set to 1 where a light is not finite (left as is elsewhere)
};

// Point LEDs at a span of surface points (PointLightField::EvaluateSpan):
// per light, the unit direction towards it and rgb * cos^mu * reference^2 /
// distance^2, with cos the cosine off the LED's axis clamped to 0.
struct PointLightArgs {
  int count = 0, num_lights = 0, stride = 0;
  const float* points = nullptr;   // 3 per pixel, interleaved
  const double* lights = nullptr;  // kPointLightValues per light, PointLightValue order
  float* dirs = nullptr;           // out: [(3k + c) * stride + i]
  float* intensities = nullptr;    // out: likewise
};
enum PointLightValue : int { kLightX, kLightY, kLightZ, kAxisX, kAxisY, kAxisZ, kMu, kReference2, kRed, kGreen, kBlue,
                             kPointLightValues };

// One row of an interpolated tile's lights (TileLightSampler's bilinear
// interpolation between node rows): first each node column's values at the
// row (linear in y), then, within each cell between two node columns,
// value(t) = start + step * t (in float) with start and step from the
// cell's two ends (in double).
struct InterpolateArgs {
  int num_values = 0;   // 3 per light
  int num_columns = 0;  // node columns
  int num_cells = 0;    // cells along the row: max(1, num_columns - 1)
  int capacity = 0;     // stride of the output planes
  double fy = 0;        // the row's position between the node rows, in [0, 1]
  const int* cell_begin = nullptr;  // per cell: its first pixel, from the span's start
  const int* cell_count = nullptr;  // per cell: its pixels (the last one includes its right node)
  const double* cell_scale = nullptr;  // per cell: 1 / its width in pixels (0 for a single column)
  // Per node column: the node above and below the row, num_values each.
  const float* const* top_dirs = nullptr;
  const float* const* bottom_dirs = nullptr;
  const float* const* top_inv = nullptr;
  const float* const* bottom_inv = nullptr;
  double* scratch = nullptr;  // 2 * num_columns * num_values + 2 * num_cells * num_values doubles
  float* dirs = nullptr;      // out: [q * capacity + i]
  float* inv = nullptr;       // out: likewise
};

// A span's fits (planar doubles) into the result images' row (interleaved
// floats), every pixel of the span: what PixelWriter::StoreFits writes where
// no pixel is skipped. Returns the pixels solved.
struct StoreArgs {
  int count = 0, capacity = 0;
  uint8_t solved = 0;                       // PixelStatus::kSolved
  uint8_t light_path = 0, no_path = 0;      // SolvePath of a solved pixel and of the others
  uint8_t unsupported = 0, not_solved = 0;  // SpecularStatus of solved and other pixels
  const uint8_t* status = nullptr;
  const int* lights_used = nullptr;
  const double* normal = nullptr;            // [c * capacity + i]
  const double* albedo = nullptr;            // [c * capacity + i]; read where albedo_out is set
  const double* luminance_albedo = nullptr;  // read where mosaic_out is set
  const double* condition = nullptr, *residual = nullptr;  // read where their outputs are set
  // The rows from the span's first pixel; null where the image is not filled.
  float* normal_out = nullptr;    // 3 per pixel
  float* albedo_out = nullptr;    // 3 per pixel, 0 unless solved
  float* mosaic_out = nullptr;    // 1 per pixel, the luminance albedo, 0 unless solved
  uint8_t* status_out = nullptr;
  uint8_t* lights_out = nullptr;  // clamped to [0, 255]
  uint8_t* path_out = nullptr;
  float* condition_out = nullptr;  // at most the largest float
  float* residual_out = nullptr;   // at most 1e30, 0 unless solved
  float* specular_out = nullptr;   // 2 per pixel, 0
  uint8_t* specular_status_out = nullptr;
};

struct SpanKernels {
  KernelIsa isa = KernelIsa::kBaseline;
  void (*accumulate)(const AccumulateArgs& args) = nullptr;
  void (*residuals)(const ResidualArgs& args) = nullptr;
  void (*point_lights)(const PointLightArgs& args) = nullptr;
  void (*solve)(const SolveArgs& args) = nullptr;
  void (*conditions)(const ConditionArgs& args) = nullptr;
  void (*light_rules)(const LightRulesArgs& args) = nullptr;
  void (*interpolate)(const InterpolateArgs& args) = nullptr;
  int (*store)(const StoreArgs& args) = nullptr;
};

// The kernels built for `isa` (which must be supported: KernelIsaSupported).
const SpanKernels& SpanKernelsFor(KernelIsa isa);

// One table per instruction set, defined in its own translation unit.
namespace isa_baseline { extern const SpanKernels kKernels; }
namespace isa_avx2 { extern const SpanKernels kKernels; }
namespace isa_avx512 { extern const SpanKernels kKernels; }

}  // namespace scanbench::tiled
