// The old sRGB-primaries camera must render exactly what it rendered before
// the spectral camera came (issue #12): FNV-1a fingerprints of its frames and
// ground truth, measured on the code before that change (commit 6e1f54f).
#include <cstdint>

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
  options.color = SensorColorModel::kSrgbPrimaries;
  options.width = kD5100Width / 16;
  options.height = kD5100Height / 16;
  return options;
}

TEST(SrgbPrimariesFingerprint, ScanFramesAndTruth) {
  const SimulatedRigOptions options = Sensor();
  const SimulatedRig rig(options, TextileScene(), MakeDefaultSimulatedRig(options.width, options.height, options.color));
  uint64_t hash = 0xcbf29ce484222325ULL;
  for (const std::optional<int> led : {std::optional<int>(), std::optional<int>(0), std::optional<int>(7)}) {
    const RawImage raw = rig.RenderFrame(led, 3);
    hash = Fnv1a(raw.mosaic.data(), raw.mosaic.size() * sizeof(uint16_t), hash);
  }
  const GroundTruthMaps truth = rig.RenderGroundTruth();
  hash = Fnv1a(truth.albedo.data(), truth.albedo.size() * sizeof(float), hash);
  EXPECT_EQ(hash, 0x62840f32182d2105ULL) << std::hex << hash;
}

TEST(SrgbPrimariesFingerprint, TargetFrames) {
  const SimulatedRigOptions options = Sensor();
  const TargetRenderer renderer(options, MakeDefaultSimulatedRig(options.width, options.height, options.color));
  uint64_t hash = 0xcbf29ce484222325ULL;
  for (const SimulatedTarget& target :
       {SimulatedTarget::GrayChart(GrayChartTarget::MunsellNeutralScale()), SimulatedTarget::WhiteSheet({})}) {
    const RawImage raw = renderer.RenderFrame(target, 2, 5);
    hash = Fnv1a(raw.mosaic.data(), raw.mosaic.size() * sizeof(uint16_t), hash);
  }
  EXPECT_EQ(hash, 0x76b3e5da79819dc4ULL) << std::hex << hash;
}

}  // namespace
}  // namespace scanbench
