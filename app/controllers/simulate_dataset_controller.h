// Near-field test folders from the simulated rig (issue #33, item 5): a
// textile on the table (by default a draped LAMBERTIAN twill with cast
// shadows) lit by the rig's point LEDs, written as a LUCES-style folder that
// `solve-dataset` reads (the layout of app/io/dataset_io.h):
//   NN.png (16-bit RGB, one per LED), filenames.txt, light_positions.txt and
//   light_directions.txt (the LEDs and their axes, mm, OpenCV camera frame),
//   light_intensities.txt (the reading of a white patch facing the LED at
//   1 mm), light_mu.txt (one falloff exponent per LED), K.txt,
//   mean_distance.txt, mask.png (the sample) and Normal_gt.mat (solver frame).
// The rig is the default simulated bench (MakeDefaultSimulatedRig) with the
// lens distortion set to zero, since the layout's camera is a pinhole K.
#pragma once

#include <filesystem>
#include <string>

#include "app/controllers/base_controller.h"
#include "app/sim/simulated_rig.h"
#include "app/sim/textile_scene.h"
#include "calibration/raw_develop.h"

namespace scanbench {

struct SimulateDatasetOptions {
  // Sensor, size, noise, cast shadows, seed. The ambient light is in every
  // RAW frame and the dark frame, which is subtracted; the linear path
  // renders without it.
  SimulatedRigOptions rig;
  TextileSceneOptions scene;  // fold_amplitude_mm: the folds lift the cloth by 0 .. 2x it (+-fold_amplitude_mm)
  // true: each frame rendered as RAW (shot and read noise) with a dark
  // frame and developed as `scanbench solve` develops it (dark subtracted,
  // demosaiced: what a camera's 16-bit output is); false: the noise-free
  // linear render of every colour at every pixel (no demosaicing).
  bool raw_path = true;
  RawDevelopOptions develop;
  bool overwrite = false;     // replace an existing folder

  SimulateDatasetOptions();   // rig and scene as `simulate`'s, at 320x240
  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

struct SimulateDatasetSummary {
  std::filesystem::path folder;
  int width = 0, height = 0, num_lights = 0;
  size_t mask_pixels = 0;
  double mean_distance_mm = 0;     // what mean_distance.txt holds
  double table_distance_mm = 0;    // camera to the table along the optical axis
  double max_height_mm = 0;        // highest surface point on the mask
  double seconds = 0;
  std::string BriefReport() const;
};

// What mean_distance.txt holds: as in LUCES, the mean distance of the
// object from the camera, here the mean camera-frame z of the true surface
// points on the mask (so the first pass's plane is the one that fits the
// sample best, and a solve's depth refinement anchors its height there).
class SimulateDatasetController : public BaseController {
 public:
  SimulateDatasetController(std::filesystem::path folder, SimulateDatasetOptions options);
  void Run() override;
  const SimulateDatasetSummary& summary() const { return summary_; }

 private:
  std::filesystem::path folder_;
  SimulateDatasetOptions options_;
  SimulateDatasetSummary summary_;
};

// The rig the folders are rendered with: MakeDefaultSimulatedRig(width,
// height, color) without lens distortion.
RigDescription SimulatedDatasetRig(int width, int height, SensorColorModel color);

}  // namespace scanbench
