// Calibration targets rendered on the simulated rig for the calibration tests:
// the rig's TRUE parameters render them, the code under test never sees those.
#pragma once

#include <optional>
#include <vector>

#include "app/sim/target_renderer.h"
#include "calibration/raw_develop.h"

namespace scanbench::testing {

// Half the default capture each way: 0.23 mm per pixel, fast.
inline constexpr int kCalibrationTestWidth = 616;
inline constexpr int kCalibrationTestHeight = 408;

inline SimulatedRigOptions CalibrationTestSensor(uint64_t seed = 77) {
  SimulatedRigOptions options;
  options.width = kCalibrationTestWidth;
  options.height = kCalibrationTestHeight;
  options.seed = seed;
  return options;
}

// The RAW frames of one target: a dark frame and one per LED.
struct TargetFrames {
  RawImage dark;
  std::vector<RawImage> leds;
};

inline TargetFrames RenderTargetFrames(const TargetRenderer& renderer, const SimulatedTarget& target,
                                       uint64_t first_frame_index, const TargetRenderOptions& render = {}) {
  const PreparedTarget prepared = renderer.Prepare(target, render);
  TargetFrames frames;
  frames.dark = renderer.RenderFrame(prepared, {}, first_frame_index, render);
  for (int k = 0; k < renderer.num_leds(); ++k) {
    frames.leds.push_back(renderer.RenderFrame(prepared, {k}, first_frame_index + 1 + k, render));
  }
  return frames;
}

}  // namespace scanbench::testing
