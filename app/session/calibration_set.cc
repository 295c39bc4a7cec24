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
using session_internal::CheckSha256Format;
using session_internal::FromJsonObject;
using session_internal::Presence;
using session_internal::RethrowAsSessionError;
using session_internal::ToJsonObject;

namespace {

constexpr char kSchemaName[] = "scanbench.calibration_set";
constexpr char kLightsFolder[] = "lights";

std::string FieldFileName(size_t led, const char* what) {
  char name[64];
  std::snprintf(name, sizeof(name), "%s/led_%02zu_%s.exr", kLightsFolder, led, what);
  return name;
}

// ---------------------------------------------------------------------------
// Records

template <typename Io>
void TargetRecordFields(Io& io, TargetCaptureRecord& t) {
  io.Field("session", t.session);
  io.Field("kind", t.kind);
  io.Field("captured", t.captured);
  io.Field("manifest_sha256", t.manifest_sha256);
  io.Field("target_sha256", t.target_sha256);
  io.Field("frame_sha256", t.frame_sha256);
}

template <typename Io>
void TargetsField(Io& io, std::vector<TargetCaptureRecord>& targets) {
  io.Array("targets", targets, [](auto& record_io, TargetCaptureRecord& t) { TargetRecordFields(record_io, t); });
}

// [a, b] of two numbers; `rule` names them.
template <typename Io>
void PairField(Io& io, std::string_view key, double& a, double& b, const char* rule) {
  io.Custom(
      key, [&] { return Json::array({a, b}); },
      [&, rule](const JsonField& field) {
        std::vector<double> values;
        session_internal::ValueFromJson(field, values);
        if (values.size() != 2) field.Fail(rule);
        a = values[0];
        b = values[1];
      });
}

// ---------------------------------------------------------------------------
// Camera

constexpr const char* kIntrinsicsStdNames[9] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};

template <typename Io>
void ViewFields(Io& io, CalibrationViewReport& v) {
  io.Field("name", v.name);
  io.Field("used", v.used);
  io.Field("reason", v.reason);
  io.Field("on_table", v.on_table);
  io.Field("edge_width_px", v.edge_width_px);
  io.Field("contrast", v.contrast);
  io.Field("rms_px", v.rms_px);
}

template <typename Io>
void CameraSectionFields(Io& io, CameraCalibrationSection& section) {
  CameraCalibrationSummary& s = section.summary;
  io.Field("date", section.date);
  TargetsField(io, section.targets);
  io.Object("board", [&](auto& board) {
    // Stored as numbers: a set written before the counts were checked as integers still reads.
    board.Custom(
        "inner_corners", [&] { return Json::array({section.board.inner_corners_x, section.board.inner_corners_y}); },
        [&](const JsonField& corners) {
          std::vector<double> counts;
          session_internal::ValueFromJson(corners, counts);
          if (counts.size() != 2) corners.Fail("must be [corners along a row, along a column]");
          section.board.inner_corners_x = static_cast<int>(counts[0]);
          section.board.inner_corners_y = static_cast<int>(counts[1]);
        });
    board.Field("square_mm", section.board.square_mm);
  });
  io.Custom(
      "geometry", [&] { return session_internal::CameraGeometryToJson(s.camera); },
      [&](const JsonField& geometry) { s.camera = session_internal::CameraGeometryFromJson(geometry); });
  io.Field("reprojection_rms_px", s.reprojection_rms_px);
  io.Field("table_view_rms_px", s.table_view_rms_px);
  io.Field("num_used_views", s.num_used_views);
  io.Object("intrinsics_std", [&](auto& stds) {
    for (int i = 0; i < 9; ++i) stds.Field(kIntrinsicsStdNames[i], s.intrinsics_std[i]);
  });
  io.Array("views", s.views, [](auto& view_io, CalibrationViewReport& v) { ViewFields(view_io, v); });
}

// ---------------------------------------------------------------------------
// White balance

