// The seed's bench as a rig description to start from (`scanbench bench
// init`, data/bench/): a camera looking straight down at the table centre,
// LEDs on rings around it, each aimed at the centre. Every number is a
// nominal value; BenchFieldsToMeasure lists what the builder measures or
// calibrates before the first real scan (docs/bench.md).
#pragma once

#include <string>
#include <vector>

#include "calibration/rig.h"

namespace scanbench {

struct BenchTemplateOptions {
  std::string name = "scanbench bench: D5100 + 85 mm, 10 x Luxeon Rebel white";
  int num_leds = 10;                              // [1, 10]: the firmware drives 10 channels
  // One ring per entry, LEDs dealt round-robin over them (LED k on ring k % rings),
  // evenly spread in azimuth within a ring, each ring turned by half a step
  // against the previous one. Defaults: 30 and 60 deg elevation at 500 mm.
  std::vector<double> ring_radii_mm = {433, 250};    // horizontal distance from the sample centre, > 0
  std::vector<double> ring_heights_mm = {250, 433};  // above the table top, > 0; one per ring radius
  std::string camera = "d5100";                   // the camera preset ("d5100": 4928 x 3264, 23.6 x 15.6 mm)
  double lens_focal_mm = 85;                      // (0, 1000]
  double camera_height_mm = 600;                  // sensor-to-table distance along the optical axis, > focal length
  double mu = 1;                                  // LED angular falloff cos^mu, >= 0 (a Lambertian emitter: 1)

  void Check() const;
};

// Throws FieldError (via Check) for bad options.
RigDescription MakeBenchTemplate(const BenchTemplateOptions& options);

// What the builder must measure (or calibrate) for `rig`, one line per field
// (JSON path, then how): "leds[0..9].position_in_table_mm: ...".
std::vector<std::string> BenchFieldsToMeasure(const RigDescription& rig);

}  // namespace scanbench
