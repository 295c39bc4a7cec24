// The simulated camera's colour (issue #12): how a surface reflectance becomes
// the sensor's white-balanced camera RGB under the rig's LEDs, and the colour
// data its DNG files carry, for each SensorColorModel.
//
// kNikonD5100: spectral. Camera response per channel c of a reflectance R is
// sum_l S_c(l) E(l) R(l) with S the measured Nikon D5100 sensitivities
// (Darrodi et al. 2015) and E the CIE LED-B5 white LED (6598 K, not D65), over
// the perfect white's response: the camera is not colorimetric, its RGB is no
// linear map of the XYZ of every spectrum. kSrgbPrimaries: camera RGB is
// linear Rec.709 under D65 (the simulated camera before issue #12).
#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>

#include "app/sim/simulated_rig.h"
#include "calibration/spectra.h"

namespace scanbench {

// "d5100", "srgb-primaries" (the CLI's --camera-color names).
const char* SensorColorModelName(SensorColorModel model);
std::optional<SensorColorModel> SensorColorModelFromName(const std::string& name);

struct SensorColor {
  SensorColorModel model = SensorColorModel::kNikonD5100;
  // White-balanced camera RGB = camera_from_linear_rec709 * rgb of the Mallett
  // 2019 upsampling of linear Rec.709 `rgb` (exact: the upsampling is linear in
  // rgb, the camera linear in the spectrum). Identity for kSrgbPrimaries.
  Eigen::Matrix3d camera_from_linear_rec709 = Eigen::Matrix3d::Identity();
  // The LED white's raw response per channel relative to green: the LEDs'
  // rgb_intensity ratios (kSrgbPrimaries: the old fixed 0.48, 1, 0.70).
  Eigen::Vector3d raw_white_relative_to_green = Eigen::Vector3d::Ones();
  // DNG ColorMatrix1 (CalibrationIlluminant1 = D65): XYZ (Y of white = 1) to
  // camera native (not white-balanced) RGB, least squares over smooth training
  // reflectances (never the ColorChecker) with the white preserved, scaled so
  // the D65 white maps to a neutral whose largest component is 1 (DNG 1.4).
  // kSrgbPrimaries: the old camera's matrix, linear Rec.709 from XYZ.
  Eigen::Matrix3d camera_from_xyz_d65 = Eigen::Matrix3d::Identity();
  // DNG AsShotNeutral: the LED white's camera response, largest component 1.
  Eigen::Vector3d as_shot_neutral = Eigen::Vector3d::Ones();
};

// Computed once per model (thread-safe), then shared.
const SensorColor& SimulatedSensorColor(SensorColorModel model);

// White-balanced camera RGB of `reflectance` under the rig's LEDs: a perfect
// white reads (1, 1, 1). kSrgbPrimaries: its linear Rec.709 under D65.
Eigen::Vector3d WhiteBalancedCameraRgbOf(SensorColorModel model, const Spectrum& reflectance);

// The DNG colour data of the simulated camera (SensorColor's fields).
Eigen::Matrix3d SimulatedCameraFromXyzD65(SensorColorModel model);
Eigen::Vector3d SimulatedAsShotNeutral(SensorColorModel model);

}  // namespace scanbench
