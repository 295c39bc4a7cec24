// What a calibration target session shows: <session>/target.json beside
// session.json. A target session is an ordinary capture session (a dark frame
// and one frame per LED) of a checkerboard, a gray chart or a white sheet;
// target.json says which, with the target's dimensions, so that the session
// describes itself. session.json is left exactly as for a scan.
//
//   {"schema": "scanbench.calibration_target", "schema_version": 1,
//    "kind": "checkerboard",
//    "checkerboard": {"inner_corners": [9, 6], "square_mm": 9.0,
//                     "on_table": true, "board_height_mm": 0.0}}
//   {"kind": "gray_chart", "gray_chart": {"height_mm": 0.0, "patches": [
//       {"name": "N5", "reflectance": 0.193, "centre_in_table_mm": [0, 0], "size_mm": 14}, ...]}}
//   {"kind": "white_sheet", "white_sheet": {"reflectance": 0.99, "height_mm": 40.0}}
#pragma once

#include <filesystem>
#include <string>

#include "app/session/session_error.h"
#include "calibration/calibration_targets.h"

namespace scanbench {

inline constexpr int kCalibrationTargetSchemaVersion = 1;
inline constexpr char kCalibrationTargetFileName[] = "target.json";

struct CalibrationTargetDescription {
  enum class Kind { kCheckerboard, kGrayChart, kWhiteSheet };
  Kind kind = Kind::kWhiteSheet;
  // kCheckerboard
  CheckerboardTarget checkerboard;
  bool on_table = false;        // the board lies flat on the table in the table's orientation
  double board_height_mm = 0;   // its face above the table when on_table, [0, 200]
  // kGrayChart
  GrayChartTarget gray_chart;
  // kWhiteSheet
  WhiteSheetTarget white_sheet;
};

// "checkerboard", "gray_chart", "white_sheet".
const char* CalibrationTargetKindName(CalibrationTargetDescription::Kind kind);

std::string CalibrationTargetToJson(const CalibrationTargetDescription& target);
// Parses and checks; errors name the file and field. Throws SessionError.
CalibrationTargetDescription CalibrationTargetFromJson(const std::string& text, const std::string& name_for_errors);

// <session_dir>/target.json; a missing file says that the session is no
// calibration target. Throws SessionError.
CalibrationTargetDescription LoadCalibrationTarget(const std::filesystem::path& session_dir);
// Writes <session_dir>/target.json atomically (replacing).
void WriteCalibrationTarget(const std::filesystem::path& session_dir, const CalibrationTargetDescription& target);

}  // namespace scanbench
