// Per-pixel training observations for the learned photometric solver (issue
// #33), rendered by the simulator's shading models (app/sim/shading_models.h):
// for each set a true normal, a material, a light set and what the solver would
// read at that pixel, never images. Deterministic from the seed: set i is a pure
// function of (seed, i), whatever the thread count.
//
// Everything is in the pixel's VIEW frame (the view direction is +z): the
// learned solver rotates each pixel's lights into that frame before it asks
// the network, so one network serves the orthographic DiLiGenT camera and the
// rig's perspective one.
//
// What a set holds is what the solver is handed: the light directions it
// BELIEVES (nominal, with the calibration's errors left in the truth, not in
// them) and the samples divided by the intensities it believes, after the
// sensor (shot and read noise, quantisation, clipping) has had its way. Clipped
// samples are left out, as the solver leaves them out, so sets differ in size.
#pragma once

#include <cstdint>
#include <string>

#include "core/progress.h"
#include "core/summary.h"
#include "solver/observation_sets.h"

namespace scanbench {

struct ObservationSetOptions {
  uint64_t seed = 1;          // every random choice is a function of (seed, set index)
  int num_sets = 100000;      // sets to render, [1, 100000000]
  int min_lights = 6;         // lights per distant set, [3, max_lights]
  int max_lights = 100;       // [min_lights, 256]
  double near_field_share = 0.25;  // share of sets lit by the near-field LED rig, [0, 1]
  double specular_share = 0.6;     // share with a GGX lobe (isotropic, anisotropic or metal), [0, 1]
  double sheen_share = 0.35;       // share with a sheen (velvet, Charlie or fuzz), [0, 1]
  double shadow_share = 0.35;      // share with a cast-shadow horizon, [0, 1]
  int num_threads = 0;             // 0 = all cores
  ProgressCallback progress;       // fraction done; false stops

  void Check() const;
};

struct ObservationSetSummary : AlgorithmSummary {
  int num_sets = 0;
  int64_t num_samples = 0;        // lights kept over all sets
  int64_t num_clipped = 0;        // samples left out as clipped
  double seconds = 0;
  std::string BriefReport() const;
};

ObservationSetSummary GenerateObservationSets(const ObservationSetOptions& options, ObservationSets* sets);

}  // namespace scanbench
