#include "app/session/calibration_set.h"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>
#include <set>

#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/session/calibration_target.h"
#include "app/session/json_field.h"

namespace scanbench {
namespace fs = std::filesystem;
using session_internal::ElementPath;
using session_internal::FormatValue;
using session_internal::Json;
using session_internal::JsonField;
using session_internal::MemberPath;
using session_internal::ThrowFieldError;
using session_internal::Vector3ToJson;

namespace {

constexpr char kSchemaName[] = "scanbench.calibration_set";
constexpr char kLightsFolder[] = "lights";

template <typename Function>
decltype(auto) AsSessionError(Function&& function) {
  try {
    return function();
  } catch (const SessionError&) {
    throw;
  } catch (const std::exception& error) {
    throw SessionError(error.what());
  }
}

std::string FieldFileName(size_t led, const char* what) {
  char name[64];
  std::snprintf(name, sizeof(name), "%s/led_%02zu_%s.exr", kLightsFolder, led, what);
  return name;
}

Json Vector2ToJson(double a, double b) { return Json::array({a, b}); }

std::vector<double> Numbers(const JsonField& field) {
  std::vector<double> values;
  for (const JsonField& element : field.Elements()) values.push_back(element.Double());
  return values;
}

std::vector<std::string> Strings(const JsonField& field) {
  std::vector<std::string> values;
  for (const JsonField& element : field.Elements()) values.push_back(element.String());
  return values;
}

// ---------------------------------------------------------------------------
// Records

Json TargetsToJson(const std::vector<TargetCaptureRecord>& targets) {
  Json json = Json::array();
  for (const TargetCaptureRecord& t : targets) {
    json.push_back({{"session", t.session},
                    {"kind", t.kind},
                    {"captured", t.captured},
                    {"manifest_sha256", t.manifest_sha256},
                    {"target_sha256", t.target_sha256},
                    {"frame_sha256", t.frame_sha256}});
  }
  return json;
}

std::vector<TargetCaptureRecord> TargetsFromJson(const JsonField& field) {
  std::vector<TargetCaptureRecord> targets;
  for (const JsonField& element : field.Elements()) {
    element.ExpectOnlyKeys({"session", "kind", "captured", "manifest_sha256", "target_sha256", "frame_sha256"});
    TargetCaptureRecord t;
    t.session = element.Member("session").String();
    t.kind = element.Member("kind").String();
    t.captured = element.Member("captured").String();
    t.manifest_sha256 = element.Member("manifest_sha256").String();
    t.target_sha256 = element.Member("target_sha256").String();
    t.frame_sha256 = Strings(element.Member("frame_sha256"));
    targets.push_back(t);
  }
  return targets;
}

// ---------------------------------------------------------------------------
// Camera

constexpr const char* kIntrinsicsStdNames[9] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};

Json CameraSectionToJson(const CameraCalibrationSection& section) {
  const CameraCalibrationSummary& s = section.summary;
  Json stds;
  for (int i = 0; i < 9; ++i) stds[kIntrinsicsStdNames[i]] = s.intrinsics_std[i];
  Json views = Json::array();
  for (const CalibrationViewReport& v : s.views) {
    views.push_back({{"name", v.name},
                     {"used", v.used},
                     {"reason", v.reason},
                     {"on_table", v.on_table},
                     {"edge_width_px", v.edge_width_px},
                     {"contrast", v.contrast},
                     {"rms_px", v.rms_px}});
  }
  return Json{{"date", section.date},
              {"targets", TargetsToJson(section.targets)},
              {"board",
               {{"inner_corners", {section.board.inner_corners_x, section.board.inner_corners_y}},
                {"square_mm", section.board.square_mm}}},
              {"geometry", session_internal::CameraGeometryToJson(s.camera)},
              {"reprojection_rms_px", s.reprojection_rms_px},
              {"table_view_rms_px", s.table_view_rms_px},
              {"num_used_views", s.num_used_views},
              {"intrinsics_std", stds},
              {"views", views}};
}

CameraCalibrationSection CameraSectionFromJson(const JsonField& field) {
  field.ExpectOnlyKeys({"date", "targets", "board", "geometry", "reprojection_rms_px", "table_view_rms_px",
                        "num_used_views", "intrinsics_std", "views"});
  CameraCalibrationSection section;
  section.date = field.Member("date").String();
  section.targets = TargetsFromJson(field.Member("targets"));
  const JsonField board = field.Member("board");
  board.ExpectOnlyKeys({"inner_corners", "square_mm"});
  const std::vector<double> corners = Numbers(board.Member("inner_corners"));
  if (corners.size() != 2) board.Member("inner_corners").Fail("must be [corners along a row, along a column]");
  section.board.inner_corners_x = static_cast<int>(corners[0]);
  section.board.inner_corners_y = static_cast<int>(corners[1]);
  section.board.square_mm = board.Member("square_mm").Double();
  CameraCalibrationSummary& s = section.summary;
  s.termination = Termination::kSuccess;
  s.camera = session_internal::CameraGeometryFromJson(field.Member("geometry"));
  s.reprojection_rms_px = field.Member("reprojection_rms_px").Double();
  s.table_view_rms_px = field.Member("table_view_rms_px").Double();
  s.num_used_views = field.Member("num_used_views").Int();
  const JsonField stds = field.Member("intrinsics_std");
  stds.ExpectOnlyKeys({"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"});
  for (int i = 0; i < 9; ++i) s.intrinsics_std[i] = stds.Member(kIntrinsicsStdNames[i]).Double();
  for (const JsonField& v : field.Member("views").Elements()) {
    v.ExpectOnlyKeys({"name", "used", "reason", "on_table", "edge_width_px", "contrast", "rms_px"});
    CalibrationViewReport view;
    view.name = v.Member("name").String();
    view.used = v.Member("used").Bool();
    view.reason = v.Member("reason").String();
    view.on_table = v.Member("on_table").Bool();
    view.edge_width_px = v.Member("edge_width_px").Double();
    view.contrast = v.Member("contrast").Double();
    view.rms_px = v.Member("rms_px").Double();
    s.views.push_back(view);
  }
  return section;
}

// ---------------------------------------------------------------------------
// White balance

Json WhiteSectionToJson(const WhiteBalanceSection& section) {
  Json leds = Json::array();
  for (size_t k = 0; k < section.summary.leds.size(); ++k) {
    const LedWhiteBalance& led = section.summary.leds[k];
    Json patches = Json::array();
    for (const PatchMeasurement& p : led.patches) {
      patches.push_back({{"name", p.name},
                         {"reflectance", p.reflectance},
                         {"mean", Vector3ToJson(p.mean)},
                         {"standard_error", Vector3ToJson(p.standard_error)},
                         {"samples", {p.samples[0], p.samples[1], p.samples[2]}},
                         {"clipped", p.clipped},
                         {"underexposed", p.underexposed},
                         {"nonlinear", p.nonlinear},
                         {"used", p.used},
                         {"linear_residual", Vector3ToJson(p.linear_residual)}});
    }
    leds.push_back({{"led_index", led.led_index},
                    {"id", k < section.led_ids.size() ? section.led_ids[k] : static_cast<int>(k)},
                    {"gains", Vector3ToJson(led.gains)},
                    {"gains_std", Vector3ToJson(led.gains_std)},
                    {"response_exponent", Vector3ToJson(led.response_exponent)},
                    {"linearity_rms", Vector3ToJson(led.linearity_rms)},
                    {"linear_range", Vector2ToJson(led.linear_range_min, led.linear_range_max)},
                    {"used_patches", led.used_patches},
                    {"patches", patches}});
  }
  return Json{{"date", section.date}, {"targets", TargetsToJson(section.targets)}, {"leds", leds}};
}

WhiteBalanceSection WhiteSectionFromJson(const JsonField& field) {
  field.ExpectOnlyKeys({"date", "targets", "leds"});
  WhiteBalanceSection section;
  section.date = field.Member("date").String();
  section.targets = TargetsFromJson(field.Member("targets"));
  section.summary.termination = Termination::kSuccess;
  for (const JsonField& l : field.Member("leds").Elements()) {
    l.ExpectOnlyKeys({"led_index", "id", "gains", "gains_std", "response_exponent", "linearity_rms", "linear_range",
                      "used_patches", "patches"});
    LedWhiteBalance led;
    led.led_index = l.Member("led_index").Int();
    section.led_ids.push_back(l.Member("id").Int());
    led.gains = l.Member("gains").Vector3();
    led.gains_std = l.Member("gains_std").Vector3();
    led.response_exponent = l.Member("response_exponent").Vector3();
    led.linearity_rms = l.Member("linearity_rms").Vector3();
    const std::vector<double> range = Numbers(l.Member("linear_range"));
    if (range.size() != 2) l.Member("linear_range").Fail("must be [lowest, highest]");
    led.linear_range_min = range[0];
    led.linear_range_max = range[1];
    led.used_patches = l.Member("used_patches").Int();
    for (const JsonField& p : l.Member("patches").Elements()) {
      p.ExpectOnlyKeys({"name", "reflectance", "mean", "standard_error", "samples", "clipped", "underexposed",
                        "nonlinear", "used", "linear_residual"});
      PatchMeasurement m;
      m.name = p.Member("name").String();
      m.reflectance = p.Member("reflectance").Double();
      m.mean = p.Member("mean").Vector3();
      m.standard_error = p.Member("standard_error").Vector3();
      const Eigen::Vector3d samples = p.Member("samples").Vector3();
      for (int c = 0; c < 3; ++c) m.samples[c] = static_cast<int>(samples[c]);
      m.clipped = p.Member("clipped").Bool();
      m.underexposed = p.Member("underexposed").Bool();
      m.nonlinear = p.Member("nonlinear").Bool();
      m.used = p.Member("used").Bool();
      m.linear_residual = p.Member("linear_residual").Vector3();
      led.patches.push_back(m);
    }
    section.summary.leds.push_back(led);
  }
  return section;
}

// ---------------------------------------------------------------------------
// Lights

Json LightsSectionToJson(const LightsSection& section) {
  const LightCalibrationSummary& s = section.summary;
  Json sheets = Json::array();
  for (const WhiteSheetTarget& sheet : section.sheets) {
    sheets.push_back({{"reflectance", sheet.reflectance}, {"height_mm", sheet.height_mm}});
  }
  Json leds = Json::array();
  for (size_t k = 0; k < s.model.size(); ++k) {
    const LedModelFit& m = s.model[k];
    Json led{{"model",
              {{"usable", m.usable},
               {"led", session_internal::LedDescriptionToJson(m.led)},
               {"position_std_mm", Vector3ToJson(m.position_std_mm)},
               {"axis_std_deg", m.axis_std_deg},
               {"mu_std", m.mu_std},
               {"intensity_std", Vector3ToJson(m.intensity_std)},
               {"residual_rms", m.residual_rms},
               {"noise_rms", m.noise_rms},
               {"chi", m.chi},
               {"evaluations", m.evaluations},
               {"termination", m.termination}}}};
    if (k < s.per_pixel.size()) {
      const LedPerPixelFit& p = s.per_pixel[k];
      led["per_pixel"] = {{"iterations", p.iterations},
                          {"converged", p.converged},
                          {"direction_change_deg", p.direction_change_deg},
                          {"intensity_change", p.intensity_change},
                          {"position_in_table_mm", Vector3ToJson(p.position_in_table_mm)},
                          {"residual_rms", p.residual_rms},
                          {"cells_used", p.cells_used},
                          {"cells_dropped", p.cells_dropped},
                          {"direction_file",
                           {{"file", FieldFileName(k, "direction")},
                            {"sha256", 2 * k < section.field_sha256.size() ? section.field_sha256[2 * k] : ""}}},
                          {"intensity_file",
                           {{"file", FieldFileName(k, "intensity")},
                            {"sha256", 2 * k + 1 < section.field_sha256.size() ? section.field_sha256[2 * k + 1] : ""}}}};
    }
    leds.push_back(led);
  }
  Json json{{"date", section.date},
            {"targets", TargetsToJson(section.targets)},
            {"sheets", sheets},
            {"cell_px", s.cell_px},
            {"selected", s.selected == LightCalibrationSummary::Choice::kModel ? "model" : "per_pixel"},
            {"selection_reason", s.selection_reason},
            {"warnings", s.warnings},
            {"leds", leds}};
  if (s.per_pixel_field) {
    const LightFieldGrid& g = s.per_pixel_field->grid();
    json["field_grid"] = {{"width", g.width},       {"height", g.height},   {"origin_x", g.origin_x},
                          {"origin_y", g.origin_y}, {"step", g.step},       {"nodes_x", g.nodes_x},
                          {"nodes_y", g.nodes_y}};
  }
  return json;
}

struct FieldFileEntry {
  std::string path;  // JSON path
  std::string file;
  std::string sha256;
};

LightsSection LightsSectionFromJson(const JsonField& field, std::vector<FieldFileEntry>* files,
                                    std::optional<LightFieldGrid>* grid) {
  field.ExpectOnlyKeys({"date", "targets", "sheets", "cell_px", "selected", "selection_reason", "warnings", "leds",
                        "field_grid"});
  LightsSection section;
  LightCalibrationSummary& s = section.summary;
  s.termination = Termination::kSuccess;
  section.date = field.Member("date").String();
  section.targets = TargetsFromJson(field.Member("targets"));
  for (const JsonField& sheet : field.Member("sheets").Elements()) {
    sheet.ExpectOnlyKeys({"reflectance", "height_mm"});
    WhiteSheetTarget target;
    target.reflectance = sheet.Member("reflectance").Double();
    target.height_mm = sheet.Member("height_mm").Double();
    section.sheets.push_back(target);
  }
  s.cell_px = field.Member("cell_px").Int();
  const JsonField selected = field.Member("selected");
  const std::string choice = selected.String();
  if (choice == "model") {
    s.selected = LightCalibrationSummary::Choice::kModel;
  } else if (choice == "per_pixel") {
    s.selected = LightCalibrationSummary::Choice::kPerPixel;
  } else {
    selected.Fail("must be \"model\" or \"per_pixel\"");
  }
  s.selection_reason = field.Member("selection_reason").String();
  s.warnings = Strings(field.Member("warnings"));
  const std::vector<JsonField> leds = field.Member("leds").Elements();
  for (size_t k = 0; k < leds.size(); ++k) {
    leds[k].ExpectOnlyKeys({"model", "per_pixel"});
    const JsonField model = leds[k].Member("model");
    model.ExpectOnlyKeys({"usable", "led", "position_std_mm", "axis_std_deg", "mu_std", "intensity_std",
                          "residual_rms", "noise_rms", "chi", "evaluations", "termination"});
    LedModelFit m;
    m.usable = model.Member("usable").Bool();
    m.led = session_internal::LedDescriptionFromJson(model.Member("led"));
    session_internal::CheckLedDescription(m.led, field.file(), MemberPath(model.path(), "led"));
    m.position_std_mm = model.Member("position_std_mm").Vector3();
    m.axis_std_deg = model.Member("axis_std_deg").Double();
    m.mu_std = model.Member("mu_std").Double();
    m.intensity_std = model.Member("intensity_std").Vector3();
    m.residual_rms = model.Member("residual_rms").Double();
    m.noise_rms = model.Member("noise_rms").Double();
    m.chi = model.Member("chi").Double();
    m.evaluations = model.Member("evaluations").Int();
    m.termination = model.Member("termination").String();
    s.model.push_back(m);
    if (const auto per_pixel = leds[k].OptionalMember("per_pixel")) {
      per_pixel->ExpectOnlyKeys({"iterations", "converged", "direction_change_deg", "intensity_change",
                                 "position_in_table_mm", "residual_rms", "cells_used", "cells_dropped",
                                 "direction_file", "intensity_file"});
      LedPerPixelFit p;
      p.iterations = per_pixel->Member("iterations").Int();
      p.converged = per_pixel->Member("converged").Bool();
      p.direction_change_deg = Numbers(per_pixel->Member("direction_change_deg"));
      p.intensity_change = Numbers(per_pixel->Member("intensity_change"));
      p.position_in_table_mm = per_pixel->Member("position_in_table_mm").Vector3();
      p.residual_rms = per_pixel->Member("residual_rms").Double();
      p.cells_used = per_pixel->Member("cells_used").Int();
      p.cells_dropped = per_pixel->Member("cells_dropped").Int();
      s.per_pixel.push_back(p);
      for (const char* which : {"direction_file", "intensity_file"}) {
        const JsonField entry = per_pixel->Member(which);
        entry.ExpectOnlyKeys({"file", "sha256"});
        files->push_back({entry.path(), entry.Member("file").String(), entry.Member("sha256").String()});
      }
    }
  }
  if (const auto g = field.OptionalMember("field_grid")) {
    g->ExpectOnlyKeys({"width", "height", "origin_x", "origin_y", "step", "nodes_x", "nodes_y"});
    LightFieldGrid value;
    value.width = g->Member("width").Int();
    value.height = g->Member("height").Int();
    value.origin_x = g->Member("origin_x").Double();
    value.origin_y = g->Member("origin_y").Double();
    value.step = g->Member("step").Double();
    value.nodes_x = g->Member("nodes_x").Int();
    value.nodes_y = g->Member("nodes_y").Int();
    try {
      value.Check();
    } catch (const std::invalid_argument& error) {
      ThrowFieldError(field.file(), g->path(), error.what());
    }
    *grid = value;
  }
  return section;
}

// ---------------------------------------------------------------------------

void CheckDate(const std::string& date, const std::string& file, const std::string& path) {
  ParseUtcTimestamp(date, file + ": " + path);
}

void CheckFinite(double value, const std::string& file, const std::string& path) {
  if (!std::isfinite(value)) ThrowFieldError(file, path, FormatValue(value) + " must be finite");
}

bool IsSha256(const std::string& text) {
  if (text.size() != 64) return false;
  for (const char c : text) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

void CheckTargets(const std::vector<TargetCaptureRecord>& targets, const char* expected_kind, const std::string& file,
                  const std::string& section) {
  const std::string path = MemberPath(section, "targets");
  if (targets.empty()) ThrowFieldError(file, path, "[] must list the target sessions the calibration read");
  for (size_t i = 0; i < targets.size(); ++i) {
    const TargetCaptureRecord& t = targets[i];
    const std::string element = ElementPath(path, i);
    if (t.kind != expected_kind) {
      ThrowFieldError(file, MemberPath(element, "kind"),
                      FormatValue(t.kind) + " must be \"" + expected_kind + "\" for this section");
    }
    for (const auto& [name, sha] : {std::pair{"manifest_sha256", &t.manifest_sha256}, {"target_sha256", &t.target_sha256}}) {
      if (!IsSha256(*sha)) ThrowFieldError(file, MemberPath(element, name), FormatValue(*sha) + " must be 64 lower-case hex digits");
    }
    for (size_t f = 0; f < t.frame_sha256.size(); ++f) {
      if (!IsSha256(t.frame_sha256[f])) {
        ThrowFieldError(file, ElementPath(MemberPath(element, "frame_sha256"), f),
                        FormatValue(t.frame_sha256[f]) + " must be 64 lower-case hex digits");
      }
    }
  }
}

int64_t DaysFromCivil(int64_t y, unsigned m, unsigned d) {
  // Days since 1970-01-01 of a proleptic Gregorian date.
  y -= m <= 2;
  const int64_t era = (y >= 0 ? y : y - 399) / 400;
  const unsigned yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<int64_t>(doe) - 719468;
}

}  // namespace

std::chrono::system_clock::time_point ParseUtcTimestamp(const std::string& text, const std::string& what) {
  int year, month, day, hour, minute, second;
  int consumed = 0;
  if (std::sscanf(text.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d%n", &year, &month, &day, &hour, &minute, &second,
                  &consumed) != 6 ||
      consumed != 19 || month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59 || second > 60) {
    throw SessionError(what + ": " + FormatValue(text) + " must be an ISO 8601 UTC time like 2024-05-01T12:34:56Z");
  }
  size_t pos = 19;
  double fraction = 0;
  if (pos < text.size() && text[pos] == '.') {
    const size_t start = ++pos;
    while (pos < text.size() && text[pos] >= '0' && text[pos] <= '9') ++pos;
    if (pos == start) throw SessionError(what + ": " + FormatValue(text) + " has an empty fraction of a second");
    fraction = std::stod("0." + text.substr(start, pos - start));
  }
  if (pos + 1 != text.size() || text[pos] != 'Z') {
    throw SessionError(what + ": " + FormatValue(text) + " must end in Z (UTC)");
  }
  const int64_t seconds = DaysFromCivil(year, month, day) * 86400 + hour * 3600 + minute * 60 + second;
  return std::chrono::system_clock::time_point(std::chrono::duration_cast<std::chrono::system_clock::duration>(
      std::chrono::duration<double>(static_cast<double>(seconds) + fraction)));
}

void CheckCalibrationSet(const CalibrationSet& set, const std::string& file) {
  if (set.schema_version != kCalibrationSetSchemaVersion) {
    ThrowFieldError(file, "schema_version",
                    std::to_string(set.schema_version) + " must be " + std::to_string(kCalibrationSetSchemaVersion));
  }
  CheckDate(set.created, file, "created");
  const CalibratedCameraIdentity& id = set.camera;
  if (id.model.empty()) ThrowFieldError(file, "camera.model", "\"\" must name the camera model");
  if (id.width <= 0) ThrowFieldError(file, "camera.width", std::to_string(id.width) + " must be > 0");
  if (id.height <= 0) ThrowFieldError(file, "camera.height", std::to_string(id.height) + " must be > 0");
  if (set.camera_calibration) {
    const CameraCalibrationSection& c = *set.camera_calibration;
    CheckDate(c.date, file, "camera.date");
    CheckTargets(c.targets, "checkerboard", file, "camera_calibration");
    session_internal::CheckCameraGeometry(c.summary.camera, file, "camera_calibration.geometry");
    const CameraIntrinsics& k = c.summary.camera.intrinsics;
    if (k.width != id.width || k.height != id.height) {
      ThrowFieldError(file, "camera_calibration.geometry.intrinsics.width",
                      std::to_string(k.width) + "x" + std::to_string(k.height) + " differs from camera " +
                          std::to_string(id.width) + "x" + std::to_string(id.height));
    }
    CheckFinite(c.summary.reprojection_rms_px, file, "camera_calibration.reprojection_rms_px");
    CheckFinite(c.summary.table_view_rms_px, file, "camera_calibration.table_view_rms_px");
  }
  size_t num_leds = 0;
  if (set.white_balance) {
    const WhiteBalanceSection& w = *set.white_balance;
    CheckDate(w.date, file, "white_balance.date");
    CheckTargets(w.targets, "gray_chart", file, "white_balance");
    if (w.summary.leds.empty()) ThrowFieldError(file, "white_balance.leds", "[] must hold one entry per LED");
    num_leds = w.summary.leds.size();
    for (size_t k = 0; k < w.summary.leds.size(); ++k) {
      const Eigen::Vector3d& gains = w.summary.leds[k].gains;
      if (!gains.allFinite() || !(gains.minCoeff() > 0)) {
        ThrowFieldError(file, MemberPath(ElementPath("white_balance.leds", k), "gains"),
                        FormatValue(gains) + " must be finite and > 0");
      }
    }
  }
  if (set.lights) {
    const LightsSection& l = *set.lights;
    CheckDate(l.date, file, "lights.date");
    CheckTargets(l.targets, "white_sheet", file, "lights");
    if (l.sheets.size() != l.targets.size()) {
      ThrowFieldError(file, "lights.sheets",
                      std::to_string(l.sheets.size()) + " sheets for " + std::to_string(l.targets.size()) +
                          " targets; one per target required");
    }
    if (l.summary.model.empty()) ThrowFieldError(file, "lights.leds", "[] must hold one entry per LED");
    if (num_leds != 0 && l.summary.model.size() != num_leds) {
      ThrowFieldError(file, "lights.leds",
                      std::to_string(l.summary.model.size()) + " LEDs, but white_balance.leds has " +
                          std::to_string(num_leds));
    }
    if (l.summary.selected == LightCalibrationSummary::Choice::kPerPixel && !l.summary.per_pixel_field) {
      ThrowFieldError(file, "lights.selected", "\"per_pixel\" needs the per-pixel field (field_grid and files)");
    }
    if (l.summary.per_pixel_field) {
      const LightFieldGrid& g = l.summary.per_pixel_field->grid();
      if (g.width != id.width || g.height != id.height) {
        ThrowFieldError(file, "lights.field_grid.width",
                        std::to_string(g.width) + "x" + std::to_string(g.height) + " differs from camera " +
                            std::to_string(id.width) + "x" + std::to_string(id.height));
      }
    }
  }
}

CalibrationSet LoadCalibrationSet(const fs::path& dir, const CalibrationLoadOptions& options) {
  const fs::path manifest = dir / kCalibrationManifestName;
  const std::string file = manifest.string();
  std::error_code error;
  if (!fs::is_regular_file(manifest, error)) {
    throw SessionError(file + ": does not exist (is " + dir.string() + " a calibration set?)");
  }
  const std::vector<uint8_t> bytes = AsSessionError([&] { return ReadFileBytes(manifest); });
  const Json json = session_internal::ParseJson(std::string(bytes.begin(), bytes.end()), file);
  const JsonField root(json, "", file);
  const JsonField schema = root.Member("schema");
  if (schema.String() != kSchemaName) schema.Fail(std::string("must be \"") + kSchemaName + "\"");
  const JsonField version = root.Member("schema_version");
  if (version.Int() > kCalibrationSetSchemaVersion) {
    version.Fail("is newer than this scanbench reads (" + std::to_string(kCalibrationSetSchemaVersion) +
                 "); update scanbench");
  }
  if (version.Int() < kCalibrationSetSchemaVersion) {
    version.Fail("is older than this scanbench reads (" + std::to_string(kCalibrationSetSchemaVersion) + ")");
  }
  root.ExpectOnlyKeys({"schema", "schema_version", "created", "software_version", "camera", "camera_calibration",
                       "white_balance", "lights"});
  CalibrationSet set;
  set.schema_version = version.Int();
  set.created = root.Member("created").String();
  set.software_version = root.Member("software_version").String();
  const JsonField camera = root.Member("camera");
  camera.ExpectOnlyKeys({"make", "model", "serial", "lens", "width", "height"});
  set.camera.make = camera.Member("make").String();
  set.camera.model = camera.Member("model").String();
  set.camera.serial = camera.Member("serial").String();
  set.camera.lens = camera.Member("lens").String();
  set.camera.width = camera.Member("width").Int();
  set.camera.height = camera.Member("height").Int();
  if (const auto section = root.OptionalMember("camera_calibration")) {
    set.camera_calibration = CameraSectionFromJson(*section);
  }
  if (const auto section = root.OptionalMember("white_balance")) set.white_balance = WhiteSectionFromJson(*section);
  std::vector<FieldFileEntry> files;
  std::optional<LightFieldGrid> grid;
  if (const auto section = root.OptionalMember("lights")) set.lights = LightsSectionFromJson(*section, &files, &grid);

  // The per-pixel field: every file inside lights/, present, hashing right,
  // of the grid's size.
  if (set.lights && grid) {
    const size_t num_leds = set.lights->summary.model.size();
    if (files.size() != 2 * num_leds) {
      ThrowFieldError(file, "lights.leds", "a field_grid needs direction_file and intensity_file for every LED");
    }
    std::vector<float> dirs(grid->num_nodes() * num_leds * 3), intensities(dirs.size());
    for (size_t f = 0; f < files.size(); ++f) {
      const FieldFileEntry& entry = files[f];
      const fs::path relative(entry.file);
      if (relative.is_absolute() || entry.file.find("..") != std::string::npos ||
          relative.begin() == relative.end() || *relative.begin() != kLightsFolder) {
        ThrowFieldError(file, MemberPath(entry.path, "file"), FormatValue(entry.file) + " must lie in lights/");
      }
      const fs::path full = dir / relative;
      if (!fs::is_regular_file(full, error)) {
        ThrowFieldError(file, MemberPath(entry.path, "file"), FormatValue(entry.file) + " does not exist in " + dir.string());
      }
      if (options.verify_checksums) {
        const std::string actual = AsSessionError([&] { return Sha256HexOfFile(full); });
        if (actual != entry.sha256) {
          ThrowFieldError(file, MemberPath(entry.path, "sha256"),
                          FormatValue(entry.sha256) + " mismatch: file " + entry.file + " has " + actual);
        }
      }
      const ImageF image = AsSessionError([&] { return ReadImageFloat(full); });
      if (image.width() != grid->nodes_x || image.height() != grid->nodes_y || image.channels() != 3) {
        ThrowFieldError(file, MemberPath(entry.path, "file"),
                        FormatValue(entry.file) + " is " + std::to_string(image.width()) + "x" +
                            std::to_string(image.height()) + "x" + std::to_string(image.channels()) + "; field_grid needs " +
                            std::to_string(grid->nodes_x) + "x" + std::to_string(grid->nodes_y) + "x3");
      }
      const size_t led = f / 2;
      std::vector<float>& target = f % 2 == 0 ? dirs : intensities;
      for (size_t n = 0; n < grid->num_nodes(); ++n) {
        for (int c = 0; c < 3; ++c) target[(n * num_leds + led) * 3 + c] = image.data()[3 * n + c];
      }
    }
    try {
      set.lights->summary.per_pixel_field.emplace(*grid, static_cast<int>(num_leds), std::move(dirs),
                                                  std::move(intensities));
    } catch (const std::invalid_argument& bad) {
      ThrowFieldError(file, "lights.field_grid", std::string("the field files are unusable: ") + bad.what());
    }
    for (size_t f = 0; f < files.size(); ++f) set.lights->field_sha256.push_back(files[f].sha256);
  }
  CheckCalibrationSet(set, file);
  return set;
}

void WriteCalibrationSet(const fs::path& dir, CalibrationSet& set) {
  const fs::path manifest = dir / kCalibrationManifestName;
  const std::string file = manifest.string();
  CheckCalibrationSet(set, file);
  AsSessionError([&] { fs::create_directories(dir); });
  if (set.lights && set.lights->summary.per_pixel_field) {
    const SampledLightField& field = *set.lights->summary.per_pixel_field;
    const LightFieldGrid& g = field.grid();
    const size_t num_leds = static_cast<size_t>(field.num_lights());
    AsSessionError([&] { fs::create_directories(dir / kLightsFolder); });
    set.lights->field_sha256.clear();
    for (size_t k = 0; k < num_leds; ++k) {
      for (const bool direction : {true, false}) {
        ImageF image(g.nodes_x, g.nodes_y, 3);
        const std::vector<float>& values = direction ? field.node_light_dirs() : field.node_rgb_intensities();
        for (size_t n = 0; n < g.num_nodes(); ++n) {
          for (int c = 0; c < 3; ++c) image.data()[3 * n + c] = values[(n * num_leds + k) * 3 + c];
        }
        const fs::path path = dir / FieldFileName(k, direction ? "direction" : "intensity");
        AsSessionError([&] { WriteExr(path, image, OverwritePolicy::kReplace); });
        set.lights->field_sha256.push_back(AsSessionError([&] { return Sha256HexOfFile(path); }));
      }
    }
  }
  Json json{{"schema", kSchemaName},
            {"schema_version", set.schema_version},
            {"created", set.created},
            {"software_version", set.software_version},
            {"camera",
             {{"make", set.camera.make},
              {"model", set.camera.model},
              {"serial", set.camera.serial},
              {"lens", set.camera.lens},
              {"width", set.camera.width},
              {"height", set.camera.height}}}};
  if (set.camera_calibration) json["camera_calibration"] = CameraSectionToJson(*set.camera_calibration);
  if (set.white_balance) json["white_balance"] = WhiteSectionToJson(*set.white_balance);
  if (set.lights) json["lights"] = LightsSectionToJson(*set.lights);
  const std::string text = session_internal::DumpJson(json);
  AsSessionError([&] { WriteFileAtomic(manifest, text, OverwritePolicy::kReplace); });
}

void CheckCalibrationFitsSession(const CalibrationSet& set, const std::string& set_name, const Session& session,
                                 const std::string& session_name) {
  const CalibratedCameraIdentity& id = set.camera;
  const CameraInfo& camera = session.camera;
  auto refuse = [&](const std::string& field, const std::string& ours, const std::string& theirs,
                    const std::string& what) {
    throw SessionError(set_name + ": camera." + field + " " + FormatValue(ours) + " differs from " + session_name +
                       " camera." + field + " " + FormatValue(theirs) + ": a calibration of " + what +
                       " is refused");
  };
  if (id.make != camera.make) refuse("make", id.make, camera.make, "another camera");
  if (id.model != camera.model) refuse("model", id.model, camera.model, "another camera");
  if (id.serial != camera.serial) refuse("serial", id.serial, camera.serial, "another camera body");
  if (id.lens != camera.lens) refuse("lens", id.lens, camera.lens, "another lens");
  if (id.width != camera.width || id.height != camera.height) {
    throw SessionError(set_name + ": camera size " + std::to_string(id.width) + "x" + std::to_string(id.height) +
                       " differs from " + session_name + " camera.settings " + std::to_string(camera.width) + "x" +
                       std::to_string(camera.height) + ": a calibration at another resolution is refused");
  }
  auto check_leds = [&](const std::vector<int>& ids, const char* section) {
    if (ids.size() != session.rig.leds.size()) {
      throw SessionError(set_name + ": " + section + " has " + std::to_string(ids.size()) + " LEDs but " +
                         session_name + " rig.leds has " + std::to_string(session.rig.leds.size()) +
                         ": a calibration of another LED set is refused");
    }
    for (size_t k = 0; k < ids.size(); ++k) {
      if (ids[k] != session.rig.leds[k].id) {
        throw SessionError(set_name + ": " + section + "[" + std::to_string(k) + "] is LED id " +
                           std::to_string(ids[k]) + " but " + session_name + " rig.leds[" + std::to_string(k) +
                           "].id is " + std::to_string(session.rig.leds[k].id));
      }
    }
  };
  if (set.lights) {
    std::vector<int> ids;
    for (const LedModelFit& fit : set.lights->summary.model) ids.push_back(fit.led.id);
    check_leds(ids, "lights.leds");
  }
  if (set.white_balance) check_leds(set.white_balance->led_ids, "white_balance.leds");
}

std::optional<std::string> CalibrationAgeWarning(const CalibrationSet& set, const std::string& set_name,
                                                 double max_age_days, std::chrono::system_clock::time_point now) {
  std::string oldest_name;
  std::optional<std::chrono::system_clock::time_point> oldest;
  auto consider = [&](const std::string& date, const char* section) {
    const auto time = ParseUtcTimestamp(date, set_name + ": " + section);
    if (!oldest || time < *oldest) {
      oldest = time;
      oldest_name = std::string(section) + " " + date;
    }
  };
  if (set.camera_calibration) consider(set.camera_calibration->date, "camera_calibration.date");
  if (set.white_balance) consider(set.white_balance->date, "white_balance.date");
  if (set.lights) consider(set.lights->date, "lights.date");
  if (!oldest) return std::nullopt;
  const double age_days = std::chrono::duration<double>(now - *oldest).count() / 86400.0;
  if (age_days <= max_age_days) return std::nullopt;
  char text[64];
  std::snprintf(text, sizeof(text), "%.1f days old", age_days);
  char limit[64];
  std::snprintf(limit, sizeof(limit), "%g days", max_age_days);
  return set_name + ": stale calibration: " + oldest_name + " is " + text + ", older than the limit of " + limit +
         "; recalibrate (LEDs age and the rig gets knocked)";
}

TargetCaptureRecord MakeTargetCaptureRecord(const fs::path& session_dir, const Session& session,
                                            const std::string& kind) {
  TargetCaptureRecord record;
  record.session = session_dir.string();
  record.kind = kind;
  record.captured = session.created;
  record.manifest_sha256 = AsSessionError([&] { return Sha256HexOfFile(session_dir / "session.json"); });
  record.target_sha256 = AsSessionError([&] { return Sha256HexOfFile(session_dir / kCalibrationTargetFileName); });
  for (const FrameRecord& frame : session.frames) record.frame_sha256.push_back(frame.sha256);
  return record;
}

}  // namespace scanbench
