// Solver throughput in megapixels per second on analytic scenes, every method.
//
//   build-solver/benchmarks/solver_benchmark                       (all)
//   build-solver/benchmarks/solver_benchmark --benchmark_filter=16MP
//
// SCANBENCH_SOLVER_ISA=baseline (or avx2) caps the kernels' instruction set;
// each case's label names the one that ran, and MP/s_cpu is the rate per
// CPU second times the threads (what MP/s would be on idle cores).
//
// Figures, not pass/fail. The 16 MP cases are the speed target: the
// default (adaptive) against the Jacobi SVD reference, 10 lights, 2 threads,
// on a Lambertian scene with near-field LEDs (per-pixel light field) and with
// distant lights. Each case also reports the mean angular error, so that
// "equal accuracy" can be read off beside the speed.
#include <time.h>

#include <algorithm>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <tuple>

#include <benchmark/benchmark.h>

#include "solver/angular_error.h"
#include "solver/coherent_sheen.h"
#include "solver/photometric_solver.h"
#include "solver/synthetic_scene.h"

namespace scanbench {
namespace {

using Method = PhotometricSolverOptions::Method;
using Lights = SyntheticSceneOptions::Lights;

// Scenes are large (16 MP x 10 lights = 2 GB): built once, shared by cases.
const SyntheticScene& Scene(Lights lights, int width, int height) {
  static std::mutex mutex;
  static std::map<std::tuple<int, int, int>, std::unique_ptr<SyntheticScene>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  const std::tuple<int, int, int> key{static_cast<int>(lights), width, height};
  auto found = cache.find(key);
  if (found == cache.end()) {
    cache.clear();  // one scene in memory at a time
    SyntheticSceneOptions options;
    options.width = width;
    options.height = height;
    options.num_lights = 10;
    options.lights = lights;
    options.noise_stddev = 0.002;
    // The near-field LEDs 500 mm away over a 0.03 mm pixel (16 MP over a
    // 150 mm field): the rig's geometry.
    options.pixel_pitch = 150.0 / width;
    options.light_distance = 500;
    found = cache.emplace(key, std::make_unique<SyntheticScene>(MakeSyntheticScene(options))).first;
  }
  return *found->second;
}

double ProcessCpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return now.tv_sec + 1e-9 * now.tv_nsec;
}

// What of adaptive runs (the default: all of it).
enum class AdaptivePasses {
  kAll,
  kIrls,           // the robust pass as before the lobe fit (Lambertian IRLS)
  kNoSheen,        // without the shared velvet sheen (its cost)
  kWithNetwork,    // with the learned network on the robust pixels without a lobe (--learned unsupported: its cost)
  kLeastSquares,   // least squares alone: no robust re-solve, no shared lobe or sheen. In the near field
                   // that is the interpolated-lights path (tiled::TileLights::kInterpolated) by itself.
};

// warm: also solve once more into the same solution and print that rate as
// MP/s_cpu_warm: the solver then reuses the result images (as band after
// band), and the first touch of ~0.6 GB of fresh memory at 16 MP is no part
// of it. MP/s and MP/s_cpu are always the first, cold solve's.
void BM_Solve(benchmark::State& state, Method method, Lights lights, int width, int height,
              AdaptivePasses passes = AdaptivePasses::kAll, bool warm = false) {
  const SyntheticScene& scene = Scene(lights, width, height);
  PhotometricSolverInput input;
  input.images = scene.ImagePointers();
  input.light_field = scene.light_field.get();
  PhotometricSolverOptions options;
  options.method = method;
  options.adaptive_lobe = passes != AdaptivePasses::kIrls && passes != AdaptivePasses::kLeastSquares;
  options.adaptive_coherent_sheen = passes == AdaptivePasses::kAll || passes == AdaptivePasses::kIrls;
  if (passes == AdaptivePasses::kLeastSquares) {
    options.adaptive_coherent_lobe = false;
    options.adaptive_robust_residual = std::numeric_limits<double>::infinity();  // no pixel re-solved
  }
  if (passes == AdaptivePasses::kWithNetwork) {
    options.adaptive_learned = PhotometricSolverOptions::LearnedUse::kUnsupportedLobe;
  }
  options.num_threads = static_cast<int>(state.range(0));
  PhotometricSolution solution;
  PhotometricSolverSummary summary;
  double cpu_seconds = 0;
  for (auto _ : state) {
    const double cpu_start = ProcessCpuSeconds();
    summary = SolvePhotometricStereo(options, input, &solution);
    cpu_seconds += ProcessCpuSeconds() - cpu_start;
    benchmark::DoNotOptimize(summary.num_solved());
  }
  const double megapixels = double(width) * height / 1e6;
  if (warm) {
    const double cpu_start = ProcessCpuSeconds();
    SolvePhotometricStereo(options, input, &solution);
    state.counters["MP/s_cpu_warm"] =
        megapixels * summary.num_threads / std::max(ProcessCpuSeconds() - cpu_start, 1e-9);
  }
  state.counters["MP/s"] = benchmark::Counter(megapixels * state.iterations(), benchmark::Counter::kIsRate);
  // The rate with the threads' cores to themselves: wall-clock MP/s falls
  // when other processes share the cores, CPU seconds much less so.
  state.counters["MP/s_cpu"] = megapixels * state.iterations() * summary.num_threads / std::max(cpu_seconds, 1e-9);
  state.SetLabel(summary.kernel_isa);
  state.counters["threads"] = summary.num_threads;
  state.counters["lights"] = 10;
  state.counters["mean_err_deg"] =
      AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, scene.object).mean;
  state.counters["robust_px"] = static_cast<double>(summary.pixels_by_path[int(SolvePath::kRobust)]);
  state.counters["learned_px"] = static_cast<double>(summary.pixels_by_path[int(SolvePath::kLearned)]);
  // Which light path the pixels took (shared, interpolated, exact), as a fraction of the image.
  const double pixels = double(width) * height;
  state.counters["shared"] = summary.pixels_by_path[int(SolvePath::kSharedLights)] / pixels;
  state.counters["interp"] = summary.pixels_by_path[int(SolvePath::kInterpolatedLights)] / pixels;
  state.counters["exact"] = summary.pixels_by_path[int(SolvePath::kExactLights)] / pixels;
}

