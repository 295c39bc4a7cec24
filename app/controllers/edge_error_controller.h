// Measures the seed's "edge error" (its Figure 10) on a session with ground
// truth: the low-frequency tilt of the solved normals that grows toward the
// image borders when the lights are treated as distant and uniform, against
// the same session solved with a calibration set.
//
// Each case is solved over the whole image (sample and table, whose true
// normal is known everywhere); the signed normal error (solved - true, x and
// y) is averaged over blocks, which removes the pixel noise and leaves the
// low-frequency tilt. Figures: its mean in a centre box and in a border band,
// its largest value, and the per-pixel angular error. Images: the tilt per
// block as colour (red = tilted toward +x, cyan toward -x, green/magenta along
// y, mid gray = none), one per case and distant-uniform | calibrated side by side.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"
#include "app/session/calibrated_lighting.h"
#include "calibration/raw_develop.h"
#include "solver/angular_error.h"
#include "solver/photometric_solver.h"

namespace scanbench {

struct EdgeErrorOptions {
  PhotometricSolverOptions solver;
  RawDevelopOptions develop;
  CalibrationUseOptions calibration;
  std::filesystem::path calibration_dir;  // the calibrated case; required
  std::filesystem::path output_dir;       // images and edge_error.json; created (existing files replaced)
  int block_px = 0;                       // side of the averaging blocks, pixels, [0, 4096]; 0 = width / 40
  double border_fraction = 0.1;           // border band: this part of the width / height at each edge, (0, 0.5)
  double centre_fraction = 0.3;           // centre box: this part of the width and height, (0, 1)
  double colour_scale_deg = 10.0;         // tilt that saturates the image colours, degrees, > 0
  bool verify_checksums = true;

  void Check() const;
};

struct EdgeErrorCase {
  std::string name;                  // distant_uniform, distant_uniform_fitted, rig_description, calibrated
  std::string description;
  ErrorStatistics error_deg;         // per-pixel angular error, every solved pixel
  ErrorStatistics sample_error_deg;  // on the sample only
  double centre_tilt_deg = 0;        // mean low-frequency tilt in the centre box
  double border_tilt_deg = 0;        // mean low-frequency tilt in the border band
  double max_tilt_deg = 0;           // largest block tilt
  std::string image;                 // its tilt image in output_dir
};

struct EdgeErrorSummary {
  std::filesystem::path output_dir;
  int block_px = 0;
  std::vector<EdgeErrorCase> cases;
  std::string comparison_image;      // distant_uniform | calibrated

  const EdgeErrorCase* Find(const std::string& name) const;
  std::string FullReport() const;
};

class EdgeErrorController : public BaseController {
 public:
  EdgeErrorController(std::filesystem::path session_dir, EdgeErrorOptions options);
  void Run() override;
  const EdgeErrorSummary& summary() const { return summary_; }

 private:
  struct Inputs;  // the session, its ground truth and developed frames
  Inputs LoadSessionWithTruth() const;
  void DevelopFrames(Inputs* inputs) const;
  // Solves with `field`, measures the case into summary_.cases, writes its
  // tilt image and returns it.
  ImageU8 MeasureCase(const Inputs& inputs, const std::string& name, const std::string& description,
                      const LightField& field);

  std::filesystem::path session_dir_;
  EdgeErrorOptions options_;
  EdgeErrorSummary summary_;
};

}  // namespace scanbench
