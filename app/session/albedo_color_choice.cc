#include "app/session/albedo_color_choice.h"

#include <stdexcept>
#include <string>

#include "app/session/calibration_set.h"
#include "calibration/color_science.h"
#include "core/format.h"

namespace scanbench {
namespace {

// The albedo's scale follows the lights: a light calibration on a white sheet of
// known reflectance makes it absolute, a rig description's intensities do not.
void SetScale(const CalibrationSet* set, const std::string& set_name, AlbedoColor* color) {
  if (set != nullptr && set->lights) {
    std::string sheets;
    for (const WhiteSheetTarget& sheet : set->lights->sheets) {
      sheets += (sheets.empty() ? "" : ", ") + Fixed(100 * sheet.reflectance, 1) + " %";
    }
    color->scale = "absolute";
    color->scale_source = "diffuse reflectance: the light calibration of " + set_name + " (" +
                          set->lights->date + ") divided out its white sheets of " + sheets + " reflectance";
    return;
  }
  color->scale = "relative";
  color->scale_source =
      "relative to the rig description's LED intensities (not measured); calibrate the lights on a white sheet "
      "for absolute reflectance";
}

AlbedoColor FromChart(const CalibrationSet& set, const std::string& set_name) {
  const ColorSection& section = *set.color;
  AlbedoColor color;
  color.source = AlbedoColorOptions::Source::kChart;
  color.rec709_from_camera = section.summary.rec709_from_camera;
  color.color_space = "linear_rec709";
  color.chart_mean_delta_e = section.summary.mean_delta_e_after;
  color.chart_max_delta_e = section.summary.max_delta_e_after;
  color.description = "colour calibration of " + set_name + " (" + section.date + ", " + section.summary.method +
                      " on a ColorChecker, " + section.white_reference + "): CIEDE2000 on the chart mean " +
                      Fixed(section.summary.mean_delta_e_after, 2) + ", max " +
                      Fixed(section.summary.max_delta_e_after, 2) + " (uncorrected mean " +
                      Fixed(section.summary.mean_delta_e_before, 2) + ")";
  return color;
}

AlbedoColor FromCameraMatrix(const Eigen::Matrix3d& camera_from_xyz, const std::string& file_name) {
  AlbedoColor color;
  color.source = AlbedoColorOptions::Source::kCameraMatrix;
  color.rec709_from_camera = Rec709FromWhiteBalancedCamera(camera_from_xyz);
  color.color_space = "linear_rec709";
  color.description = "the RAW file's own camera matrix (" + file_name +
                      ": XYZ -> camera under D65) to linear Rec.709; the weaker path: a maker's matrix for the "
                      "model, not this sensor under these LEDs; calibrate on a ColorChecker (scanbench calibrate "
                      "color) for accurate colour";
  return color;
}

AlbedoColor Uncorrected(const std::string& why) {
  AlbedoColor color;
  color.source = AlbedoColorOptions::Source::kNone;
  color.description = "not colour calibrated: white-balanced camera RGB (the sensor's own primaries), " + why;
  return color;
}

}  // namespace

AlbedoColor ChooseAlbedoColor(const AlbedoColorOptions& options, const CalibrationSet* set,
                              const std::string& set_name,
                              const std::optional<Eigen::Matrix3d>& file_camera_from_xyz,
                              const std::string& file_name) {
  using Source = AlbedoColorOptions::Source;
  const bool has_chart = set != nullptr && set->color.has_value();
  AlbedoColor color;
  switch (options.source) {
    case Source::kAuto:
      if (has_chart) {
        color = FromChart(*set, set_name);
      } else if (file_camera_from_xyz) {
        color = FromCameraMatrix(*file_camera_from_xyz, file_name);
      } else {
        color = Uncorrected("because there is no colour calibration and " + file_name + " carries no camera matrix");
      }
      break;
    case Source::kChart:
      if (!has_chart) {
        throw std::runtime_error(set == nullptr ? std::string("albedo colour \"chart\" needs a calibration set "
                                                              "(--calibration) with a colour section")
                                                : set_name + ": color: missing; run `scanbench calibrate color` "
                                                             "into this set, or choose another albedo colour");
      }
      color = FromChart(*set, set_name);
      break;
    case Source::kCameraMatrix:
      if (!file_camera_from_xyz) {
        throw std::runtime_error(file_name + ": carries no camera colour matrix (albedo colour \"camera-matrix\")");
      }
      color = FromCameraMatrix(*file_camera_from_xyz, file_name);
      break;
    case Source::kNone:
      color = Uncorrected("as asked (albedo colour \"none\")");
      break;
  }
  SetScale(set, set_name, &color);
  return color;
}

}  // namespace scanbench
