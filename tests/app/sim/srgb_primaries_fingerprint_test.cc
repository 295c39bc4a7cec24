// The old sRGB-primaries camera must render exactly what it rendered before
// the spectral camera came (issue #12): fingerprints of its frames, measured
// on the code before that change.
#include <cstdint>
#include <cstdio>

#include <gtest/gtest.h>

#include "app/sim/simulated_rig.h"
#include "app/sim/target_renderer.h"

namespace scanbench {
namespace {

uint64_t Fnv1a(const void* data, size_t bytes, uint64_t hash = 0xcbf29ce484222325ULL) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < bytes; ++i) hash = (hash ^ p[i]) * 0x100000001b3ULL;
  return hash;
}

SimulatedRigOptions Sensor() {
  SimulatedRigOptions options;
  options.width = kD5100Width / 16;
  options.height = kD5100Height / 16;
  return options;
}

TEST(SrgbPrimariesFingerprint, ScanFramesAndTruth) {
  const SimulatedRigOptions options = Sensor();
  const SimulatedRig rig(options, TextileScene(), MakeDefaultSimulatedRig(options.width, options.height));
  uint64_t hash = 0xcbf29ce484222325ULL;
  for (const std::optional<int> led : {std::optional<int>(), std::optional<int>(0), std::optional<int>(7)}) {
    const RawImage raw = rig.RenderFrame(led, 3);
    hash = Fnv1a(raw.mosaic.data(), raw.mosaic.size() * sizeof(uint16_t), hash);
  }
  const GroundTruthMaps truth = rig.RenderGroundTruth();
  hash = Fnv1a(truth.albedo.data(), truth.albedo.size() * sizeof(float), hash);
  std::printf("scan fingerprint %016llx\n", static_cast<unsigned long long>(hash));
}

TEST(SrgbPrimariesFingerprint, TargetFrames) {
  const SimulatedRigOptions options = Sensor();
  const TargetRenderer renderer(options, MakeDefaultSimulatedRig(options.width, options.height));
  uint64_t hash = 0xcbf29ce484222325ULL;
  for (const SimulatedTarget& target :
       {SimulatedTarget::GrayChart(GrayChartTarget::MunsellNeutralScale()), SimulatedTarget::WhiteSheet({})}) {
    const RawImage raw = renderer.RenderFrame(target, 2, 5);
    hash = Fnv1a(raw.mosaic.data(), raw.mosaic.size() * sizeof(uint16_t), hash);
  }
  std::printf("target fingerprint %016llx\n", static_cast<unsigned long long>(hash));
}

}  // namespace
}  // namespace scanbench
