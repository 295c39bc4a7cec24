#include "app/session/calibration_target.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include "core/field_error.h"

#include "app/io/file_util.h"
#include "app/session/json_field.h"

namespace scanbench {
namespace fs = std::filesystem;
using session_internal::FromJsonObject;
using session_internal::Json;
using session_internal::JsonField;
using session_internal::Presence;
using session_internal::ReadObject;
using session_internal::RethrowAsSessionError;
using session_internal::ThrowFieldError;
using session_internal::ToJsonObject;
using session_internal::WriteObject;

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

std::optional<CalibrationTargetDescription::Kind> CalibrationTargetKindFromName(const std::string& name) {
  for (const auto kind : {CalibrationTargetDescription::Kind::kCheckerboard,
                          CalibrationTargetDescription::Kind::kGrayChart,
                          CalibrationTargetDescription::Kind::kWhiteSheet,
                          CalibrationTargetDescription::Kind::kColorChart}) {
    if (name == CalibrationTargetKindName(kind)) return kind;
  }
  return std::nullopt;
}

const char* CalibrationTargetKindName(CalibrationTargetDescription::Kind kind) {
  switch (kind) {
    case CalibrationTargetDescription::Kind::kCheckerboard: return "checkerboard";
    case CalibrationTargetDescription::Kind::kGrayChart: return "gray_chart";
    case CalibrationTargetDescription::Kind::kWhiteSheet: return "white_sheet";
    case CalibrationTargetDescription::Kind::kColorChart: return "color_chart";
  }
  return "?";
}

void ColorChartDescription::Check() const {
  const std::string where = "ColorChartDescription";
  if (chart != kColorCheckerClassicChart) {
    throw FieldError(where, "chart", "'" + chart + "'", std::string("must be \"") + kColorCheckerClassicChart + "\"");
  }
  SCANBENCH_REQUIRE_GT_LE(where, "patch_mm", patch_mm, 0, 100, "mm");
  if (!(pitch_mm >= patch_mm && pitch_mm <= 200)) {
    throw FieldError(where, "pitch_mm", pitch_mm, "must lie in [patch_mm = " + std::to_string(patch_mm) + ", 200] mm");
  }
  SCANBENCH_REQUIRE_GE_LE(where, "height_mm", height_mm, 0, 200, "mm");
}

namespace {

template <typename Io>
void CheckerboardFields(Io& io, CalibrationTargetDescription& target) {
  CheckerboardTarget& board = target.checkerboard;
  io.Custom(
      "inner_corners", [&] { return Json::array({board.inner_corners_x, board.inner_corners_y}); },
      [&](const JsonField& corners) {
        const std::vector<JsonField> counts = corners.Elements();
        if (counts.size() != 2) corners.Fail("must be [corners along a row, corners along a column]");
        board.inner_corners_x = counts[0].Int();
        board.inner_corners_y = counts[1].Int();
      });
  io.Field("square_mm", board.square_mm);
  io.Field("on_table", target.on_table);
  io.Custom(
      "board_height_mm", [&] { return Json(target.board_height_mm); },
      [&](const JsonField& height) {
        target.board_height_mm = height.Double();
        if (!(target.board_height_mm >= 0 && target.board_height_mm <= 200)) height.Fail("must lie in [0, 200] mm");
      });
}

template <typename Io>
void GrayPatchFields(Io& io, GrayPatch& patch) {
  io.Field("name", patch.name);
  io.Field("reflectance", patch.reflectance);
  io.Custom(
      "centre_in_table_mm", [&] { return Vector2ToJson(patch.centre_in_table_mm); },
      [&](const JsonField& centre) { patch.centre_in_table_mm = Vector2FromJson(centre); });
  io.Field("size_mm", patch.size_mm);
}

template <typename Io>
void GrayChartFields(Io& io, GrayChartTarget& chart) {
  io.Field("height_mm", chart.height_mm);
  io.Array("patches", chart.patches, [](auto& patch_io, GrayPatch& patch) { GrayPatchFields(patch_io, patch); });
}

template <typename Io>
void WhiteSheetFields(Io& io, WhiteSheetTarget& sheet) {
  io.Field("reflectance", sheet.reflectance);
  io.Field("height_mm", sheet.height_mm);
}

template <typename Io>
void ColorChartFields(Io& io, ColorChartDescription& chart) {
  io.Field("chart", chart.chart);
  io.Field("patch_mm", chart.patch_mm);
  io.Field("pitch_mm", chart.pitch_mm);
  io.Field("height_mm", chart.height_mm);
}

using Kind = CalibrationTargetDescription::Kind;
constexpr Kind kKinds[] = {Kind::kCheckerboard, Kind::kGrayChart, Kind::kWhiteSheet, Kind::kColorChart};

// The section of `kind`, under the key CalibrationTargetKindName(kind); its
// checks run on the section read. Only the target's own kind is written.
template <typename Io>
void SectionFields(Io& io, CalibrationTargetDescription& target, Kind kind, const std::string& file) {
  const char* key = CalibrationTargetKindName(kind);
  auto read = [&](auto& section_io) {
    switch (kind) {
      case Kind::kCheckerboard: CheckerboardFields(section_io, target); break;
      case Kind::kGrayChart: GrayChartFields(section_io, target.gray_chart); break;
      case Kind::kWhiteSheet: WhiteSheetFields(section_io, target.white_sheet); break;
      case Kind::kColorChart: ColorChartFields(section_io, target.color_chart); break;
    }
  };
  io.Custom(
      key,
      [&]() -> std::optional<Json> {
        if (target.kind != kind) return std::nullopt;
        return WriteObject(read);
      },
      [&](const JsonField& section) {
        if (target.kind != kind) return;  // another kind's section is ignored, as it always was
        ReadObject(section, read);
        CheckAs(file, key, [&] {
          switch (kind) {
            case Kind::kCheckerboard: target.checkerboard.Check(); break;
            case Kind::kGrayChart: target.gray_chart.Check(); break;
            case Kind::kWhiteSheet: target.white_sheet.Check(); break;
            case Kind::kColorChart: target.color_chart.Check(); break;
          }
        });
      },
      target.kind == kind ? Presence::kRequired : Presence::kOptionalOnRead);
}

template <typename Io>
void TargetFields(Io& io, CalibrationTargetDescription& target, const std::string& file) {
  io.Custom(
      "schema", [] { return Json(kSchemaName); }, [](const JsonField&) { /* checked first, by CheckSchema */ });
  io.Custom(
      "schema_version", [] { return Json(kCalibrationTargetSchemaVersion); }, [](const JsonField&) {});
  io.Custom(
      "kind", [&] { return Json(CalibrationTargetKindName(target.kind)); },
      [&](const JsonField& kind) {
        const auto known = CalibrationTargetKindFromName(kind.String());
        if (!known) kind.Fail("must be \"checkerboard\", \"gray_chart\", \"white_sheet\" or \"color_chart\"");
        target.kind = *known;
      });
  for (const Kind kind : kKinds) SectionFields(io, target, kind, file);
}

// The schema and its version say how to read the rest, so they come first.
void CheckSchema(const JsonField& root) {
  const JsonField schema = root.Member("schema");
  if (schema.String() != kSchemaName) schema.Fail(std::string("must be \"") + kSchemaName + "\"");
  const JsonField version = root.Member("schema_version");
  if (version.Int() != kCalibrationTargetSchemaVersion) {
    version.Fail("is not the version this scanbench reads (" + std::to_string(kCalibrationTargetSchemaVersion) + ")");
  }
}

}  // namespace

std::string CalibrationTargetToJson(const CalibrationTargetDescription& target) {
  return session_internal::DumpJson(
      ToJsonObject(target, [](auto& io, CalibrationTargetDescription& value) { TargetFields(io, value, ""); }));
}

CalibrationTargetDescription CalibrationTargetFromJson(const std::string& text, const std::string& file) {
  const Json json = session_internal::ParseJson(text, file);
  const JsonField root(json, "", file);
  CheckSchema(root);
  return FromJsonObject<CalibrationTargetDescription>(
      root, [&](auto& io, CalibrationTargetDescription& value) { TargetFields(io, value, file); });
}

CalibrationTargetDescription LoadCalibrationTarget(const fs::path& session_dir) {
  const fs::path path = session_dir / kCalibrationTargetFileName;
  std::error_code error;
  if (!fs::is_regular_file(path, error)) {
    throw SessionError(path.string() + ": does not exist: " + session_dir.string() +
                       " is no calibration target session (a scan session has no target.json)");
  }
  const std::vector<uint8_t> bytes = RethrowAsSessionError([&] { return ReadFileBytes(path); });
  return CalibrationTargetFromJson(std::string(bytes.begin(), bytes.end()), path.string());
}

void WriteCalibrationTarget(const fs::path& session_dir, const CalibrationTargetDescription& target) {
  const std::string text = CalibrationTargetToJson(target);
  // Round-trip through the checks: never write what the loader refuses.
  CalibrationTargetFromJson(text, (session_dir / kCalibrationTargetFileName).string());
  RethrowAsSessionError([&] { WriteFileAtomic(session_dir / kCalibrationTargetFileName, text, OverwritePolicy::kReplace); });
}

// ---------------------------------------------------------------------------
// Target sessions in a folder, and captures described as targets

std::map<Kind, std::vector<fs::path>> FindTargetSessions(const fs::path& folder) {
  std::vector<fs::path> dirs;
  std::error_code error;
  if (fs::exists(folder / kCalibrationTargetFileName, error)) dirs.push_back(folder);
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.is_directory(error) && fs::exists(entry.path() / kCalibrationTargetFileName, error)) {
      dirs.push_back(entry.path());
    }
  }
  std::sort(dirs.begin(), dirs.end());
  std::map<Kind, std::vector<fs::path>> found;
  for (const fs::path& dir : dirs) {
    try {
      found[LoadCalibrationTarget(dir).kind].push_back(dir);
    } catch (const SessionError&) {
    }
  }
  return found;
}

