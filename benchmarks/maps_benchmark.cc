// Height from normals (relaxation, DCT) and normal flattening, megapixels per
// second at 1, 4 and 16 MP.
//
//   build-maps-height/benchmarks/maps_benchmark
//   build-maps-height/benchmarks/maps_benchmark --benchmark_filter=4MP
//
// Figures, not pass/fail. The normals are those of a weave-like relief
// (threads of 2.4 x 3 mm, 0.2 mm crowns) on a slow fold, at the pixel pitch
// of a 150 mm field. The relaxation runs its default budget (400 sweeps per
// level, 1e-6 tolerance), which it uses up on every level of these sizes;
// its counters give the sweeps and the RMS slope residual reached. CPU time
// (and so MP/s) is the whole process's, all threads: the relaxation sweeps
// run on the shared thread pool (core/parallel_for.h), OpenCV's blur and
// resize on cv::parallel_for_.
#include <cmath>
#include <numbers>

#include <benchmark/benchmark.h>

#include "benchmarks/map_cache.h"
#include "maps/height_from_normals.h"
#include "maps/normal_flattening.h"

namespace scanbench {
namespace {

// A weave-like relief's normals: gradient of 0.2 |sin(2 pi u / 2.4)| |cos(2 pi v / 3)| + 3 sin(2 pi (u + v) / 80),
// u, v in mm.
ImageF WeaveNormals(int width, int height) {
  constexpr double two_pi = 2 * std::numbers::pi;
  return SampleField(width, height, 3, [](double u, double v, float* normal) {
    const double su = std::sin(two_pi * u / 2.4), cv = std::cos(two_pi * v / 3.0);
    const double fold = 3 * two_pi / 80 * std::cos(two_pi * (u + v) / 80);
    const double dzdu = 0.2 * two_pi / 2.4 * std::cos(two_pi * u / 2.4) * (su >= 0 ? 1 : -1) * std::abs(cv) + fold;
    const double dzdv = -0.2 * two_pi / 3.0 * std::abs(su) * std::sin(two_pi * v / 3.0) * (cv >= 0 ? 1 : -1) + fold;
    // v runs down the image; the tangent frame's y is up.
    const double p = dzdu, q = -dzdv, length = std::sqrt(p * p + q * q + 1);
    normal[0] = static_cast<float>(-p / length);
    normal[1] = static_cast<float>(-q / length);
    normal[2] = static_cast<float>(1 / length);
  });
}

const ImageF& Normals(int width, int height) {
  static MapCache cache(WeaveNormals);
  return cache.Get(width, height);
}

void BM_Height(benchmark::State& state, HeightFromNormalsOptions::Method method, int width, int height) {
  const ImageF& normals = Normals(width, height);
  HeightFromNormalsOptions options;
  options.method = method;
  options.mm_per_pixel = kFieldWidthMm / width;
  HeightFromNormalsSummary summary;
  ImageF heights;
  for (auto _ : state) {
    summary = HeightFromNormals(options, normals, nullptr, &heights);
    benchmark::DoNotOptimize(heights.data());
  }
  SetMegapixelRate(state, width, height);
  state.counters["sweeps"] = summary.total_sweeps;
  state.counters["levels"] = summary.levels;
  state.counters["residual"] = summary.rms_slope_residual;
}

void BM_Flatten(benchmark::State& state, int width, int height) {
  const ImageF& normals = Normals(width, height);
  NormalFlatteningOptions options;
  options.low_pass_sigma_px = static_cast<double>(state.range(0));
  NormalFlatteningSummary summary;
  ImageF flat;
  for (auto _ : state) {
    summary = FlattenNormals(options, normals, nullptr, &flat);
    benchmark::DoNotOptimize(flat.data());
  }
  SetMegapixelRate(state, width, height);
  state.counters["removed_tilt_deg"] = summary.mean_removed_tilt_deg;
}

using Method = HeightFromNormalsOptions::Method;

// 1 MP (1232 x 816), 4 MP (2464 x 1632), 16 MP (4928 x 3264): the D5100 binned and full.
BENCHMARK_CAPTURE(BM_Height, dct_1MP, Method::kDctPoisson, 1232, 816)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime();
BENCHMARK_CAPTURE(BM_Height, dct_4MP, Method::kDctPoisson, 2464, 1632)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime();
BENCHMARK_CAPTURE(BM_Height, dct_16MP, Method::kDctPoisson, 4928, 3264)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->Iterations(1);
BENCHMARK_CAPTURE(BM_Height, relaxation_1MP, Method::kMultiresolutionRelaxation, 1232, 816)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->Iterations(1);
BENCHMARK_CAPTURE(BM_Height, relaxation_4MP, Method::kMultiresolutionRelaxation, 2464, 1632)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->Iterations(1);
BENCHMARK_CAPTURE(BM_Height, relaxation_16MP, Method::kMultiresolutionRelaxation, 4928, 3264)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->Iterations(1);
// range(0): low_pass_sigma_px (4 = blurred at full resolution, 48 = default, 200 = very slow tilt).
BENCHMARK_CAPTURE(BM_Flatten, 1MP, 1232, 816)
    ->Arg(4)
    ->Arg(48)
    ->Arg(200)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime();
BENCHMARK_CAPTURE(BM_Flatten, 4MP, 2464, 1632)
    ->Arg(4)
    ->Arg(48)
    ->Arg(200)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime();
BENCHMARK_CAPTURE(BM_Flatten, 16MP, 4928, 3264)
    ->Arg(48)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->Iterations(1);

}  // namespace
}  // namespace scanbench
