#include "app/session/calibration_target.h"

#include <stdexcept>

#include "app/io/file_util.h"
#include "app/session/json_field.h"

namespace scanbench {
namespace fs = std::filesystem;
using session_internal::Json;
using session_internal::JsonField;
using session_internal::ThrowFieldError;

namespace {

constexpr char kSchemaName[] = "scanbench.calibration_target";

Json Vector2ToJson(const Eigen::Vector2d& v) { return Json::array({v.x(), v.y()}); }

Eigen::Vector2d Vector2FromJson(const JsonField& field) {
  const std::vector<JsonField> elements = field.Elements();
  if (elements.size() != 2) field.Fail("must be an array of 2 numbers");
  return {elements[0].Double(), elements[1].Double()};
}

// Turns the calibration library's std::invalid_argument into a SessionError
// naming the file and the JSON object.
template <typename Function>
void CheckAs(const std::string& file, const std::string& path, Function&& check) {
  try {
    check();
  } catch (const std::invalid_argument& error) {
    ThrowFieldError(file, path, error.what());
  }
}

}  // namespace

const char* CalibrationTargetKindName(CalibrationTargetDescription::Kind kind) {
  switch (kind) {
    case CalibrationTargetDescription::Kind::kCheckerboard: return "checkerboard";
    case CalibrationTargetDescription::Kind::kGrayChart: return "gray_chart";
    case CalibrationTargetDescription::Kind::kWhiteSheet: return "white_sheet";
  }
  return "?";
}

std::string CalibrationTargetToJson(const CalibrationTargetDescription& target) {
  Json json{{"schema", kSchemaName},
            {"schema_version", kCalibrationTargetSchemaVersion},
            {"kind", CalibrationTargetKindName(target.kind)}};
  switch (target.kind) {
    case CalibrationTargetDescription::Kind::kCheckerboard:
      json["checkerboard"] = {{"inner_corners", {target.checkerboard.inner_corners_x, target.checkerboard.inner_corners_y}},
                              {"square_mm", target.checkerboard.square_mm},
                              {"on_table", target.on_table},
                              {"board_height_mm", target.board_height_mm}};
      break;
    case CalibrationTargetDescription::Kind::kGrayChart: {
      Json patches = Json::array();
      for (const GrayPatch& patch : target.gray_chart.patches) {
        patches.push_back({{"name", patch.name},
                           {"reflectance", patch.reflectance},
                           {"centre_in_table_mm", Vector2ToJson(patch.centre_in_table_mm)},
                           {"size_mm", patch.size_mm}});
      }
      json["gray_chart"] = {{"height_mm", target.gray_chart.height_mm}, {"patches", std::move(patches)}};
      break;
    }
    case CalibrationTargetDescription::Kind::kWhiteSheet:
      json["white_sheet"] = {{"reflectance", target.white_sheet.reflectance},
                             {"height_mm", target.white_sheet.height_mm}};
      break;
  }
  return session_internal::DumpJson(json);
}

CalibrationTargetDescription CalibrationTargetFromJson(const std::string& text, const std::string& file) {
  const Json json = session_internal::ParseJson(text, file);
  const JsonField root(json, "", file);
  const JsonField schema = root.Member("schema");
  if (schema.String() != kSchemaName) schema.Fail(std::string("must be \"") + kSchemaName + "\"");
  const JsonField version = root.Member("schema_version");
  if (version.Int() != kCalibrationTargetSchemaVersion) {
    version.Fail("is not the version this scanbench reads (" + std::to_string(kCalibrationTargetSchemaVersion) + ")");
  }
  root.ExpectOnlyKeys({"schema", "schema_version", "kind", "checkerboard", "gray_chart", "white_sheet"});
  CalibrationTargetDescription target;
  const JsonField kind = root.Member("kind");
  const std::string kind_name = kind.String();
  if (kind_name == "checkerboard") {
    target.kind = CalibrationTargetDescription::Kind::kCheckerboard;
    const JsonField board = root.Member("checkerboard");
    board.ExpectOnlyKeys({"inner_corners", "square_mm", "on_table", "board_height_mm"});
    const JsonField corners = board.Member("inner_corners");
    const std::vector<JsonField> counts = corners.Elements();
    if (counts.size() != 2) corners.Fail("must be [corners along a row, corners along a column]");
    target.checkerboard.inner_corners_x = counts[0].Int();
    target.checkerboard.inner_corners_y = counts[1].Int();
    target.checkerboard.square_mm = board.Member("square_mm").Double();
    target.on_table = board.Member("on_table").Bool();
    target.board_height_mm = board.Member("board_height_mm").Double();
    CheckAs(file, "checkerboard", [&] { target.checkerboard.Check(); });
    if (!(target.board_height_mm >= 0 && target.board_height_mm <= 200)) {
      board.Member("board_height_mm").Fail("must lie in [0, 200] mm");
    }
  } else if (kind_name == "gray_chart") {
    target.kind = CalibrationTargetDescription::Kind::kGrayChart;
    const JsonField chart = root.Member("gray_chart");
    chart.ExpectOnlyKeys({"height_mm", "patches"});
    target.gray_chart.height_mm = chart.Member("height_mm").Double();
    for (const JsonField& patch_field : chart.Member("patches").Elements()) {
      patch_field.ExpectOnlyKeys({"name", "reflectance", "centre_in_table_mm", "size_mm"});
      GrayPatch patch;
      patch.name = patch_field.Member("name").String();
      patch.reflectance = patch_field.Member("reflectance").Double();
      patch.centre_in_table_mm = Vector2FromJson(patch_field.Member("centre_in_table_mm"));
      patch.size_mm = patch_field.Member("size_mm").Double();
      target.gray_chart.patches.push_back(patch);
    }
    CheckAs(file, "gray_chart", [&] { target.gray_chart.Check(); });
  } else if (kind_name == "white_sheet") {
    target.kind = CalibrationTargetDescription::Kind::kWhiteSheet;
    const JsonField sheet = root.Member("white_sheet");
    sheet.ExpectOnlyKeys({"reflectance", "height_mm"});
    target.white_sheet.reflectance = sheet.Member("reflectance").Double();
    target.white_sheet.height_mm = sheet.Member("height_mm").Double();
    CheckAs(file, "white_sheet", [&] { target.white_sheet.Check(); });
  } else {
    kind.Fail("must be \"checkerboard\", \"gray_chart\" or \"white_sheet\"");
  }
  return target;
}

CalibrationTargetDescription LoadCalibrationTarget(const fs::path& session_dir) {
  const fs::path path = session_dir / kCalibrationTargetFileName;
  std::error_code error;
  if (!fs::is_regular_file(path, error)) {
    throw SessionError(path.string() + ": does not exist: " + session_dir.string() +
                       " is no calibration target session (a scan session has no target.json)");
  }
  std::vector<uint8_t> bytes;
  try {
    bytes = ReadFileBytes(path);
  } catch (const std::exception& read_error) {
    throw SessionError(read_error.what());
  }
  return CalibrationTargetFromJson(std::string(bytes.begin(), bytes.end()), path.string());
}

void WriteCalibrationTarget(const fs::path& session_dir, const CalibrationTargetDescription& target) {
  const std::string text = CalibrationTargetToJson(target);
  // Round-trip through the checks: never write what the loader refuses.
  CalibrationTargetFromJson(text, (session_dir / kCalibrationTargetFileName).string());
  try {
    WriteFileAtomic(session_dir / kCalibrationTargetFileName, text, OverwritePolicy::kReplace);
  } catch (const std::exception& error) {
    throw SessionError(error.what());
  }
}

}  // namespace scanbench
