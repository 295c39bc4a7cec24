// The light field a solve uses when given a calibration set instead of the
// session's rig description: the set's calibrated camera (its per-pixel rays
// meet the table plane: ray maps, no image resampling) and the light model
// the light calibration selected (fitted point LEDs, or the measured per-pixel
// field), with the gray chart's white balance per LED when the set has one.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "app/session/calibration_set.h"
#include "app/session/session.h"
#include "solver/light_field.h"

namespace scanbench {

struct CalibrationUseOptions {
  double max_age_days = 90.0;     // older sets still solve, with a warning, > 0
  bool use_white_balance = true;  // R and B from the gray chart's gains (else from the white sheet's colours)

  void Check() const;
};

struct CalibratedLighting {
  std::unique_ptr<LightField> light_field;
  std::string light_model;            // one line for reports: what and why
  std::vector<std::string> warnings;  // e.g. a stale set
  std::string report_json;            // the "calibration" object of report.json (JSON text)
  std::shared_ptr<const CalibrationSet> set;  // the set it came from (its colour section, its white sheets)
};

// Loads and checks the set (SessionError naming file and field), refuses a set
// of another camera, lens, resolution or LED set, builds the light field.
CalibratedLighting MakeCalibratedLighting(const std::filesystem::path& calibration_dir, const Session& session,
                                          const std::string& session_name, const CalibrationUseOptions& options = {});

// The same from a loaded set (no files read).
CalibratedLighting MakeCalibratedLighting(const CalibrationSet& set, const std::string& set_name,
                                          const Session& session, const std::string& session_name,
                                          const CalibrationUseOptions& options = {});

// Distant, uniform lights: every LED's direction and intensity as they are at
// the table origin, the same at every pixel (the assumption the seed's Figure
// 10 shows the cost of). From `leds` (any description: measured or fitted).
std::unique_ptr<LightField> MakeDistantUniformLightField(const std::vector<LedDescription>& leds, int width,
                                                         int height);

}  // namespace scanbench
