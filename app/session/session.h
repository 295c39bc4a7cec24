// A scan session on disk: the unit every user deals with.
//
//   <root>/session.json       manifest: sample, rig, camera, frames (+ checksums)
//   <root>/frames/            RAW files, one dark frame and one per LED; never overwritten
//   <root>/results/<run-id>/  maps and report.json of one solver run
//
// session.json is also the capture journal: every AddFrame rewrites it
// atomically, so an interrupted capture can be resumed from what it lists.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "app/io/staged_folder.h"
#include "app/session/rig_json.h"
#include "app/session/session_error.h"
#include "calibration/rig.h"

namespace scanbench {

// Bump when the layout of session.json changes; the loader refuses any other.
inline constexpr int kSessionSchemaVersion = 1;

enum class FrameKind { kDark, kLed };

struct FrameRecord {
  FrameKind kind = FrameKind::kLed;
  int led_index = -1;        // index into RigDescription::leds; -1 for the dark frame
  std::string file;          // relative to the session folder, e.g. "frames/led_03.dng"
  std::string sha256;        // lower-case hex of the file's bytes
  std::string capture_time;  // ISO 8601 UTC, e.g. "2024-05-01T12:34:56.789Z"
  double exposure_time_s = 0;
  int width = 0;             // RAW image size, pixels
  int height = 0;
  // scanbench import: the absolute path of the file this frame was copied
  // from ("source" in session.json); empty for frames a capture wrote.
  std::string source;
};

// What took the frames, as the camera reported it. 0 means unknown for iso,
// exposure_time_s and f_number; width and height are the RAW image size.
struct CameraInfo {
  std::string make, model, serial, lens;
  double iso = 0;
  double exposure_time_s = 0;
  double f_number = 0;
  int width = 0;
  int height = 0;
};

// Reference maps of a simulated session; paths relative to the session folder.
struct GroundTruthFiles {
  std::string normal_file, normal_sha256;
  std::string albedo_file, albedo_sha256;
  std::string height_file, height_sha256;
  std::string mask_file, mask_sha256;
  double mm_per_pixel = 0;
};

// What a simulated session renders (simulate, capture --rig sim): recorded so
// that resuming an interrupted run with other scene options, whose frames
// would not belong together, is refused (CheckResumedSimulation). Strings and
// plain values, so the session does not depend on the simulator.
struct SimulatedSceneRecord {
  std::string sample;            // "twill" or "colorchecker"
  std::string material;          // "lambert", "cloth", "satin" (SurfaceMaterialName)
  std::string scene_seed;        // decimal uint64: the textile's variation and folds
  double warp_pitch_mm = 0;
  double weft_pitch_mm = 0;
  std::string noise_seed;        // decimal uint64: the sensor noise
  bool noise = true;             // sensor noise on
  bool cast_shadows = true;
  double fold_amplitude_mm = 2.5;  // issue #15: the folds' amplitude (absent in older sessions: their 2.5 mm)
};

// A session made by `scanbench import` from a folder of RAW files
// ("import" in session.json): where the frames came from and how they were
// matched to LEDs, so that an interrupted import resumes only from the same
// folder.
struct ImportRecord {
  std::string source_folder;  // absolute path
  std::string match;          // "capture order", "pattern 'led_{led}'" or "list /abs/path/list.txt"
};

struct Session {
  int schema_version = kSessionSchemaVersion;
  std::string sample_name;
  std::string notes;
  std::string created;           // ISO 8601 UTC
  std::string software_version;
  RigDescription rig;
  CameraInfo camera;
  std::vector<FrameRecord> frames;
  std::optional<GroundTruthFiles> ground_truth;
  std::optional<SimulatedSceneRecord> simulation;  // simulated sessions only ("simulation" in session.json)
  std::optional<ImportRecord> import;              // imported sessions only ("import" in session.json)
  // False while capturing. Only a complete session must have a dark frame and
  // a frame for every LED of the rig.
  bool capture_complete = false;
};

struct SessionLoadOptions {
  // Hashing every RAW file costs a full read; tools that only list sessions
  // may skip it. File existence is always checked.
  bool verify_checksums = true;
  // Files hashed at once (0 or less = every hardware thread): file reads and
  // SHA-256, 0.6 GB for a 16 MP session with ground truth.
  int num_threads = 0;
};

// Reads and checks <root>/session.json and the files it lists. Every error
// names the file and the field. Throws SessionError.
Session LoadSession(const std::filesystem::path& root, const SessionLoadOptions& options = {});

// Checks the session (CheckSession) and atomically replaces <root>/session.json.
// A manifest that LoadSession would reject is never written.
void WriteSessionManifest(const std::filesystem::path& root, const Session& session);

// The manifest of a new session, before any frame: `created` now, this
// scanbench's software_version; capture_complete false.
Session NewSessionManifest(const std::string& sample_name, const std::string& notes, const RigDescription& rig,
                           const CameraInfo& camera);

// Makes <root>, <root>/frames and <root>/results. Refuses if <root>/session.json
// exists, so that an existing session is never mixed with a new one. The caller
// writes the first manifest with WriteSessionManifest. Returns <root> made absolute.
std::filesystem::path CreateSessionFolder(const std::filesystem::path& root);

// Stores one captured frame: writes `bytes` to <root>/<record.file> (which must
// lie in frames/), fills record.sha256, appends the record to `session` and
// rewrites session.json. An existing file is never overwritten; one with exactly
// these bytes (left by a crash before the manifest was written) is adopted.
// The record is checked against the session before anything is written; on
// error `session` is unchanged.
void AddFrame(const std::filesystem::path& root, Session& session, FrameRecord record,
              std::span<const uint8_t> bytes);

// Reserves a new <root>/results/<UTC timestamp>-<run_label>[-N] (e.g.
// "20240501T123456Z-default"): written into its staging folder, it appears
// on Commit and never before, so a run killed outright leaves nothing under
// the name, and its staging folder is removed by the next reservation
// (StagedFolder::ReserveNumbered). An existing folder is never reused.
// `run_label` is 1-64 characters of [A-Za-z0-9._-].
StagedFolder ReserveResultFolder(const std::filesystem::path& root, const std::string& run_label,
                                 std::chrono::system_clock::time_point now = std::chrono::system_clock::now());

// The complete result folders of the session at `root` (not the hidden
// staging folders of runs under way or killed), oldest first (run ids start
// with their UTC timestamp). Empty when there is no results folder.
std::vector<std::filesystem::path> ListResultFolders(const std::filesystem::path& root);

// nullptr if absent.
// Frame file names inside the session: "dark" / "led_03" (also used in
// messages), and "frames/dark.dng" with the camera's extension.
std::string FrameStem(std::optional<int> led_index);
std::string FrameFileName(std::optional<int> led_index, const std::string& extension);

// What a frame's developed values are multiplied by to read as if exposed
// for the session's exposure (camera.settings.exposure_time_s): that
// exposure over the frame's. Exactly 1 when they are equal or the session's
// is unknown (0), so a session of one exposure is solved unscaled. The rig's
// LED intensities refer to the session's exposure.
double FrameExposureScale(const Session& session, const FrameRecord& frame);

const FrameRecord* FindDarkFrame(const Session& session);
const FrameRecord* FindLedFrame(const Session& session, int led_index);

// Throws SessionError naming the field when the session is inconsistent on its
// own (no files are read): schema version, required strings, timestamps, rig,
// camera settings, frame kinds, duplicate or out-of-range LED frames, dark frame
// count, frame sizes against camera settings, file paths leaving the session
// folder, checksum format, and completeness when capture_complete is true.
void CheckSession(const Session& session, const std::string& name_for_errors);

// session.json text, and back (parse + CheckSession, no files read).
std::string SessionToJson(const Session& session);
Session SessionFromJson(const std::string& text, const std::string& name_for_errors);

// Throws SessionError unless the scene an interrupted simulated session
// recorded equals `requested`, naming the file, the first field that differs
// and both values; a session without a record (written before scene options
// were recorded) is refused too, as nothing shows its frames match.
void CheckResumedSimulation(const std::filesystem::path& manifest, const Session& session,
                            const SimulatedSceneRecord& requested);

// "2024-05-01T12:34:56.789Z", for Session::created and FrameRecord::capture_time.
std::string FormatUtcTimestamp(std::chrono::system_clock::time_point time);

}  // namespace scanbench
