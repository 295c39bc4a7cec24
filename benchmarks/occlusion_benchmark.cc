// Ambient occlusion and cavity from a height map, megapixels per second.
//
//   build-maps-occlusion/benchmarks/occlusion_benchmark
//   build-maps-occlusion/benchmarks/occlusion_benchmark --benchmark_filter=16MP
//
// Figures, not pass/fail. On a shared machine read the CPU column of the
// 1-thread cases (the calling thread's time; with 2 threads it is half the work). The height field is a weave-like relief (threads of
// 2.4 x 3 mm, 0.2 mm crowns, plus fine ripples) at the rig's pixel pitch for
// the size (150 mm across the field); cost does not depend on the content,
// only on pixels x directions x steps.
#include <cmath>
#include <numbers>

#include <benchmark/benchmark.h>

#include "benchmarks/map_cache.h"
#include "maps/surface_occlusion.h"

namespace scanbench {
namespace {

// A weave-like relief, mm: threads of 2.4 x 3 mm with 0.2 mm crowns plus fine ripples.
ImageF WeaveHeight(int width, int height) {
  constexpr double two_pi = 2 * std::numbers::pi;
  return SampleField(width, height, 1, [](double u, double v, float* height_mm) {
    *height_mm = static_cast<float>(0.2 * std::abs(std::sin(two_pi * u / 2.4)) * std::abs(std::cos(two_pi * v / 3.0)) +
                                    0.02 * std::sin(two_pi * (u + 0.7 * v) / 0.35));
  });
}

const ImageF& Height(int width, int height) {
  static MapCache cache(WeaveHeight);
  return cache.Get(width, height);
}

void SetFigures(benchmark::State& state, int width, int height, const OcclusionSummary& summary) {
  SetMegapixelRate(state, width, height);
  state.counters["mean"] = summary.mean;
  state.counters["steps"] = summary.steps_per_direction;
}

// range(0): threads, range(1): directions, range(2): max_steps, range(3): 1 = around the pixel normal.
void BM_AmbientOcclusion(benchmark::State& state, int width, int height) {
  const ImageF& map = Height(width, height);
  AmbientOcclusionOptions options;
  options.mm_per_pixel = kFieldWidthMm / width;
  options.num_threads = static_cast<int>(state.range(0));
  options.num_directions = static_cast<int>(state.range(1));
  options.max_steps = static_cast<int>(state.range(2));
  options.around_pixel_normal = state.range(3) != 0;
  OcclusionSummary summary;
  ImageF ao;
  for (auto _ : state) {
    summary = AmbientOcclusionFromHeight(options, map, &ao);
    benchmark::DoNotOptimize(ao.data());
  }
  SetFigures(state, width, height, summary);
}

// min_coarse_sigma_px 0: the full-resolution cv::GaussianBlur; 8: the default coarse grid.
void BM_Cavity(benchmark::State& state, int width, int height, double min_coarse_sigma_px) {
  const ImageF& map = Height(width, height);
  CavityOptions options;
  options.mm_per_pixel = kFieldWidthMm / width;
  options.min_coarse_sigma_px = min_coarse_sigma_px;
  OcclusionSummary summary;
  ImageF cavity;
  for (auto _ : state) {
    summary = CavityFromHeight(options, map, &cavity);
    benchmark::DoNotOptimize(cavity.data());
  }
  SetFigures(state, width, height, summary);
}

BENCHMARK_CAPTURE(BM_AmbientOcclusion, 1MP, 1232, 816)
    ->Args({1, 16, 32, 0})
    ->Args({2, 16, 32, 0})
    ->Args({2, 16, 32, 1})
    ->Args({2, 8, 16, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_AmbientOcclusion, 16MP, 4928, 3264)
    ->Args({1, 16, 32, 0})
    ->Args({1, 16, 16, 0})  // the export's default
    ->Args({2, 16, 32, 0})
    ->Args({2, 16, 32, 1})
    ->Args({2, 8, 16, 0})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Cavity, 1MP, 1232, 816, 8.0)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Cavity, 16MP, 4928, 3264, 8.0)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Cavity, 16MP_full_resolution, 4928, 3264, 0.0)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace scanbench