template <typename Io>
void PatchFields(Io& io, PatchMeasurement& p) {
  io.Field("name", p.name);
  io.Field("reflectance", p.reflectance);
  io.Field("mean", p.mean);
  io.Field("standard_error", p.standard_error);
  io.Custom(
      "samples", [&] { return Json::array({p.samples[0], p.samples[1], p.samples[2]}); },
      [&](const JsonField& samples) {
        const Eigen::Vector3d counts = samples.Vector3();
        for (int c = 0; c < 3; ++c) p.samples[c] = static_cast<int>(counts[c]);
      });
  io.Field("clipped", p.clipped);
  io.Field("underexposed", p.underexposed);
  io.Field("nonlinear", p.nonlinear);
  io.Field("used", p.used);
  io.Field("linear_residual", p.linear_residual);
}

// One entry of white_balance.leds: the LED's figures and its firmware id.
struct WhiteLedEntry {
  LedWhiteBalance led;
  int id = 0;
};

template <typename Io>
void WhiteLedFields(Io& io, WhiteLedEntry& entry) {
  LedWhiteBalance& led = entry.led;
  io.Field("led_index", led.led_index);
  io.Field("id", entry.id);
  io.Field("gains", led.gains);
  io.Field("gains_std", led.gains_std);
  io.Field("response_exponent", led.response_exponent);
  io.Field("linearity_rms", led.linearity_rms);
  PairField(io, "linear_range", led.linear_range_min, led.linear_range_max, "must be [lowest, highest]");
  io.Field("used_patches", led.used_patches);
  io.Array("patches", led.patches, [](auto& patch_io, PatchMeasurement& p) { PatchFields(patch_io, p); });
}

template <typename Io>
void WhiteSectionFields(Io& io, WhiteBalanceSection& section) {
  io.Field("date", section.date);
  TargetsField(io, section.targets);
  io.Custom(
      "leds",
      [&] {
        Json leds = Json::array();
        for (size_t k = 0; k < section.summary.leds.size(); ++k) {
          const WhiteLedEntry entry{section.summary.leds[k],
                                    k < section.led_ids.size() ? section.led_ids[k] : static_cast<int>(k)};
          leds.push_back(ToJsonObject(entry, [](auto& led_io, WhiteLedEntry& e) { WhiteLedFields(led_io, e); }));
        }
        return leds;
      },
      [&](const JsonField& leds) {
        for (const JsonField& element : leds.Elements()) {
          const auto entry =
              FromJsonObject<WhiteLedEntry>(element, [](auto& led_io, WhiteLedEntry& e) { WhiteLedFields(led_io, e); });
          section.summary.leds.push_back(entry.led);
          section.led_ids.push_back(entry.id);
        }
      });
}

// ---------------------------------------------------------------------------
// Lights

struct FieldFileEntry {
  std::string path;  // JSON path, for errors
  std::string file;
  std::string sha256;
};

// One entry of lights.leds: the LED model's fit, and the per-pixel field's
// when there is one, with its two files.
struct LightLedEntry {
  LedModelFit model;
  std::optional<LedPerPixelFit> per_pixel;
  FieldFileEntry direction_file, intensity_file;
};

template <typename Io>
void FieldFileFields(Io& io, std::string_view key, FieldFileEntry& entry) {
  io.Object(key, [&](auto& file_io) {
    file_io.Field("file", entry.file);
    file_io.Field("sha256", entry.sha256);
  });
}

template <typename Io>
void ModelFitFields(Io& io, LedModelFit& m) {
  io.Field("usable", m.usable);
  io.Custom(
      "led", [&] { return session_internal::LedDescriptionToJson(m.led); },
      [&](const JsonField& led) {
        m.led = session_internal::LedDescriptionFromJson(led);
        session_internal::CheckLedDescription(m.led, led.file(), led.path());
      });
  io.Field("position_std_mm", m.position_std_mm);
  io.Field("axis_std_deg", m.axis_std_deg);
  io.Field("mu_std", m.mu_std);
  io.Field("intensity_std", m.intensity_std);
  io.Field("residual_rms", m.residual_rms);
  io.Field("noise_rms", m.noise_rms);
  io.Field("chi", m.chi);
  io.Field("evaluations", m.evaluations);
  io.Field("termination", m.termination);
}

