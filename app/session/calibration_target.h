// What a calibration target session shows: <session>/target.json beside
// session.json. A target session is an ordinary capture session (a dark frame
// and one frame per LED) of a checkerboard, a gray chart, a white sheet or a
// colour chart;
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
//   {"kind": "color_chart", "color_chart": {"chart": "colorchecker_classic", "patch_mm": 16.0,
//                                           "pitch_mm": 20.0, "height_mm": 0.0}}
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "app/session/session_error.h"
#include "calibration/calibration_targets.h"

namespace scanbench {

inline constexpr int kCalibrationTargetSchemaVersion = 1;
inline constexpr char kCalibrationTargetFileName[] = "target.json";

// A colour chart lying flat, face up, anywhere in view (its detection finds
// it): which chart and its patch grid.
inline constexpr char kColorCheckerClassicChart[] = "colorchecker_classic";
struct ColorChartDescription {
  std::string chart = kColorCheckerClassicChart;  // the only chart known: the 24-patch ColorChecker Classic
  double patch_mm = 16.0;   // side of a square patch, (0, 100]
  double pitch_mm = 20.0;   // patch centre spacing, [patch_mm, 200]
  double height_mm = 0.0;   // the chart's face above the table, [0, 200]

  // Throws std::invalid_argument (FieldError) naming the field.
  void Check() const;
};

struct CalibrationTargetDescription {
  enum class Kind { kCheckerboard, kGrayChart, kWhiteSheet, kColorChart };
  Kind kind = Kind::kWhiteSheet;
  // kCheckerboard
  CheckerboardTarget checkerboard;
  bool on_table = false;        // the board lies flat on the table in the table's orientation
  double board_height_mm = 0;   // its face above the table when on_table, [0, 200]
  // kGrayChart
  GrayChartTarget gray_chart;
  // kWhiteSheet
  WhiteSheetTarget white_sheet;
  // kColorChart
  ColorChartDescription color_chart;
};

// "checkerboard", "gray_chart", "white_sheet", "color_chart".
const char* CalibrationTargetKindName(CalibrationTargetDescription::Kind kind);

std::string CalibrationTargetToJson(const CalibrationTargetDescription& target);
// Parses and checks; errors name the file and field. Throws SessionError.
CalibrationTargetDescription CalibrationTargetFromJson(const std::string& text, const std::string& name_for_errors);

// <session_dir>/target.json; a missing file says that the session is no
// calibration target. Throws SessionError.
CalibrationTargetDescription LoadCalibrationTarget(const std::filesystem::path& session_dir);
// Writes <session_dir>/target.json atomically (replacing).
void WriteCalibrationTarget(const std::filesystem::path& session_dir, const CalibrationTargetDescription& target);

// "checkerboard" -> kCheckerboard, ...; std::nullopt for any other name.
std::optional<CalibrationTargetDescription::Kind> CalibrationTargetKindFromName(const std::string& name);

// The target sessions in `folder` (itself, or its sub-folders) by kind, each
// sorted by folder name. Unreadable target.json files are skipped: the
// calibration names what is wrong with them if they are chosen anyway.
std::map<CalibrationTargetDescription::Kind, std::vector<std::filesystem::path>> FindTargetSessions(
    const std::filesystem::path& folder);

// Whether `target` is the view on the table its calibration needs once: the
// board lying on the table (camera), the white sheet on the table (lights).
// Always false for a gray chart and a colour chart.
bool IsTableView(const CalibrationTargetDescription& target);

// Describing captures of the standard targets made on the real bench (plain
// sessions, without target.json) as target sessions.
struct DescribeTargetsOptions {
  CalibrationTargetDescription::Kind kind = CalibrationTargetDescription::Kind::kCheckerboard;
  // The raised white sheet's face above the table, mm, (0, 200]; white sheets only.
  double spacer_mm = 40.0;

  // Throws std::invalid_argument (FieldError) naming the field.
  void Check() const;
};

struct DescribedTargetSession {
  std::filesystem::path session;
  // False: the session had a target.json, which is never replaced (it may
  // describe another target).
  bool written = false;
  // "the board lying on the table", "a tilted board pose", "the gray chart",
  // "the sheet on the table", "the sheet on the 40 mm spacer"; "" when kept.
  std::string what;
};

// Writes the standard target of options.kind into each of `sessions` (in
// order) that has no target.json: the 9 x 6 checkerboard of 9 mm squares,
// the Munsell neutral scale centred on the table, the 99 % white sheet, or a
// ColorChecker Classic of the real size (40 mm pitch, 35 mm patches) on the table.
// The first board / sheet written is the table view unless one of `sessions`
// or `also_listed` (the other sessions of the calibration) already is one;
// later ones are tilted board poses / sheets on the spacer. Throws
// SessionError naming the session when one holds no session.json (those
// before it are written).
std::vector<DescribedTargetSession> DescribeTargetSessions(const DescribeTargetsOptions& options,
                                                           const std::vector<std::filesystem::path>& sessions,
                                                           const std::vector<std::filesystem::path>& also_listed = {});

}  // namespace scanbench
