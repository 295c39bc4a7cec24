// A calibration set on disk: everything the calibrations measured for one
// camera + lens at one resolution, with where it came from.
//
//   <dir>/calibration.json           manifest (schema "scanbench.calibration_set", version 1)
//   <dir>/lights/led_NN_direction.exr per-pixel field of LED NN on its grid: unit direction to the LED (x, y, z)
//   <dir>/lights/led_NN_intensity.exr and RGB intensity (as rig.h's rgb_intensity, at the pixel's table point)
//
// calibration.json: schema_version, created, software_version, the camera's
// identity (make, model, serial, lens, width, height), then one section per
// calibration done: "camera", "white_balance", "lights". Each section has its
// date, the checksums of its target captures (each session's session.json,
// target.json and every frame) and every figure the calibration reported
// (docs/calibration.md lists them). "color" (issue #12) holds the colour
// correction from the solver's white-balanced camera RGB to linear Rec.709
// and its per-patch table. Sections are added by later calibrations
// of the same set; a camera calibration starts a new set.
//
// The loader checks everything like the session loader (file, field, value,
// rule), including the field files' checksums; a set from another camera,
// lens or resolution is refused for a session; an old set warns.
#pragma once

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "app/session/session.h"
#include "app/session/session_error.h"
#include "calibration/calibration_targets.h"
#include "calibration/camera_calibration.h"
#include "calibration/color_calibration.h"
#include "calibration/light_calibration.h"
#include "calibration/white_balance.h"

namespace scanbench {

inline constexpr int kCalibrationSetSchemaVersion = 1;
inline constexpr char kCalibrationManifestName[] = "calibration.json";

// What was calibrated: a set serves sessions of exactly this camera.
struct CalibratedCameraIdentity {
  std::string make, model, serial, lens;
  int width = 0;   // pixels
  int height = 0;
};

// One target session a calibration read.
struct TargetCaptureRecord {
  std::string session;                      // its folder, as given to the calibration
  std::string kind;                         // "checkerboard", "gray_chart", "white_sheet"
  std::string captured;                     // its session.json "created"
  std::string manifest_sha256;              // of its session.json (which lists each frame's SHA-256 too)
  std::string target_sha256;                // of its target.json
  std::vector<std::string> frame_sha256;    // every frame, in session order
};

struct CameraCalibrationSection {
  std::string date;                          // ISO 8601 UTC
  std::vector<TargetCaptureRecord> targets;
  CheckerboardTarget board;
  CameraCalibrationSummary summary;          // views' cam_from_target are not stored
};

struct WhiteBalanceSection {
  std::string date;
  std::vector<TargetCaptureRecord> targets;
  std::vector<int> led_ids;                  // firmware id of each LED, in order
  WhiteBalanceSummary summary;
};

struct LightsSection {
  std::string date;
  std::vector<TargetCaptureRecord> targets;
  std::vector<WhiteSheetTarget> sheets;      // one per target, in order
  // Figures, fitted LEDs (ids included), the per-pixel field (read from and
  // written to the lights/ files) and the selection.
  LightCalibrationSummary summary;
  std::vector<std::string> field_sha256;     // per LED: direction file, then intensity file
};

// A single RAW photo a calibration read (a chart shot outside a target session).
struct RawFileRecord {
  std::string path;    // as given to the calibration
  std::string sha256;  // of the file
};

struct ColorSection {
  std::string date;
  std::vector<TargetCaptureRecord> targets;  // colour chart target sessions ("color_chart")
  std::vector<RawFileRecord> raw_files;      // single RAW photos of the chart
  // What a perfect white reads, that the patch values were divided by:
  // "light_field" (the set's calibrated lights, so values are absolute
  // reflectances in the solver's albedo space) or "neutral_patches" (a photo
  // under unknown light: per-channel gains from the chart's gray row, relative).
  std::string white_reference;
  int num_frames = 0;                        // frames (LEDs x targets, or photos) averaged per patch
  ColorCorrectionSummary summary;            // the matrix, the method and the per-patch table
};

struct CalibrationSet {
  int schema_version = kCalibrationSetSchemaVersion;
  std::string created;                       // ISO 8601 UTC, when the set was started
  std::string software_version;
  CalibratedCameraIdentity camera;
  std::optional<CameraCalibrationSection> camera_calibration;
  std::optional<WhiteBalanceSection> white_balance;
  std::optional<LightsSection> lights;
  std::optional<ColorSection> color;
};

struct CalibrationLoadOptions {
  bool verify_checksums = true;  // re-hash the field files
};

// Reads and checks <dir>/calibration.json and its files. Throws SessionError
// naming the file and the field.
CalibrationSet LoadCalibrationSet(const std::filesystem::path& dir, const CalibrationLoadOptions& options = {});

// Checks the set, writes the per-pixel field files (when the lights section
// holds a field) and atomically replaces <dir>/calibration.json; makes <dir>.
// Fills lights->field_sha256. Throws SessionError.
void WriteCalibrationSet(const std::filesystem::path& dir, CalibrationSet& set);

// Throws SessionError naming the field when the set is inconsistent on its
// own (no files read).
void CheckCalibrationSet(const CalibrationSet& set, const std::string& name_for_errors);

// Refuses (SessionError) a set made for another camera, lens or resolution,
// or for another number of LEDs or LED ids, than the session's. The message
// names both values.
void CheckCalibrationFitsSession(const CalibrationSet& set, const std::string& set_name, const Session& session,
                                 const std::string& session_name);

// The oldest section date, and a warning when it is more than max_age_days
// before `now` (std::nullopt when fresh).
std::optional<std::string> CalibrationAgeWarning(const CalibrationSet& set, const std::string& set_name,
                                                 double max_age_days,
                                                 std::chrono::system_clock::time_point now =
                                                     std::chrono::system_clock::now());

// Parses "2024-05-01T12:34:56[.789]Z". Throws SessionError naming `what`.
std::chrono::system_clock::time_point ParseUtcTimestamp(const std::string& text, const std::string& what);

// The record of a target session for a calibration set: checksums of its
// session.json, target.json and frames (as listed, already verified by the
// loader). Throws SessionError.
TargetCaptureRecord MakeTargetCaptureRecord(const std::filesystem::path& session_dir, const Session& session,
                                            const std::string& kind);

}  // namespace scanbench
