// The learned solver's forward pass (solver/normal_network.h): pixels per
// second at the rig's 10 lights, 20 and DiLiGenT's 96, on each supported ISA,
// one thread (the solver runs one pass per tile on each pool thread).
#include <cmath>
#include <random>

#include <benchmark/benchmark.h>

#include "solver/normal_network.h"

namespace scanbench {
namespace {

NormalNetworkInput RandomPixels(int pixels, int lights) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  NormalNetworkInput input;
  for (int p = 0; p < pixels; ++p) {
    for (int k = 0; k < lights; ++k) {
      const float z = 0.3f + 0.7f * u(rng), phi = 6.2831853f * u(rng), r = std::sqrt(1 - z * z);
      const float light[3] = {r * std::cos(phi), r * std::sin(phi), z};
      input.AddToken(light, u(rng));
    }
    input.EndPixel();
  }
  return input;
}

void BM_NormalNetwork(benchmark::State& state) {
  const int lights = static_cast<int>(state.range(0));
  const KernelIsa isa = static_cast<KernelIsa>(state.range(1));
  if (!KernelIsaSupported(isa)) {
    state.SkipWithError("ISA not supported here");
    return;
  }
  const int pixels = 2048;
  const NormalNetworkInput input = RandomPixels(pixels, lights);
  const NormalNetwork& net = NormalNetwork::Embedded();
  std::vector<NormalNetworkOutput> out;
  for (auto _ : state) {
    net.Predict(input, &out, isa);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * pixels);
  state.SetLabel(std::string(net.kind()) + " " + KernelIsaName(isa));
}
BENCHMARK(BM_NormalNetwork)
    ->ArgsProduct({{10, 20, 96}, {static_cast<int>(KernelIsa::kBaseline), static_cast<int>(KernelIsa::kAvx2),
                                  static_cast<int>(KernelIsa::kAvx512)}})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace scanbench

BENCHMARK_MAIN();