template <typename Io>
void LightLedFields(Io& io, LightLedEntry& entry) {
  io.Object("model", [&](auto& model) { ModelFitFields(model, entry.model); });
  io.Optional("per_pixel", entry.per_pixel, [&](auto& p_io, LedPerPixelFit& p) {
    p_io.Field("iterations", p.iterations);
    p_io.Field("converged", p.converged);
    p_io.Field("direction_change_deg", p.direction_change_deg);
    p_io.Field("intensity_change", p.intensity_change);
    p_io.Field("position_in_table_mm", p.position_in_table_mm);
    p_io.Field("residual_rms", p.residual_rms);
    p_io.Field("cells_used", p.cells_used);
    p_io.Field("cells_dropped", p.cells_dropped);
    FieldFileFields(p_io, "direction_file", entry.direction_file);
    FieldFileFields(p_io, "intensity_file", entry.intensity_file);
  });
}

template <typename Io>
void GridFields(Io& io, LightFieldGrid& g) {
  io.Field("width", g.width);
  io.Field("height", g.height);
  io.Field("origin_x", g.origin_x);
  io.Field("origin_y", g.origin_y);
  io.Field("step", g.step);
  io.Field("nodes_x", g.nodes_x);
  io.Field("nodes_y", g.nodes_y);
}

const char* ChoiceName(LightCalibrationSummary::Choice choice) {
  return choice == LightCalibrationSummary::Choice::kModel ? "model" : "per_pixel";
}

// What reading the lights section finds besides the section: the field
// files (loaded after the manifest) and their grid.
struct LightsFieldOnDisk {
  std::vector<FieldFileEntry> files;
  std::optional<LightFieldGrid> grid;
};

template <typename Io>
void LightsSectionFields(Io& io, LightsSection& section, LightsFieldOnDisk* on_disk) {
  LightCalibrationSummary& s = section.summary;
  io.Field("date", section.date);
  TargetsField(io, section.targets);
  io.Array("sheets", section.sheets, [](auto& sheet_io, WhiteSheetTarget& sheet) {
    sheet_io.Field("reflectance", sheet.reflectance);
    sheet_io.Field("height_mm", sheet.height_mm);
  });
  io.Field("cell_px", s.cell_px);
  io.Custom(
      "selected", [&] { return Json(ChoiceName(s.selected)); },
      [&](const JsonField& selected) {
        const std::string choice = selected.String();
        if (choice == ChoiceName(LightCalibrationSummary::Choice::kModel)) {
          s.selected = LightCalibrationSummary::Choice::kModel;
        } else if (choice == ChoiceName(LightCalibrationSummary::Choice::kPerPixel)) {
          s.selected = LightCalibrationSummary::Choice::kPerPixel;
        } else {
          selected.Fail("must be \"model\" or \"per_pixel\"");
        }
      });
  io.Field("selection_reason", s.selection_reason);
  io.Field("warnings", s.warnings);
  auto led_fields = [](auto& led_io, LightLedEntry& entry) { LightLedFields(led_io, entry); };
  io.Custom(
      "leds",
      [&] {
        Json leds = Json::array();
        for (size_t k = 0; k < s.model.size(); ++k) {
          LightLedEntry entry{s.model[k], std::nullopt, {}, {}};
          if (k < s.per_pixel.size()) {
            entry.per_pixel = s.per_pixel[k];
            auto sha = [&](size_t i) { return i < section.field_sha256.size() ? section.field_sha256[i] : ""; };
            entry.direction_file = {"", FieldFileName(k, "direction"), sha(2 * k)};
            entry.intensity_file = {"", FieldFileName(k, "intensity"), sha(2 * k + 1)};
          }
          leds.push_back(ToJsonObject(entry, led_fields));
        }
        return leds;
      },
      [&](const JsonField& leds) {
        for (const JsonField& element : leds.Elements()) {
          LightLedEntry entry = FromJsonObject<LightLedEntry>(element, led_fields);
          s.model.push_back(entry.model);
          if (!entry.per_pixel) continue;
          s.per_pixel.push_back(*entry.per_pixel);
          const std::string per_pixel_path = MemberPath(element.path(), "per_pixel");
          entry.direction_file.path = MemberPath(per_pixel_path, "direction_file");
          entry.intensity_file.path = MemberPath(per_pixel_path, "intensity_file");
          on_disk->files.push_back(entry.direction_file);
          on_disk->files.push_back(entry.intensity_file);
        }
      });
  io.Custom(
      "field_grid",
      [&]() -> std::optional<Json> {
        if (!s.per_pixel_field) return std::nullopt;
        return ToJsonObject(s.per_pixel_field->grid(), [](auto& grid_io, LightFieldGrid& g) { GridFields(grid_io, g); });
      },
      [&](const JsonField& field) {
        const auto grid =
            FromJsonObject<LightFieldGrid>(field, [](auto& grid_io, LightFieldGrid& g) { GridFields(grid_io, g); });
        try {
          grid.Check();
        } catch (const std::invalid_argument& error) {
          ThrowFieldError(field.file(), field.path(), error.what());
        }
        on_disk->grid = grid;
      },
      Presence::kOptionalOnRead);
}