bool IsTableView(const CalibrationTargetDescription& target) {
  switch (target.kind) {
    case Kind::kCheckerboard: return target.on_table;
    case Kind::kWhiteSheet: return target.white_sheet.height_mm == 0;
    case Kind::kGrayChart:
    case Kind::kColorChart: break;
  }
  return false;
}

void DescribeTargetsOptions::Check() const {
  SCANBENCH_REQUIRE_GT_LE("DescribeTargetsOptions", "spacer_mm", spacer_mm, 0, 200, "mm");
}

namespace {

// Is one of `sessions` already the table view of a `kind` target?
bool HasTableView(Kind kind, const std::vector<fs::path>& sessions) {
  for (const fs::path& session : sessions) {
    try {
      const CalibrationTargetDescription target = LoadCalibrationTarget(session);
      if (target.kind == kind && IsTableView(target)) return true;
    } catch (const SessionError&) {
    }
  }
  return false;
}

// The standard target of `kind`; the table view when `table_view`.
std::pair<CalibrationTargetDescription, std::string> StandardTarget(const DescribeTargetsOptions& options,
                                                                    bool table_view) {
  CalibrationTargetDescription target;
  target.kind = options.kind;
  switch (options.kind) {
    case Kind::kCheckerboard:
      target.on_table = table_view;
      return {target, table_view ? "the board lying on the table" : "a tilted board pose"};
    case Kind::kGrayChart:
      target.gray_chart = GrayChartTarget::MunsellNeutralScale();
      return {target, "the gray chart"};
    case Kind::kColorChart:
      // The real ColorChecker Classic: 279 x 216 mm on a 40 mm pitch, patches ~35 mm.
      target.color_chart.patch_mm = 35.0;
      target.color_chart.pitch_mm = 40.0;
      return {target, "the ColorChecker Classic"};
    case Kind::kWhiteSheet:
      break;
  }
  target.white_sheet.height_mm = table_view ? 0 : options.spacer_mm;
  char spacer[96];
  std::snprintf(spacer, sizeof(spacer), "the sheet on the %g mm spacer", options.spacer_mm);
  return {target, table_view ? "the sheet on the table" : spacer};
}

}  // namespace

std::vector<DescribedTargetSession> DescribeTargetSessions(const DescribeTargetsOptions& options,
                                                           const std::vector<fs::path>& sessions,
                                                           const std::vector<fs::path>& also_listed) {
  options.Check();
  bool have_table_view = HasTableView(options.kind, sessions) || HasTableView(options.kind, also_listed);
  std::vector<DescribedTargetSession> described;
  for (const fs::path& dir : sessions) {
    std::error_code error;
    if (fs::exists(dir / kCalibrationTargetFileName, error)) {
      described.push_back({dir, false, ""});
      continue;
    }
    if (!fs::exists(dir / "session.json", error)) {
      throw SessionError(dir.string() + " holds no session.json: capture it first");
    }
    auto [target, what] = StandardTarget(options, !have_table_view);
    have_table_view |= IsTableView(target);
    WriteCalibrationTarget(dir, target);
    described.push_back({dir, true, what});
  }
  return described;
}

}  // namespace scanbench
