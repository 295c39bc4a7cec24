// Internal to the solver library (not part of its API): what every method's
// tiled solve shares. The tile loop (photometric_solver.cc) classifies a
// tile's lights (tile_lights.h), accumulates each row's samples into
// structure-of-arrays span buffers (AccumulateSpan, here), and hands the span
// to the method's pixel kernel (pixel_kernels.h), which writes its fits
// through a PixelWriter.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "solver/photometric_methods.h"
#include "solver/photometric_solver.h"
#include "solver/pixel_solvers.h"
#include "solver/span_kernels.h"

namespace scanbench::tiled {

// What the tile loop, the light sampler and the kernels need to know about
// the job. `bayer` selects the input layout: one CFA channel per raw pixel
// (mosaics) instead of RGB pixels.
struct SolveJob {
  const PhotometricSolverOptions* options = nullptr;
  const LightField* field = nullptr;
  const std::vector<const ImageF*>* images = nullptr;  // RGB images or mosaics
  const std::vector<const ImageU8*>* sample_valid = nullptr;
  const ImageU8* region = nullptr;
  bool bayer = false;
  std::array<int, 4> cfa_channels{};
  int num_lights = 0;
  bool with_albedo = true;  // RGB albedo solves per pixel (never in Bayer mode: see albedo_mosaic)
  bool with_confidence = true;
  PhotometricSolution* solution = nullptr;
  ImageF* albedo_mosaic = nullptr;  // Bayer mode: the albedo of each raw pixel's own channel
  const SpanKernels* kernels = nullptr;  // the hot loops' instruction set; null = ActiveKernelIsa()
  const ImageU8* sheen_pixels = nullptr;  // optional: the coherent sheen's candidates (BayerSolverInput)
};

// The job of an RGB solve (or a refinement pass over one) of `input` into
// `solution`.
SolveJob RgbSolveJob(const PhotometricSolverOptions& options, const PhotometricSolverInput& input,
                     PhotometricSolution* solution, bool with_albedo, bool with_confidence);

// The job's kernels: job.kernels, else those of ActiveKernelIsa().
const SpanKernels& KernelsOf(const SolveJob& job);

// The checks a refinement pass over an RGB solve (the shared lobe, the shared
// sheen) makes of its input first: a solution, a light field, one 3-channel
// image of the field's size per light, a sample mask per image or none.
// Throws std::invalid_argument naming `pass` and the rule broken.
void CheckRgbRefinementInput(const char* pass, const PhotometricSolverInput& input,
                             const PhotometricSolution* solution);

// A refinement pass's loop over its blocks (the shared lobe, the shared
// sheen): every block_size square of width x height, the last row and column
// cut to the image, handed to `refine_block(x0, y0, x1, y1, worker)` on
// `num_workers` threads of the pool (BlockPassWorkers), worker in
// [0, num_workers). Each block writes only its own pixels, so the result does
// not depend on the thread count. `progress` gets the fraction of blocks done
// and may stop the pass; `summary` ends succeeded, or cancelled after so many
// blocks.
using BlockRefine = std::function<void(int x0, int y0, int x1, int y1, int worker)>;
int BlockPassWorkers(int requested_threads, int width, int height, int block_size);
void RunBlockPass(int width, int height, int block_size, int num_workers, const BlockRefine& refine_block,
                  const ProgressCallback& progress, AlgorithmSummary* summary);

// How a tile's pixels get their lights.
enum class TileLights {
  kUniform,       // one set of lights (and one light matrix) for the whole tile
  kInterpolated,  // bilinear between nodes kLightCell apart, checked against the field
  kExact,         // evaluated at every pixel
};

// Per-thread buffers of one span (up to `capacity` pixels of a row), planar:
// per light and pixel at [(3k + c) * capacity + i] or [k * capacity + i].
struct SpanBuffers {
  SpanBuffers(int num_lights, int capacity);

  int num_lights = 0;
  int capacity = 0;
  std::vector<float> dir, inv;  // light direction and 1 / intensity per channel (not for uniform tiles)
  std::vector<float> lum, rgb;  // intensity-divided samples (0 where not used)
  std::vector<float> ok;        // 1 where the sample is used, else 0
  std::vector<uint8_t> ones;    // stands in for a missing sample mask
  std::vector<const float*> rows;      // per light: the span's samples in the image
  std::vector<const uint8_t*> marks;  // per light: the span's sample_valid (or `ones`)
  std::vector<const float*> next_rows;         // per light: the next row's samples (prefetched)
  std::vector<const uint8_t*> next_marks;      // per light: the next row's sample_valid (or `ones`)
  std::vector<double> acc;      // [a * capacity + i], a in Acc (summed in float per span, see span_kernels_impl.h)
  std::vector<uint8_t> light_bad;              // non-finite light at the pixel
  std::vector<float> clipped;                  // 1 where a sample was marked invalid (clipped)
  std::vector<double> all_lights_condition;    // interpolated tiles: condition number of all lights
};

// A uniform tile's lights: 3 per light, and the light matrix of every light
// usable in all three channels.
struct SharedLights {
  std::vector<float> dir, inv;
  int usable = 0;  // lights in `inverse`; -1: the matrix is never shared
  Eigen::Matrix3d inverse = Eigen::Matrix3d::Identity();
  double condition = 0;
  uint64_t generation = 0;  // changes whenever the lights do (keys what kernels derive from them)
};

// One row's stretch of a tile once its samples are accumulated: what a kernel reads.
struct Span {
  TileLights lights = TileLights::kExact;
  int x0 = 0, y = 0, count = 0;
  const uint8_t* region = nullptr;  // the region's row from x0; null = every pixel
  const SpanBuffers* buffers = nullptr;
  const SharedLights* shared = nullptr;