// ---------------------------------------------------------------------------
// Colour

Json Matrix3ToJson(const Eigen::Matrix3d& m) {
  Json rows = Json::array();
  for (int r = 0; r < 3; ++r) rows.push_back(Json::array({m(r, 0), m(r, 1), m(r, 2)}));
  return rows;
}

Eigen::Matrix3d Matrix3FromJson(const JsonField& field) {
  const std::vector<JsonField> rows = field.Elements();
  if (rows.size() != 3) field.Fail("must be 3 rows of 3 numbers");
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) m.row(r) = rows[r].Vector3().transpose();
  return m;
}

template <typename Io>
void ColorPatchFields(Io& io, ColorPatchResult& p) {
  io.Field("name", p.name);
  io.Field("used", p.used);
  io.Field("status", p.status);
  io.Field("measured_camera", p.measured_camera);
  io.Field("reference_linear_rec709", p.reference_linear_rec709);
  io.Field("corrected_linear_rec709", p.corrected_linear_rec709);
  io.Field("delta_e_before", p.delta_e_before);
  io.Field("delta_e_after", p.delta_e_after);
}

template <typename Io>
void RawFileFields(Io& io, RawFileRecord& r) {
  io.Field("path", r.path);
  io.Field("sha256", r.sha256);
}

template <typename Io>
void ColorSectionFields(Io& io, ColorSection& section) {
  io.Field("date", section.date);
  TargetsField(io, section.targets);
  io.Array("raw_files", section.raw_files, [](auto& file_io, RawFileRecord& r) { RawFileFields(file_io, r); });
  io.Field("white_reference", section.white_reference);
  io.Field("num_frames", section.num_frames);
  ColorCorrectionSummary& s = section.summary;
  io.Field("method", s.method);
  io.Field("used_patches", s.used_patches);
  io.Custom(
      "rec709_from_camera", [&] { return Matrix3ToJson(s.rec709_from_camera); },
      [&](const JsonField& field) { s.rec709_from_camera = Matrix3FromJson(field); });
  io.Field("mean_delta_e_before", s.mean_delta_e_before);
  io.Field("max_delta_e_before", s.max_delta_e_before);
  io.Field("mean_delta_e_after", s.mean_delta_e_after);
  io.Field("max_delta_e_after", s.max_delta_e_after);
  io.Array("patches", s.patches, [](auto& patch_io, ColorPatchResult& p) { ColorPatchFields(patch_io, p); });
}

