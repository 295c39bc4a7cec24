// Sensor linearity and white balance from a matte neutral gray chart (the
// Munsell neutral value scale) lying flat on the table, measured on the raw
// Bayer samples per CFA colour, once per LED: the seed keeps one white-balance
// profile per light.
//
// Per LED and colour c, a patch of reflectance rho at table (x, y) reads
//   v_c = s_c * rho^gamma_c * E(x, y) * (1 + a x + b y)
// where E is the irradiance the LED's (uncalibrated) description predicts
// across the small chart and (1 + a x + b y) absorbs its error (both the same
// for every colour). gamma_c = 1 is a linear sensor; the gains
// that make a neutral patch read alike in every colour are s_G / s_c. Patches
// that clip, are underexposed or leave the linear fit by more than a tolerance
// are flagged and left out; the linear range is the span of levels the
// remaining patches cover.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/progress.h"
#include "core/summary.h"
#include "calibration/calibration_targets.h"
#include "calibration/raw_image.h"
#include "calibration/rig.h"

namespace scanbench {

struct WhiteBalanceOptions {
  // Part of the patch side left out at each edge, [0, 0.45]: keeps the
  // measurement inside the patch despite registration error and blur.
  double patch_inset = 0.2;
  // A raw sample at or above this fraction of the white level is clipped, (0, 1].
  double clip_fraction = 0.98;
  // A patch whose mean (fraction of the raw range) is below this in any
  // colour is underexposed: noise and black-level error dominate, [0, 1).
  double min_level = 0.01;
  // Relative deviation from the linear fit beyond which a patch lies outside
  // the sensor's linear range, (0, 1).
  double linearity_tolerance = 0.01;
  // Samples needed per patch and colour, >= 1.
  int min_samples = 30;

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

struct PatchMeasurement {
  std::string name;
  double reflectance = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();            // per colour, fraction of the raw range
  Eigen::Vector3d standard_error = Eigen::Vector3d::Zero();  // of the mean
  std::array<int, 3> samples{};                              // per colour
  bool clipped = false;       // some sample reached the clip level
  bool underexposed = false;  // some colour's mean below min_level
  bool nonlinear = false;     // leaves the linear fit by more than linearity_tolerance
  bool used = false;          // in the gains and the linear fit
  Eigen::Vector3d linear_residual = Eigen::Vector3d::Zero();  // relative deviation from the linear fit
};

struct LedWhiteBalance {
  int led_index = 0;
  // Multiply raw colour c by gains[c] to make a neutral surface read alike in
  // every colour; gains[1] (green) = 1.
  Eigen::Vector3d gains = Eigen::Vector3d::Ones();
  Eigen::Vector3d gains_std = Eigen::Vector3d::Zero();       // one standard deviation
  Eigen::Vector3d response_exponent = Eigen::Vector3d::Ones();  // fitted gamma_c; 1 = linear
  Eigen::Vector3d linearity_rms = Eigen::Vector3d::Zero();   // rms relative residual of the used patches
  double linear_range_min = 0;   // lowest and highest used patch level (fraction of the raw range,
  double linear_range_max = 0;   // over all colours): the range shown linear
  int used_patches = 0;
  std::vector<PatchMeasurement> patches;  // in chart order
};

struct WhiteBalanceSummary : AlgorithmSummary {
  std::vector<LedWhiteBalance> leds;  // in the order of the frames given

  std::string BriefReport() const;
};

// `led_frames[k]`: the chart lit by LED k alone; `dark`: all LEDs off, same
// exposure. `camera`: the calibrated camera (to find the patches). `leds`:
// the LED descriptions (one per frame; measured positions are good enough) for
// the shape of the irradiance over the chart, or empty for a plain gradient.
// The gains are figures of the summary (the calibration set stores it as it
// is). Throws std::invalid_argument for bad options, chart or frames that do
// not fit together; returns Termination::kFailure (naming the LED and patch)
// when a LED leaves fewer than 3 usable patches of 2 reflectances, and
// Termination::kCancelled when the progress callback (called after each LED)
// asks to stop.
WhiteBalanceSummary CalibrateWhiteBalance(const WhiteBalanceOptions& options, const GrayChartTarget& chart,
                                          const CameraGeometry& camera, const std::vector<LedDescription>& leds,
                                          const RawImage& dark, const std::vector<RawImage>& led_frames,
                                          const ProgressCallback& progress = {});

}  // namespace scanbench
