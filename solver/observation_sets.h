// Per-pixel observation sets: what the photometric solver reads at one pixel
// (believed light directions and intensity-divided samples), with the true
// normal. The learned solver's training data (rendered by
// app/sim/observation_sets.h, written by app/io/observation_set_io.h) and its
// test vectors. Every direction is in the pixel's VIEW frame (view = +z).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace scanbench {

// Where a set's lights come from.
enum class LightSetKind : int32_t {
  kHemisphere = 0,  // distant, uniform over a cap of the hemisphere
  kRings = 1,       // distant, one to three rings (the rig's layout, DiLiGenT ring subsets)
  kGrid = 2,        // distant, a square grid of positions on a plane above (DiLiGenT's light array)
  kNearField = 3,   // the scanner: point LEDs on rings at a finite distance, per-pixel direction and falloff
};

// The sets as structure-of-arrays: set s has lights [offset[s], offset[s + 1]).
struct ObservationSets {
  std::vector<int64_t> offset{0};              // size num_sets + 1
  std::vector<Eigen::Vector3f> normal;         // true unit normal, view frame
  std::vector<float> albedo;                   // the diffuse albedo, the scale a normal solve cannot see
  std::vector<int32_t> light_set_kind;         // LightSetKind
  std::vector<int32_t> material_flags;         // bits: 0 specular, 1 anisotropic, 2 metal, 3 sheen, 4 Burley
                                               // diffuse, 5 cast shadow, 6 inter-reflection, 7 two-normal footprint
  std::vector<Eigen::Vector3f> light_dir;      // the lights' believed unit directions, view frame
  std::vector<float> value;                    // the sample divided by the believed intensity

  int num_sets() const { return static_cast<int>(normal.size()); }
  int NumLights(int set) const { return static_cast<int>(offset[set + 1] - offset[set]); }
};

}  // namespace scanbench