// The shared velvet sheen's pass alone (RefineCoherentSheen) on the adaptive
// solve without it, the per-pixel solve outside the timing: what the pass
// costs on a Lambertian scene (its gate should leave nearly every block after
// one look). Reports the pass's CPU seconds per iteration and its counts.
void BM_CoherentSheenPass(benchmark::State& state, Lights lights, int width, int height) {
  const SyntheticScene& scene = Scene(lights, width, height);
  PhotometricSolverInput input;
  input.images = scene.ImagePointers();
  input.light_field = scene.light_field.get();
  PhotometricSolverOptions options;
  options.method = Method::kAdaptive;
  options.adaptive_coherent_sheen = false;
  options.num_threads = static_cast<int>(state.range(0));
  PhotometricSolution solved;
  SolvePhotometricStereo(options, input, &solved);
  solved.coherent_sheen = ImageU8(width, height, 1, uint8_t{0});
  CoherentSheenOptions sheen_options;
  sheen_options.num_threads = options.num_threads;
  CoherentSheenSummary summary;
  PhotometricSolution solution;
  double cpu_seconds = 0;
  for (auto _ : state) {
    state.PauseTiming();
    solution = solved;
    state.ResumeTiming();
    const double cpu_start = ProcessCpuSeconds();
    summary = RefineCoherentSheen(sheen_options, options, input, &solution);
    cpu_seconds += ProcessCpuSeconds() - cpu_start;
    benchmark::DoNotOptimize(summary.pixels_refined);
  }
  state.counters["cpu_s"] = cpu_seconds / std::max<double>(1, state.iterations());
  state.counters["blocks_gated"] = static_cast<double>(summary.blocks_gated);
  state.counters["blocks_passed"] = static_cast<double>(summary.blocks_passed);
  state.counters["groups_tried"] = static_cast<double>(summary.groups_tried);
  state.counters["groups_taken"] = static_cast<double>(summary.groups_taken);
  state.counters["px_refined"] = static_cast<double>(summary.pixels_refined);
  state.counters["mean_err_deg"] =
      AngularErrorDegrees(solution.normal_in_table, scene.normal_in_table, scene.object).mean;
}

#define SCANBENCH_SOLVE_CASE(name, method, lights, width, height, ...) \
  BENCHMARK_CAPTURE(BM_Solve, name, method, lights, width, height)     \
      ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)__VA_ARGS__

// 1 MP, 1 and 2 threads: every method.
SCANBENCH_SOLVE_CASE(1MP_near_adaptive, Method::kAdaptive, Lights::kNearField, 1024, 1024, ->Arg(1)->Arg(2));
SCANBENCH_SOLVE_CASE(1MP_near_jacobi_svd, Method::kJacobiSvd, Lights::kNearField, 1024, 1024, ->Arg(1)->Arg(2));
SCANBENCH_SOLVE_CASE(1MP_near_normal_equations, Method::kNormalEquations, Lights::kNearField, 1024, 1024,
                     ->Arg(1)->Arg(2));
