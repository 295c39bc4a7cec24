// Light calibration from a flat white target: what each LED delivers at every
// pixel, two ways.
//
//  * Per-pixel field (the seed's procedure): start from the measured LED
//    positions; the white sheet gives each LED's intensity at every pixel
//    (raw samples averaged per CFA colour over small cells, cells that stand
//    out from their neighbours dropped: paper fibres, dust); dividing by the
//    Lambert factor of the current direction gives the intensity map; the LED
//    position that best explains those maps gives new directions; repeat
//    until directions and intensities stop changing. The result keeps the
//    measured intensity map as it is (any emission pattern) with directions
//    from the converged position. Sheets at two heights (on the table and on a
//    spacer) pin the distance down: on one plane, distance, aim and falloff
//    trade off against each other.
//  * Parametric model: position, axis, anisotropy mu and RGB intensity per
//    LED (calibration/rig.h's model) fitted to the same samples by
//    Levenberg-Marquardt (Eigen), with parameter uncertainties.
//
// Both are scored against the noise of the measurement; the model is chosen
// when its residual is within noise (compact, and it extrapolates to any
// height), the per-pixel field otherwise (the LEDs do not follow the model).
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/progress.h"
#include "core/summary.h"
#include "calibration/calibration_targets.h"
#include "calibration/raw_image.h"
#include "calibration/rig.h"
#include "calibration/sampled_light_field.h"

namespace scanbench {

// One placement of the white sheet: a dark frame and one frame per LED.
struct WhiteSheetCapture {
  std::string name;                           // for messages (e.g. the session folder)
  WhiteSheetTarget sheet;                     // reflectance and height above the table
  const RawImage* dark = nullptr;
  std::vector<const RawImage*> led_frames;    // one per LED, in the order of the LEDs
};

struct LightCalibrationOptions {
  // Side of the square cells the raw samples are averaged over, even pixels,
  // [2, 512]; 0 = about width / 64. Also the node spacing of the per-pixel field.
  int cell_px = 0;
  // A raw sample at or above this fraction of the white level is clipped;
  // cells holding one are not used, (0, 1].
  double clip_fraction = 0.98;
  // Cells darker than this in some colour (fraction of the raw range) are
  // not used, [0, 1).
  double min_level = 0.002;
  // Cells further than this many standard errors from the median of their
  // 3x3 neighbourhood are dropped (dust, creases), > 0.
  double outlier_sigma = 6.0;
  // Per-pixel procedure: iteration limit, [1, 1000], and convergence: the
  // largest change of any direction (degrees) and intensity (relative) from
  // one iteration to the next.
  int max_iterations = 60;
  double direction_tolerance_deg = 1e-4;  // > 0
  double intensity_tolerance = 1e-5;      // > 0
  // Smooth the per-pixel intensity maps with a 3x3 binomial filter over the
  // cells (filters what the cell averages leave of the paper's texture).
  bool smooth_intensity = true;
  // Levenberg-Marquardt: function evaluations per fit, [10, 1e6].
  int max_fit_evaluations = 4000;
  // The model is selected when its residual RMS is at most this many times
  // the noise RMS of the cells, >= 1.
  double model_noise_factor = 2.0;

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

struct LedModelFit {
  bool usable = false;                    // the fit converged to valid parameters
  LedDescription led;                     // fitted position, axis, mu, rgb_intensity (id copied)
  Eigen::Vector3d position_std_mm = Eigen::Vector3d::Zero();  // one standard deviation
  double axis_std_deg = 0;
  double mu_std = 0;
  Eigen::Vector3d intensity_std = Eigen::Vector3d::Zero();    // relative
  double residual_rms = 0;   // relative (log) residual RMS over the cells
  double noise_rms = 0;      // relative noise RMS of the cells (from their standard errors)
  double chi = 0;            // RMS of residual / noise: 1 = within noise
  int evaluations = 0;       // function evaluations of Levenberg-Marquardt
  std::string termination;   // Levenberg-Marquardt's reason to stop
};

struct LedPerPixelFit {
  int iterations = 0;
  bool converged = false;
  std::vector<double> direction_change_deg;  // per iteration: largest change of any cell's direction
  std::vector<double> intensity_change;      // per iteration: largest relative change of any cell's intensity
  Eigen::Vector3d position_in_table_mm = Eigen::Vector3d::Zero();  // converged position
  double residual_rms = 0;   // relative residual of the position fit to the intensity maps
  int cells_used = 0;        // on the table sheet
  int cells_dropped = 0;     // clipped, dark or outliers, filled from the model
};

struct LightCalibrationSummary : AlgorithmSummary {
  enum class Choice { kModel, kPerPixel };
  int cell_px = 0;
  std::vector<LedModelFit> model;          // per LED
  std::vector<LedPerPixelFit> per_pixel;   // per LED
  // Measured light at every pixel's table point (z = 0), on the cell grid.
  std::optional<SampledLightField> per_pixel_field;
  Choice selected = Choice::kModel;
  std::string selection_reason;
  std::vector<std::string> warnings;

  // The LEDs as the model fitted them, in order.
  std::vector<LedDescription> ModelLeds() const;
  std::string BriefReport() const;
};

// `camera`: the calibrated camera. `measured_leds`: the starting point (tape-
// measured positions; axis, mu and intensity may be nominal). `sheets`: at
// least one on the table (height 0: the per-pixel field lives there); a second
// at another height is strongly advised. Both products (the fitted LEDs and
// the per-pixel field) are figures of the summary, which the calibration set
// stores as it is. Throws std::invalid_argument for bad options or inputs
// that do not fit together; returns Termination::kFailure (with the reason)
// when the data cannot be fitted, Termination::kCancelled when the progress
// callback asks to stop.
LightCalibrationSummary CalibrateLights(const LightCalibrationOptions& options, const CameraGeometry& camera,
                                        const std::vector<LedDescription>& measured_leds,
                                        const std::vector<WhiteSheetCapture>& sheets,
                                        const ProgressCallback& progress = {});

}  // namespace scanbench