// ---------------------------------------------------------------------------
// The set

template <typename Io>
void CalibrationSetFields(Io& io, CalibrationSet& set, LightsFieldOnDisk* on_disk) {
  io.Custom(
      "schema", [] { return Json(kSchemaName); }, [](const JsonField&) { /* checked first, by CheckSchema */ });
  io.Field("schema_version", set.schema_version);
  io.Field("created", set.created);
  io.Field("software_version", set.software_version);
  io.Object("camera", [&](auto& camera) {
    camera.Field("make", set.camera.make);
    camera.Field("model", set.camera.model);
    camera.Field("serial", set.camera.serial);
    camera.Field("lens", set.camera.lens);
    camera.Field("width", set.camera.width);
    camera.Field("height", set.camera.height);
  });
  io.Optional("camera_calibration", set.camera_calibration,
              [](auto& section_io, CameraCalibrationSection& section) { CameraSectionFields(section_io, section); });
  io.Optional("white_balance", set.white_balance,
              [](auto& section_io, WhiteBalanceSection& section) { WhiteSectionFields(section_io, section); });
  io.Optional("lights", set.lights, [on_disk](auto& section_io, LightsSection& section) {
    LightsSectionFields(section_io, section, on_disk);
  });
  io.Optional("color", set.color, [](auto& section_io, ColorSection& section) { ColorSectionFields(section_io, section); });
}

// The schema and its version say how to read the rest, so they come first.
void CheckSchema(const JsonField& root) {
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
}

// ---------------------------------------------------------------------------

void CheckDate(const std::string& date, const std::string& file, const std::string& path) {
  session_internal::ParseIso8601Utc(date, file + ": " + path);
}

void CheckFinite(double value, const std::string& file, const std::string& path) {
  if (!std::isfinite(value)) ThrowFieldError(file, path, FormatValue(value) + " must be finite");
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
    CheckSha256Format(t.manifest_sha256, file, MemberPath(element, "manifest_sha256"));
    CheckSha256Format(t.target_sha256, file, MemberPath(element, "target_sha256"));
    for (size_t f = 0; f < t.frame_sha256.size(); ++f) {
      CheckSha256Format(t.frame_sha256[f], file, ElementPath(MemberPath(element, "frame_sha256"), f));
    }
  }
}

void CheckColorSection(const ColorSection& c, const std::string& file) {
  CheckDate(c.date, file, "color.date");
  if (c.targets.empty() && c.raw_files.empty()) {
    ThrowFieldError(file, "color.targets", "[] and raw_files [] must list what the colour calibration read");
  }
  if (!c.targets.empty()) CheckTargets(c.targets, "color_chart", file, "color");
  for (size_t i = 0; i < c.raw_files.size(); ++i) {
    CheckSha256Format(c.raw_files[i].sha256, file, MemberPath(ElementPath("color.raw_files", i), "sha256"));
  }
  if (c.white_reference != "light_field" && c.white_reference != "neutral_patches") {
    ThrowFieldError(file, "color.white_reference",
                    FormatValue(c.white_reference) + " must be \"light_field\" or \"neutral_patches\"");
  }
  const Eigen::Matrix3d& m = c.summary.rec709_from_camera;
  if (!m.allFinite() || !(std::abs(m.determinant()) > 1e-9)) {
    ThrowFieldError(file, "color.rec709_from_camera", "must be 3x3 finite numbers with a non-zero determinant");
  }
  for (const double figure : {c.summary.mean_delta_e_before, c.summary.max_delta_e_before,
                              c.summary.mean_delta_e_after, c.summary.max_delta_e_after}) {
    if (!std::isfinite(figure) || figure < 0) {
      ThrowFieldError(file, "color.mean_delta_e_after", FormatValue(figure) + " must be finite and >= 0");
    }
  }
}

}  // namespace

std::chrono::system_clock::time_point ParseUtcTimestamp(const std::string& text, const std::string& what) {
  return session_internal::ParseIso8601Utc(text, what);
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
  if (set.color) CheckColorSection(*set.color, file);
}

