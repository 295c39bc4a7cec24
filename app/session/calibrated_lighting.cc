#include "app/session/calibrated_lighting.h"

#include <cmath>
#include <iomanip>
#include <sstream>

#include <nlohmann/json.hpp>

#include "app/io/file_util.h"
#include "calibration/camera_model.h"
#include "calibration/rig_light_field.h"
#include "calibration/sampled_light_field.h"
#include "core/field_error.h"

namespace scanbench {
namespace fs = std::filesystem;
namespace {

// The view direction (table point towards the camera centre) at every node of
// the measured light field's grid, node-major: what the specular lobe fits need.
std::vector<float> NodeViewDirections(const CameraGeometry& camera, const LightFieldGrid& grid) {
  std::vector<Eigen::Vector2d> pixels;
  pixels.reserve(grid.num_nodes());
  for (int j = 0; j < grid.nodes_y; ++j) {
    for (int i = 0; i < grid.nodes_x; ++i) pixels.emplace_back(grid.NodeX(i), grid.NodeY(j));
  }
  const std::vector<Eigen::Vector3d> points = ComputePlanePointsInTable(camera, pixels, 0.0);
  const Eigen::Vector3d centre = CameraCentreInTable(camera);
  std::vector<float> dirs(3 * points.size());
  for (size_t n = 0; n < points.size(); ++n) {
    const Eigen::Vector3d view = (centre - points[n]).normalized();
    for (int c = 0; c < 3; ++c) dirs[3 * n + c] = static_cast<float>(view[c]);
  }
  return dirs;
}

}  // namespace

void CalibrationUseOptions::Check() const {
  SCANBENCH_REQUIRE_FINITE_GT("CalibrationUseOptions", "max_age_days", max_age_days, 0);
}

CalibratedLighting MakeCalibratedLighting(const fs::path& calibration_dir, const Session& session,
                                          const std::string& session_name, const CalibrationUseOptions& options) {
  options.Check();
  const CalibrationSet set = LoadCalibrationSet(calibration_dir);
  CalibratedLighting lighting =
      MakeCalibratedLighting(set, (calibration_dir / kCalibrationManifestName).string(), session, session_name, options);
  nlohmann::json report = nlohmann::json::parse(lighting.report_json);
  report["path"] = fs::absolute(calibration_dir).lexically_normal().string();
  report["manifest_sha256"] = Sha256HexOfFile(calibration_dir / kCalibrationManifestName);
  lighting.report_json = report.dump();
  return lighting;
}

CalibratedLighting MakeCalibratedLighting(const CalibrationSet& set, const std::string& set_name,
                                          const Session& session, const std::string& session_name,
                                          const CalibrationUseOptions& options) {
  options.Check();
  CheckCalibrationFitsSession(set, set_name, session, session_name);
  if (!set.camera_calibration) {
    throw SessionError(set_name + ": camera_calibration: missing; the set cannot place pixels on the table");
  }
  if (!set.lights) {
    throw SessionError(set_name + ": lights: missing; run `scanbench calibrate lights` into this set first");
  }
  const LightsSection& lights = *set.lights;
  const size_t num_leds = lights.summary.model.size();
  // White balance: the chart's per-LED gains give R and B relative to G.
  std::string white_balance = "white sheet colours (the set has no gray chart white balance)";
  const bool chart = options.use_white_balance && set.white_balance;
  if (set.white_balance && !options.use_white_balance) white_balance = "white sheet colours (gray chart not used)";

  CalibratedLighting lighting;
  const CameraGeometry& camera = set.camera_calibration->summary.camera;
  std::vector<Eigen::Vector3d> green_to_rgb(num_leds, Eigen::Vector3d::Ones());
  if (chart) {
    for (size_t k = 0; k < num_leds; ++k) {
      const Eigen::Vector3d& gains = set.white_balance->summary.leds[k].gains;
      green_to_rgb[k] = Eigen::Vector3d(1.0 / gains[0], 1.0, 1.0 / gains[2]);
    }
    white_balance = "gray chart gains per LED (R and B from G)";
  }
  const bool model = lights.summary.selected == LightCalibrationSummary::Choice::kModel;
  if (model) {
    RigDescription rig;
    rig.camera = camera;
    rig.leds = lights.summary.ModelLeds();
    if (chart) {
      for (size_t k = 0; k < num_leds; ++k) rig.leds[k].rgb_intensity = rig.leds[k].rgb_intensity[1] * green_to_rgb[k];
    }
    lighting.light_field = MakeRigLightField(rig);
  } else {
    const SampledLightField& field = *lights.summary.per_pixel_field;
    std::vector<float> intensities = field.node_rgb_intensities();
    if (chart) {
      for (size_t n = 0; n < field.grid().num_nodes(); ++n) {
        for (size_t k = 0; k < num_leds; ++k) {
          float* e = &intensities[(n * num_leds + k) * 3];
          const float green = e[1];
          for (int c = 0; c < 3; ++c) e[c] = static_cast<float>(green * green_to_rgb[k][c]);
        }
      }
    }
    auto sampled = std::make_unique<SampledLightField>(field.grid(), static_cast<int>(num_leds),
                                                       field.node_light_dirs(), std::move(intensities));
    sampled->SetViewDirections(NodeViewDirections(camera, field.grid()));
    lighting.light_field = std::move(sampled);
  }
  lighting.light_model = std::string("calibration set ") + set_name + ": " +
                         (model ? "fitted point LEDs (position, axis, mu, RGB intensity)"
                                : "measured per-pixel light field (cells of " + std::to_string(lights.summary.cell_px) +
                                      " px)") +
                         " on the calibrated camera's table plane; white balance: " + white_balance +
                         "; chosen because " + lights.summary.selection_reason;
  if (const auto stale = CalibrationAgeWarning(set, set_name, options.max_age_days)) lighting.warnings.push_back(*stale);
  for (const std::string& warning : lights.summary.warnings) lighting.warnings.push_back(set_name + ": " + warning);

  nlohmann::json report;
  report["used"] = set_name;
  report["created"] = set.created;
  report["camera"] = {{"make", set.camera.make},     {"model", set.camera.model}, {"serial", set.camera.serial},
                      {"lens", set.camera.lens},     {"width", set.camera.width}, {"height", set.camera.height}};
  report["camera_calibration_date"] = set.camera_calibration->date;
  report["camera_reprojection_rms_px"] = set.camera_calibration->summary.reprojection_rms_px;
  report["lights_date"] = lights.date;
  report["light_model"] = model ? "model" : "per_pixel";
  report["why"] = lights.summary.selection_reason;
  report["white_balance"] = white_balance;
  if (set.white_balance) report["white_balance_date"] = set.white_balance->date;
  report["rays"] = "per-pixel ray maps of the calibrated intrinsics and distortion; images not resampled";
  report["warnings"] = lighting.warnings;
  report["description"] = lighting.light_model;
  lighting.report_json = report.dump();
  lighting.set = std::make_shared<const CalibrationSet>(set);
  return lighting;
}

std::unique_ptr<LightField> MakeDistantUniformLightField(const std::vector<LedDescription>& leds, int width,
                                                         int height) {
  std::vector<Eigen::Vector3d> directions, intensities;
  for (const LedDescription& led : leds) {
    const Eigen::Vector3d to_led = led.position_in_table_mm;  // from the table origin
    const double d = to_led.norm();
    const double cos_off_axis = std::max(0.0, -(to_led / d).dot(led.axis_in_table.normalized()));
    directions.push_back(to_led / d);
    intensities.push_back(led.rgb_intensity * std::pow(cos_off_axis, led.mu) *
                          (kLedReferenceDistanceMm * kLedReferenceDistanceMm / (d * d)));
  }
  return std::make_unique<DirectionalLightField>(width, height, std::move(directions), std::move(intensities));
}

}  // namespace scanbench
