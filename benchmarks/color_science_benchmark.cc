// CIEDE2000 per pixel, as the solve's evaluation computes it (the solved
// albedo against the simulated truth, both linear Rec.709): millions of
// colour pairs per second, the published formula (LabFromLinearRec709 and
// Ciede2000) against Ciede2000FromLinearRec709 (calibration/color_science.h),
// and the CIEDE2000 step alone on L*a*b* pairs.
//
//   build/benchmarks/color_science_benchmark
//
// Figures, not pass/fail; one thread. The pairs are a fixed random set of
// albedos in [0, 1.2] and a solved value a few percent off each, the way a
// solve misses its truth.
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "calibration/color_science.h"

namespace scanbench {
namespace {

constexpr int kPairs = 1 << 16;

struct Pairs {
  std::vector<Eigen::Vector3d> truth, solved;          // linear Rec.709
  std::vector<Eigen::Vector3d> truth_lab, solved_lab;  // their L*a*b* (D65)
};

const Pairs& TestPairs() {
  static const Pairs pairs = [] {
    Pairs p;
    std::mt19937_64 rng(14);
    std::uniform_real_distribution<double> albedo(0, 1.2), off(0.95, 1.05);
    for (int i = 0; i < kPairs; ++i) {
      const Eigen::Vector3d truth(albedo(rng), albedo(rng), albedo(rng));
      const Eigen::Vector3d solved(truth.x() * off(rng), truth.y() * off(rng), truth.z() * off(rng));
      p.truth.push_back(truth);
      p.solved.push_back(solved);
      p.truth_lab.push_back(LabFromLinearRec709(truth));
      p.solved_lab.push_back(LabFromLinearRec709(solved));
    }
    return p;
  }();
  return pairs;
}

void SetPairRate(benchmark::State& state) {
  state.counters["Mpairs/s"] = benchmark::Counter(1e-6 * kPairs * state.iterations(), benchmark::Counter::kIsRate);
}

void BM_Ciede2000OfLinearRec709_Reference(benchmark::State& state) {
  const Pairs& p = TestPairs();
  for (auto _ : state) {
    double sum = 0;
    for (int i = 0; i < kPairs; ++i) {
      sum += Ciede2000(LabFromLinearRec709(p.solved[i]), LabFromLinearRec709(p.truth[i]));
    }
    benchmark::DoNotOptimize(sum);
  }
  SetPairRate(state);
}
BENCHMARK(BM_Ciede2000OfLinearRec709_Reference);

void BM_Ciede2000OfLinearRec709_Fast(benchmark::State& state) {
  const Pairs& p = TestPairs();
  for (auto _ : state) {
    double sum = 0;
    for (int i = 0; i < kPairs; ++i) sum += Ciede2000FromLinearRec709(p.solved[i], p.truth[i]);
    benchmark::DoNotOptimize(sum);
  }
  SetPairRate(state);
}
BENCHMARK(BM_Ciede2000OfLinearRec709_Fast);

// The many-pairs form on float colours (the solve's evaluation's call): the
// colour kernels of the ISA the solver's dispatch picks (SCANBENCH_SOLVER_ISA
// caps it), within 1e-5 of the published formula.
void BM_Ciede2000OfLinearRec709_ManyPairs(benchmark::State& state) {
  const Pairs& p = TestPairs();
  std::vector<float> solved(3 * kPairs), truth(3 * kPairs);
  for (int i = 0; i < kPairs; ++i) {
    for (int c = 0; c < 3; ++c) {
      solved[3 * i + c] = static_cast<float>(p.solved[i][c]);
      truth[3 * i + c] = static_cast<float>(p.truth[i][c]);
    }
  }
  std::vector<double> delta_e(kPairs);
  for (auto _ : state) {
    Ciede2000FromLinearRec709(solved.data(), truth.data(), kPairs, delta_e.data());
    benchmark::DoNotOptimize(delta_e.data());
  }
  SetPairRate(state);
}
BENCHMARK(BM_Ciede2000OfLinearRec709_ManyPairs);

void BM_Ciede2000OfLab_Reference(benchmark::State& state) {
  const Pairs& p = TestPairs();
  for (auto _ : state) {
    double sum = 0;
    for (int i = 0; i < kPairs; ++i) sum += Ciede2000(p.solved_lab[i], p.truth_lab[i]);
    benchmark::DoNotOptimize(sum);
  }
  SetPairRate(state);
}
BENCHMARK(BM_Ciede2000OfLab_Reference);

void BM_Ciede2000OfLab_Fast(benchmark::State& state) {
  const Pairs& p = TestPairs();
  for (auto _ : state) {
    double sum = 0;
    for (int i = 0; i < kPairs; ++i) sum += FastCiede2000(p.solved_lab[i], p.truth_lab[i]);
    benchmark::DoNotOptimize(sum);
  }
  SetPairRate(state);
}
BENCHMARK(BM_Ciede2000OfLab_Fast);

void BM_LabOfLinearRec709_Reference(benchmark::State& state) {
  const Pairs& p = TestPairs();
  for (auto _ : state) {
    double sum = 0;
    for (int i = 0; i < kPairs; ++i) sum += LabFromLinearRec709(p.truth[i]).sum();
    benchmark::DoNotOptimize(sum);
  }
  SetPairRate(state);
}
BENCHMARK(BM_LabOfLinearRec709_Reference);

void BM_LabOfLinearRec709_Fast(benchmark::State& state) {
  const Pairs& p = TestPairs();
  for (auto _ : state) {
    double sum = 0;
    for (int i = 0; i < kPairs; ++i) sum += FastLabFromLinearRec709(p.truth[i]).sum();
    benchmark::DoNotOptimize(sum);
  }
  SetPairRate(state);
}
BENCHMARK(BM_LabOfLinearRec709_Fast);

}  // namespace
}  // namespace scanbench

BENCHMARK_MAIN();