CalibrationSet LoadCalibrationSet(const fs::path& dir, const CalibrationLoadOptions& options) {
  const fs::path manifest = dir / kCalibrationManifestName;
  const std::string file = manifest.string();
  std::error_code error;
  if (!fs::is_regular_file(manifest, error)) {
    throw SessionError(file + ": does not exist (is " + dir.string() + " a calibration set?)");
  }
  const std::vector<uint8_t> bytes = RethrowAsSessionError([&] { return ReadFileBytes(manifest); });
  const Json json = session_internal::ParseJson(std::string(bytes.begin(), bytes.end()), file);
  const JsonField root(json, "", file);
  CheckSchema(root);
  CalibrationSet set;
  LightsFieldOnDisk on_disk;
  session_internal::ReadObject(root, [&](auto& io) { CalibrationSetFields(io, set, &on_disk); });
  // Only successful calibrations are stored.
  if (set.camera_calibration) set.camera_calibration->summary.termination = Termination::kSuccess;
  if (set.white_balance) set.white_balance->summary.termination = Termination::kSuccess;
  if (set.lights) set.lights->summary.termination = Termination::kSuccess;
  if (set.color) set.color->summary.termination = Termination::kSuccess;
  const std::vector<FieldFileEntry>& files = on_disk.files;
  const std::optional<LightFieldGrid>& grid = on_disk.grid;

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
        const std::string actual = RethrowAsSessionError([&] { return Sha256HexOfFile(full); });
        if (actual != entry.sha256) {
          ThrowFieldError(file, MemberPath(entry.path, "sha256"),
                          FormatValue(entry.sha256) + " mismatch: file " + entry.file + " has " + actual);
        }
      }
      const ImageF image = RethrowAsSessionError([&] { return ReadImageFloat(full); });
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
  RethrowAsSessionError([&] { fs::create_directories(dir); });
  if (set.lights && set.lights->summary.per_pixel_field) {
    const SampledLightField& field = *set.lights->summary.per_pixel_field;
    const LightFieldGrid& g = field.grid();
    const size_t num_leds = static_cast<size_t>(field.num_lights());
    RethrowAsSessionError([&] { fs::create_directories(dir / kLightsFolder); });
    set.lights->field_sha256.clear();
    for (size_t k = 0; k < num_leds; ++k) {
      for (const bool direction : {true, false}) {
        ImageF image(g.nodes_x, g.nodes_y, 3);
        const std::vector<float>& values = direction ? field.node_light_dirs() : field.node_rgb_intensities();
        for (size_t n = 0; n < g.num_nodes(); ++n) {
          for (int c = 0; c < 3; ++c) image.data()[3 * n + c] = values[(n * num_leds + k) * 3 + c];
        }
        const fs::path path = dir / FieldFileName(k, direction ? "direction" : "intensity");
        RethrowAsSessionError([&] { WriteExr(path, image, OverwritePolicy::kReplace); });
        set.lights->field_sha256.push_back(RethrowAsSessionError([&] { return Sha256HexOfFile(path); }));
      }
    }
  }
  const Json json =
      ToJsonObject(set, [](auto& io, CalibrationSet& value) { CalibrationSetFields(io, value, nullptr); });
  const std::string text = session_internal::DumpJson(json);
  RethrowAsSessionError([&] { WriteFileAtomic(manifest, text, OverwritePolicy::kReplace); });
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
  if (set.color) consider(set.color->date, "color.date");
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
  record.manifest_sha256 = RethrowAsSessionError([&] { return Sha256HexOfFile(session_dir / "session.json"); });
  record.target_sha256 = RethrowAsSessionError([&] { return Sha256HexOfFile(session_dir / kCalibrationTargetFileName); });
  for (const FrameRecord& frame : session.frames) record.frame_sha256.push_back(frame.sha256);
  return record;
}

}  // namespace scanbench