  bool Wanted(int i) const { return region == nullptr || region[i] != 0; }
  // The path of a least-squares fit on these lights.
  SolvePath LightPath() const {
    return lights == TileLights::kUniform        ? SolvePath::kSharedLights
           : lights == TileLights::kInterpolated ? SolvePath::kInterpolatedLights
                                                 : SolvePath::kExactLights;
  }
};

// Divides one row's samples by the lights, decides which are usable and adds
// them to the normal equations in `buffers` (acc, lum, rgb, ok, clipped).
using AccumulateSpanFn = void (*)(const SolveJob& job, const SharedLights& shared, int x0, int count, int y,
                                  SpanBuffers* buffers);
// The instantiation of the hot loop for the job's layout (RGB or Bayer), its
// RGB albedo and the tile's lights: chosen once per solve and tile kind.
AccumulateSpanFn ChooseAccumulator(bool bayer, bool with_albedo, bool uniform_lights);

// The used samples of pixel i of the span, for the per-pixel fits.
void GatherSamples(const Span& span, int i, bool with_rgb, PixelSamples* samples);

// A span's least-squares fits, planar ([c * capacity + i] for 3 values):
// what NormalEquationsSolve (pixel_kernels.cc) produces and
// PixelWriter::StoreFits writes. No specular lobe (kUnsupported where solved).
struct SpanFits {
  explicit SpanFits(int capacity);
  PixelFit Fit(int i) const;  // pixel i as a PixelFit

  int capacity = 0;
  std::vector<uint8_t> status;       // PixelStatus
  std::vector<int> lights_used;
  std::vector<double> normal;        // unit; (0, 0, 1) unless solved
  std::vector<double> albedo;        // RGB; 0 unless solved (and asked for)
  std::vector<double> luminance_albedo, condition_number, residual;
};

// Writes fits into the solution and counts them by path.
class PixelWriter {
 public:
  explicit PixelWriter(const SolveJob& job) : job_(job) {}
  // `path` is the path that produced the fit; an unsolved fit counts as kNone.
  void Store(const PixelFit& fit, int x, int y, SolvePath path);
  // Store(fits.Fit(i), span.x0 + i, span.y, span.LightPath()) for every
  // wanted pixel i of the span with skip[i] == 0 (skip may be null), one
  // image at a time.
  void StoreFits(const SpanFits& fits, const Span& span, const uint8_t* skip);
  // The learned network's expected error of pixel (x, y), where the solution has the map.
  void StoreExpectedError(float degrees, int x, int y) {
    if (!job_.solution->learned_error_deg.empty()) job_.solution->learned_error_deg(x, y) = degrees;
  }
  const std::array<size_t, kNumSolvePaths>& pixels_by_path() const { return pixels_by_path_; }

 private:
  const SolveJob& job_;
  std::array<size_t, kNumSolvePaths> pixels_by_path_{};
};

// Inline: called once per pixel from the kernels' translation unit.
inline void PixelWriter::Store(const PixelFit& fit, int x, int y, SolvePath path) {
  PhotometricSolution& s = *job_.solution;
  for (int c = 0; c < 3; ++c) s.normal_in_table(x, y, c) = static_cast<float>(fit.normal[c]);
  const bool solved = fit.status == PixelStatus::kSolved;
  if (job_.bayer) {
    (*job_.albedo_mosaic)(x, y) = solved ? static_cast<float>(fit.luminance_albedo) : 0.0f;
  } else if (job_.with_albedo) {
    for (int c = 0; c < 3; ++c) s.albedo(x, y, c) = solved ? static_cast<float>(fit.albedo[c]) : 0.0f;
  }
  s.status(x, y) = static_cast<uint8_t>(fit.status);
  s.lights_used(x, y) = static_cast<uint8_t>(std::clamp(fit.lights_used, 0, 255));
  if (job_.with_confidence) {
    s.condition_number(x, y) =
        static_cast<float>(std::min(fit.condition_number, double(std::numeric_limits<float>::max())));
    s.residual(x, y) = solved ? static_cast<float>(std::min(fit.residual, 1e30)) : 0.0f;
  }
  if (!s.specular.empty()) {
    const bool estimated = solved && fit.specular_status == SpecularStatus::kEstimated;
    s.specular(x, y, 0) = estimated ? static_cast<float>(fit.specular_f0) : 0.0f;
    s.specular(x, y, 1) = estimated ? static_cast<float>(fit.roughness_alpha) : 0.0f;
    s.specular_status(x, y) = static_cast<uint8_t>(
        !solved ? SpecularStatus::kNotSolved : estimated ? SpecularStatus::kEstimated : SpecularStatus::kUnsupported);
  }
  const SolvePath stored = solved ? path : SolvePath::kNone;
  s.solve_path(x, y) = static_cast<uint8_t>(stored);
  ++pixels_by_path_[static_cast<int>(stored)];
}

}  // namespace scanbench::tiled
