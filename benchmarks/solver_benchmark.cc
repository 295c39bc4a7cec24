// Solver throughput in megapixels per second, 10 lights, on analytic scenes.
// Run: build/benchmarks/solver_benchmark  (figures, not pass/fail)
#include <benchmark/benchmark.h>

#include "solver/photometric_solver.h"
#include "solver/synthetic_scene.h"

namespace scanbench {
namespace {

void BM_JacobiSvdSolve(benchmark::State& state, SyntheticSceneOptions::Lights lights) {
  SyntheticSceneOptions scene_options;
  scene_options.width = 1024;
  scene_options.height = 1024;
  scene_options.num_lights = 10;
  scene_options.lights = lights;
  scene_options.noise_stddev = 0.001;
  const SyntheticScene scene = MakeSyntheticScene(scene_options);
  PhotometricSolverInput input;
  input.images = scene.ImagePointers();
  input.light_field = scene.light_field.get();
  PhotometricSolverOptions options;
  options.num_threads = static_cast<int>(state.range(0));
  PhotometricSolution solution;
  for (auto _ : state) {
    const PhotometricSolverSummary summary = SolvePhotometricStereo(options, input, &solution);
    benchmark::DoNotOptimize(summary.num_solved());
  }
  const double megapixels = scene_options.width * scene_options.height / 1e6;
  state.counters["MP/s"] = benchmark::Counter(megapixels * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["threads"] = static_cast<double>(options.num_threads);
  state.counters["lights"] = scene_options.num_lights;
}

BENCHMARK_CAPTURE(BM_JacobiSvdSolve, distant_lights, SyntheticSceneOptions::Lights::kDistant)
    ->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_JacobiSvdSolve, near_field_leds, SyntheticSceneOptions::Lights::kNearField)
    ->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace scanbench
