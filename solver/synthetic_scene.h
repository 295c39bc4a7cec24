// Analytic photometric-stereo scenes with exact ground truth, for tests and
// benchmarks (no sensor, no optics: see app/sim for the physical rig).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "solver/light_field.h"

namespace scanbench {

struct SyntheticSceneOptions {
  enum class Shape {
    kSphere,       // hemisphere filling most of the image, table around it
    kTiltedPlane,  // one plane tilted by tilt_degrees about the x axis
  };
  enum class Lights {
    kDistant,    // same direction and intensity everywhere
    kNearField,  // point LEDs at light_distance over a plane with pixel_pitch
  };
  Shape shape = Shape::kSphere;
  Lights lights = Lights::kDistant;
  int width = 128;                  // pixels, >= 8
  int height = 128;                 // pixels, >= 8
  int num_lights = 10;              // >= 3; spread over two rings
  double min_elevation_deg = 30;    // elevation of the low ring, (0, 90)
  double max_elevation_deg = 60;    // elevation of the high ring, [min, 90)
  double tilt_degrees = 20;         // plane tilt, [0, 80)
  Eigen::Vector3d albedo = {0.6, 0.45, 0.3};  // RGB, each in [0, 1]
  double light_distance = 500;      // near field: LED distance from the centre, pixel_pitch units
  double pixel_pitch = 0.1;         // near field: table units per pixel, > 0
  double noise_stddev = 0;          // additive Gaussian noise per sample, >= 0
  // Specular sheen (Blinn-Phong, white, viewer along +z): adds
  // specular * (n . h)^shininess * light intensity to every channel, [0, 10].
  double specular = 0;
  double shininess = 40;            // Blinn-Phong exponent, [1, 10000]
  uint64_t seed = 1;

  void Check() const;
};

struct SyntheticScene {
  std::vector<ImageF> images;         // one RGB image per light
  std::unique_ptr<LightField> light_field;
  ImageF normal_in_table;             // ground truth, unit
  ImageF albedo;                      // ground truth, RGB
  ImageU8 fully_lit;                  // 1 where every light has n . l > 0
  ImageU8 object;                     // 1 on the object (sphere), all ones for the plane

  std::vector<const ImageF*> ImagePointers() const;
};

SyntheticScene MakeSyntheticScene(const SyntheticSceneOptions& options);

// Light directions (unit, z up) on two rings like the simulated rig's LEDs:
// the first ceil(num_lights / 2) at the low elevation, the rest at the high
// one, each ring evenly spread in azimuth, the upper one turned half a step,
// the first light at `azimuth_deg`.
std::vector<Eigen::Vector3d> RingLightDirections(int num_lights, double low_elevation_deg,
                                                 double high_elevation_deg, double azimuth_deg = 0);

}  // namespace scanbench