SCANBENCH_SOLVE_CASE(1MP_near_qr, Method::kQr, Lights::kNearField, 1024, 1024, ->Arg(1)->Arg(2));
SCANBENCH_SOLVE_CASE(1MP_near_robust_irls, Method::kRobustIrls, Lights::kNearField, 1024, 1024, ->Arg(1)->Arg(2));
SCANBENCH_SOLVE_CASE(1MP_near_sparse_bayesian, Method::kSparseBayesian, Lights::kNearField, 1024, 1024,
                     ->Arg(1)->Arg(2));
SCANBENCH_SOLVE_CASE(1MP_near_diffuse_lobe, Method::kDiffuseLobe, Lights::kNearField, 1024, 1024, ->Arg(1)->Arg(2));
BENCHMARK_CAPTURE(BM_Solve, 1MP_near_interpolated, Method::kAdaptive, Lights::kNearField, 1024, 1024,
                  AdaptivePasses::kLeastSquares)
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Arg(1)->Arg(2);
SCANBENCH_SOLVE_CASE(1MP_distant_adaptive, Method::kAdaptive, Lights::kDistant, 1024, 1024, ->Arg(1)->Arg(2));
SCANBENCH_SOLVE_CASE(1MP_distant_uniform_pinv, Method::kUniformPseudoInverse, Lights::kDistant, 1024, 1024,
                     ->Arg(1)->Arg(2));
SCANBENCH_SOLVE_CASE(1MP_distant_jacobi_svd, Method::kJacobiSvd, Lights::kDistant, 1024, 1024, ->Arg(1)->Arg(2));

// 16 MP (4928 x 3264, the D5100's full sensor), 10 lights, 2 threads: the target.
SCANBENCH_SOLVE_CASE(16MP_near_adaptive, Method::kAdaptive, Lights::kNearField, 4928, 3264, ->Arg(2));
BENCHMARK_CAPTURE(BM_Solve, 16MP_near_adaptive_irls, Method::kAdaptive, Lights::kNearField, 4928, 3264,
                  AdaptivePasses::kIrls)
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Arg(2);
BENCHMARK_CAPTURE(BM_Solve, 16MP_near_adaptive_no_sheen, Method::kAdaptive, Lights::kNearField, 4928, 3264,
                  AdaptivePasses::kNoSheen)
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Arg(2);
BENCHMARK_CAPTURE(BM_Solve, 16MP_near_adaptive_learned, Method::kAdaptive, Lights::kNearField, 4928, 3264,
                  AdaptivePasses::kWithNetwork)
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Arg(2);
// The interpolated-lights path alone: adaptive's least squares in the near field.
BENCHMARK_CAPTURE(BM_Solve, 16MP_near_interpolated, Method::kAdaptive, Lights::kNearField, 4928, 3264,
                  AdaptivePasses::kLeastSquares, true)
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Arg(2);
BENCHMARK_CAPTURE(BM_CoherentSheenPass, 16MP_near_coherent_sheen_pass, Lights::kNearField, 4928, 3264)
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3)->Arg(2);
SCANBENCH_SOLVE_CASE(16MP_near_jacobi_svd, Method::kJacobiSvd, Lights::kNearField, 4928, 3264, ->Arg(2));
// The exact-lights path (and below, the shared one), cold and warm.
BENCHMARK_CAPTURE(BM_Solve, 16MP_near_normal_equations, Method::kNormalEquations, Lights::kNearField, 4928, 3264,
                  AdaptivePasses::kAll, true)
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Arg(2);
SCANBENCH_SOLVE_CASE(16MP_near_qr, Method::kQr, Lights::kNearField, 4928, 3264, ->Arg(2));
SCANBENCH_SOLVE_CASE(16MP_near_robust_irls, Method::kRobustIrls, Lights::kNearField, 4928, 3264, ->Arg(2));
SCANBENCH_SOLVE_CASE(16MP_distant_adaptive, Method::kAdaptive, Lights::kDistant, 4928, 3264, ->Arg(2));
BENCHMARK_CAPTURE(BM_Solve, 16MP_distant_uniform_pinv, Method::kUniformPseudoInverse, Lights::kDistant, 4928, 3264,
                  AdaptivePasses::kAll, true)
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Arg(2);
SCANBENCH_SOLVE_CASE(16MP_distant_jacobi_svd, Method::kJacobiSvd, Lights::kDistant, 4928, 3264, ->Arg(2));

}  // namespace
}  // namespace scanbench
