#include "app/session/session.h"

#include <sys/stat.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <ctime>
#include <map>
#include <string_view>
#include <type_traits>

#include "app/io/file_util.h"
#include "app/session/json_field.h"

namespace scanbench {
namespace fs = std::filesystem;
using session_internal::ElementPath;
using session_internal::FormatValue;
using session_internal::Json;
using session_internal::JsonField;
using session_internal::MemberPath;
using session_internal::ThrowFieldError;

namespace {

constexpr char kManifestName[] = "session.json";
constexpr char kFramesFolder[] = "frames";
constexpr char kResultsFolder[] = "results";
constexpr size_t kMaxRunLabelLength = 64;

// I/O helpers throw std::runtime_error / fs::filesystem_error naming the path;
// callers of this library catch one type.
template <typename Function>
decltype(auto) RethrowAsSessionError(Function&& function) {
  try {
    return function();
  } catch (const SessionError&) {
    throw;
  } catch (const std::exception& error) {
    throw SessionError(error.what());
  }
}

// ----------------------------------------------------------------------------
// Field rules

bool IsDigits(std::string_view text, size_t pos, size_t count) {
  if (pos + count > text.size()) return false;
  for (size_t i = pos; i < pos + count; ++i) {
    if (text[i] < '0' || text[i] > '9') return false;
  }
  return true;
}

int DigitsValue(std::string_view text, size_t pos, size_t count) {
  int value = 0;
  for (size_t i = pos; i < pos + count; ++i) value = value * 10 + (text[i] - '0');
  return value;
}

// YYYY-MM-DDTHH:MM:SS[.fraction]Z. Only UTC: local times without a zone are
// ambiguous once a session travels.
bool IsIso8601Utc(std::string_view text) {
  if (text.size() < 20 || !IsDigits(text, 0, 4) || text[4] != '-' || !IsDigits(text, 5, 2) || text[7] != '-' ||
      !IsDigits(text, 8, 2) || text[10] != 'T' || !IsDigits(text, 11, 2) || text[13] != ':' ||
      !IsDigits(text, 14, 2) || text[16] != ':' || !IsDigits(text, 17, 2)) {
    return false;
  }
  const int month = DigitsValue(text, 5, 2), day = DigitsValue(text, 8, 2);
  const int hour = DigitsValue(text, 11, 2), minute = DigitsValue(text, 14, 2), second = DigitsValue(text, 17, 2);
  if (month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59 || second > 60) return false;
  size_t pos = 19;
  if (text[pos] == '.') {
    ++pos;
    const size_t fraction_start = pos;
    while (pos < text.size() && IsDigits(text, pos, 1)) ++pos;
    if (pos == fraction_start) return false;
  }
  return pos + 1 == text.size() && text[pos] == 'Z';
}

bool IsSha256Hex(std::string_view text) {
  if (text.size() != 64) return false;
  for (const char c : text) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

// Every file a session lists must stay inside its folder, so that a session can
// be moved or archived as one folder and a manifest cannot point at /etc.
void CheckRelativePath(const std::string& relative, const std::string& file, const std::string& path) {
  const fs::path candidate(relative);
  if (relative.empty()) ThrowFieldError(file, path, "\"\" must name a file");
  if (candidate.is_absolute() || candidate.has_root_name() || candidate.has_root_directory()) {
    ThrowFieldError(file, path, FormatValue(relative) + " must be relative to the session folder");
  }
  for (const fs::path& part : candidate) {
    if (part == "..") ThrowFieldError(file, path, FormatValue(relative) + " must not leave the session folder (\"..\")");
  }
}

bool IsInFramesFolder(const std::string& relative) {
  const fs::path path = fs::path(relative).lexically_normal();
  auto part = path.begin();
  return part != path.end() && *part == kFramesFolder && ++part != path.end() && !part->empty();
}

void CheckSha256Format(const std::string& sha256, const std::string& file, const std::string& path) {
  if (!IsSha256Hex(sha256)) ThrowFieldError(file, path, FormatValue(sha256) + " must be 64 lower-case hex digits");
}

void CheckTimestamp(const std::string& time, const std::string& file, const std::string& path) {
  if (!IsIso8601Utc(time)) {
    ThrowFieldError(file, path, FormatValue(time) + " must be an ISO 8601 UTC time like 2024-05-01T12:34:56Z");
  }
}

void CheckCamera(const CameraInfo& camera, const std::string& file) {
  const std::string settings = "camera.settings";
  for (const auto& [name, value] : {std::pair{"iso", camera.iso},
                                    {"exposure_time_s", camera.exposure_time_s},
                                    {"f_number", camera.f_number}}) {
    if (!std::isfinite(value) || value < 0) {
      ThrowFieldError(file, MemberPath(settings, name), FormatValue(value) + " must be finite and >= 0 (0: unknown)");
    }
  }
  if (camera.width <= 0) ThrowFieldError(file, MemberPath(settings, "width"), std::to_string(camera.width) + " must be > 0");
  if (camera.height <= 0) {
    ThrowFieldError(file, MemberPath(settings, "height"), std::to_string(camera.height) + " must be > 0");
  }
}

void CheckFrames(const Session& session, const std::string& file) {
  const size_t num_leds = session.rig.leds.size();
  int dark_frame = -1;
  std::vector<int> frame_of_led(num_leds, -1);
  std::map<std::string, size_t> frame_of_file;
  for (size_t i = 0; i < session.frames.size(); ++i) {
    const FrameRecord& frame = session.frames[i];
    const std::string path = ElementPath("frames", i);
    const std::string led_index_path = MemberPath(path, "led_index");
    switch (frame.kind) {
      case FrameKind::kDark:
        if (frame.led_index != -1) {
          ThrowFieldError(file, led_index_path, std::to_string(frame.led_index) + " must be absent for a dark frame");
        }
        if (dark_frame >= 0) {
          ThrowFieldError(file, MemberPath(path, "kind"),
                          "\"dark\" is a second dark frame (the first is " + ElementPath("frames", dark_frame) + ")");
        }
        dark_frame = static_cast<int>(i);
        break;
      case FrameKind::kLed:
        if (frame.led_index < 0 || static_cast<size_t>(frame.led_index) >= num_leds) {
          ThrowFieldError(file, led_index_path,
                          std::to_string(frame.led_index) + " is out of range: rig.leds has " +
                              std::to_string(num_leds) + " entries");
        }
        if (frame_of_led[frame.led_index] >= 0) {
          ThrowFieldError(file, led_index_path,
                          std::to_string(frame.led_index) + " is already captured by " +
                              ElementPath("frames", frame_of_led[frame.led_index]));
        }
        frame_of_led[frame.led_index] = static_cast<int>(i);
        break;
      default:
        ThrowFieldError(file, MemberPath(path, "kind"),
                        std::to_string(static_cast<int>(frame.kind)) + " is not a FrameKind");
    }
    const std::string file_path = MemberPath(path, "file");
    CheckRelativePath(frame.file, file, file_path);
    const auto [it, inserted] = frame_of_file.emplace(fs::path(frame.file).lexically_normal().string(), i);
    if (!inserted) {
      ThrowFieldError(file, file_path,
                      FormatValue(frame.file) + " is already used by " + ElementPath("frames", it->second));
    }
    CheckSha256Format(frame.sha256, file, MemberPath(path, "sha256"));
    CheckTimestamp(frame.capture_time, file, MemberPath(path, "capture_time"));
    if (!std::isfinite(frame.exposure_time_s) || !(frame.exposure_time_s > 0)) {
      ThrowFieldError(file, MemberPath(path, "exposure_time_s"),
                      FormatValue(frame.exposure_time_s) + " must be finite and > 0");
    }
    // The solver stacks the frames pixel by pixel; all must have the camera's size.
    if (frame.width != session.camera.width) {
      ThrowFieldError(file, MemberPath(path, "width"),
                      std::to_string(frame.width) + " differs from camera.settings.width " +
                          std::to_string(session.camera.width));
    }
    if (frame.height != session.camera.height) {
      ThrowFieldError(file, MemberPath(path, "height"),
                      std::to_string(frame.height) + " differs from camera.settings.height " +
                          std::to_string(session.camera.height));
    }
  }
  if (!session.capture_complete) return;  // a journal of a capture still under way
  if (dark_frame < 0) ThrowFieldError(file, "frames", "no dark frame, but capture.complete is true");
  for (size_t led = 0; led < num_leds; ++led) {
    if (frame_of_led[led] < 0) {
      ThrowFieldError(file, "frames",
                      "no frame for " + ElementPath("rig.leds", led) + " (id " +
                          std::to_string(session.rig.leds[led].id) + "), but capture.complete is true");
    }
  }
}

// The four maps, so that checks, reading and writing treat them alike.
template <typename Truth>  // GroundTruthFiles or const GroundTruthFiles
auto GroundTruthEntries(Truth& truth) {
  using String = std::conditional_t<std::is_const_v<Truth>, const std::string, std::string>;
  struct Entry {
    const char* name;
    String* file;
    String* sha256;
  };
  return std::array<Entry, 4>{{{"normal", &truth.normal_file, &truth.normal_sha256},
                               {"albedo", &truth.albedo_file, &truth.albedo_sha256},
                               {"height", &truth.height_file, &truth.height_sha256},
                               {"mask", &truth.mask_file, &truth.mask_sha256}}};
}

void CheckGroundTruth(const GroundTruthFiles& truth, const std::string& file) {
  for (const auto& entry : GroundTruthEntries(truth)) {
    const std::string path = MemberPath("ground_truth", entry.name);
    CheckRelativePath(*entry.file, file, MemberPath(path, "file"));
    CheckSha256Format(*entry.sha256, file, MemberPath(path, "sha256"));
  }
  if (!std::isfinite(truth.mm_per_pixel) || !(truth.mm_per_pixel > 0)) {
    ThrowFieldError(file, "ground_truth.mm_per_pixel", FormatValue(truth.mm_per_pixel) + " must be finite and > 0");
  }
}

// A file listed in the manifest must exist and, if asked, hash to its record.
void CheckListedFile(const fs::path& root, const std::string& manifest, const std::string& path,
                     const std::string& relative, const std::string& sha256, bool verify_checksum) {
  const fs::path full = root / relative;
  std::error_code error;
  if (!fs::is_regular_file(full, error)) {
    const std::string problem = fs::exists(full, error) ? " is not a regular file"
                                                        : " does not exist in the session folder " + root.string();
    ThrowFieldError(manifest, MemberPath(path, "file"), FormatValue(relative) + problem);
  }
  if (!verify_checksum) return;
  const std::string actual = RethrowAsSessionError([&] { return Sha256HexOfFile(full); });
  if (actual != sha256) {
    ThrowFieldError(manifest, MemberPath(path, "sha256"),
                    FormatValue(sha256) + " mismatch: file " + relative + " has " + actual);
  }
}

// ----------------------------------------------------------------------------
// JSON

const char* FrameKindName(FrameKind kind) { return kind == FrameKind::kDark ? "dark" : "led"; }

Json FrameToJson(const FrameRecord& frame) {
  Json json{{"kind", FrameKindName(frame.kind)}};
  if (frame.kind == FrameKind::kLed) json["led_index"] = frame.led_index;
  json["file"] = frame.file;
  json["sha256"] = frame.sha256;
  json["capture_time"] = frame.capture_time;
  json["exposure_time_s"] = frame.exposure_time_s;
  json["width"] = frame.width;
  json["height"] = frame.height;
  return json;
}

FrameRecord FrameFromJson(const JsonField& field) {
  field.ExpectOnlyKeys({"kind", "led_index", "file", "sha256", "capture_time", "exposure_time_s", "width", "height"});
  FrameRecord frame;
  const JsonField kind = field.Member("kind");
  const std::string kind_name = kind.String();
  if (kind_name == "dark") {
    frame.kind = FrameKind::kDark;
    if (const auto led_index = field.OptionalMember("led_index")) led_index->Fail("must be absent or null for a dark frame");
  } else if (kind_name == "led") {
    frame.kind = FrameKind::kLed;
    frame.led_index = field.Member("led_index").Int();
  } else {
    kind.Fail("must be \"dark\" or \"led\"");
  }
  frame.file = field.Member("file").String();
  frame.sha256 = field.Member("sha256").String();
  frame.capture_time = field.Member("capture_time").String();
  frame.exposure_time_s = field.Member("exposure_time_s").Double();
  frame.width = field.Member("width").Int();
  frame.height = field.Member("height").Int();
  return frame;
}

Json CameraToJson(const CameraInfo& camera) {
  return Json{{"make", camera.make},
              {"model", camera.model},
              {"serial", camera.serial},
              {"lens", camera.lens},
              {"settings",
               {{"iso", camera.iso},
                {"exposure_time_s", camera.exposure_time_s},
                {"f_number", camera.f_number},
                {"width", camera.width},
                {"height", camera.height}}}};
}

CameraInfo CameraFromJson(const JsonField& field) {
  field.ExpectOnlyKeys({"make", "model", "serial", "lens", "settings"});
  CameraInfo camera;
  camera.make = field.Member("make").String();
  camera.model = field.Member("model").String();
  camera.serial = field.Member("serial").String();
  camera.lens = field.Member("lens").String();
  const JsonField settings = field.Member("settings");
  settings.ExpectOnlyKeys({"iso", "exposure_time_s", "f_number", "width", "height"});
  camera.iso = settings.Member("iso").Double();
  camera.exposure_time_s = settings.Member("exposure_time_s").Double();
  camera.f_number = settings.Member("f_number").Double();
  camera.width = settings.Member("width").Int();
  camera.height = settings.Member("height").Int();
  return camera;
}

Json GroundTruthToJson(const GroundTruthFiles& truth) {
  Json json{{"mm_per_pixel", truth.mm_per_pixel}};
  for (const auto& entry : GroundTruthEntries(truth)) {
    json[entry.name] = Json{{"file", *entry.file}, {"sha256", *entry.sha256}};
  }
  return json;
}

GroundTruthFiles GroundTruthFromJson(const JsonField& field) {
  field.ExpectOnlyKeys({"mm_per_pixel", "normal", "albedo", "height", "mask"});
  GroundTruthFiles truth;
  truth.mm_per_pixel = field.Member("mm_per_pixel").Double();
  for (const auto& entry : GroundTruthEntries(truth)) {
    const JsonField file_entry = field.Member(entry.name);
    file_entry.ExpectOnlyKeys({"file", "sha256"});
    *entry.file = file_entry.Member("file").String();
    *entry.sha256 = file_entry.Member("sha256").String();
  }
  return truth;
}

Json SessionToJsonValue(const Session& session) {
  Json json{{"schema_version", session.schema_version},
            {"sample_name", session.sample_name},
            {"notes", session.notes},
            {"created", session.created},
            {"software_version", session.software_version},
            {"capture", {{"complete", session.capture_complete}}},
            {"camera", CameraToJson(session.camera)},
            {"rig", session_internal::RigToJson(session.rig)}};
  if (session.ground_truth) json["ground_truth"] = GroundTruthToJson(*session.ground_truth);
  Json frames = Json::array();
  for (const FrameRecord& frame : session.frames) frames.push_back(FrameToJson(frame));
  json["frames"] = std::move(frames);
  return json;
}

Session SessionFromJsonValue(const Json& json, const std::string& file) {
  const JsonField root(json, "", file);
  // The version decides how to read everything else, so it comes first.
  const JsonField version_field = root.Member("schema_version");
  const int version = version_field.Int();
  if (version > kSessionSchemaVersion) {
    version_field.Fail("is newer than this scanbench reads (" + std::to_string(kSessionSchemaVersion) +
                       "); update scanbench");
  }
  if (version < kSessionSchemaVersion) {
    version_field.Fail("is older than this scanbench reads (" + std::to_string(kSessionSchemaVersion) +
                       ") and cannot be converted");
  }
  root.ExpectOnlyKeys({"schema_version", "sample_name", "notes", "created", "software_version", "capture", "camera",
                       "rig", "ground_truth", "frames"});
  Session session;
  session.schema_version = version;
  session.sample_name = root.Member("sample_name").String();
  if (const auto notes = root.OptionalMember("notes")) session.notes = notes->String();
  session.created = root.Member("created").String();
  session.software_version = root.Member("software_version").String();
  // Sessions written without journalling (e.g. simulated ones) are whole by construction.
  session.capture_complete = true;
  if (const auto capture = root.OptionalMember("capture")) {
    capture->ExpectOnlyKeys({"complete"});
    session.capture_complete = capture->Member("complete").Bool();
  }
  session.camera = CameraFromJson(root.Member("camera"));
  session.rig = session_internal::RigFromJson(root.Member("rig"));
  if (const auto truth = root.OptionalMember("ground_truth")) session.ground_truth = GroundTruthFromJson(*truth);
  for (const JsonField& frame : root.Member("frames").Elements()) session.frames.push_back(FrameFromJson(frame));
  return session;
}

// ----------------------------------------------------------------------------
// Time

std::tm UtcCalendarTime(std::chrono::system_clock::time_point time) {
  const std::time_t seconds = std::chrono::system_clock::to_time_t(std::chrono::floor<std::chrono::seconds>(time));
  std::tm calendar{};
  if (gmtime_r(&seconds, &calendar) == nullptr) throw SessionError("time out of range for a calendar date");
  return calendar;
}

// "20240501T123456Z": sorts by time and has no ':' (awkward in file names).
std::string CompactUtcTimestamp(std::chrono::system_clock::time_point time) {
  const std::tm calendar = UtcCalendarTime(time);
  char text[32];
  std::strftime(text, sizeof(text), "%Y%m%dT%H%M%SZ", &calendar);
  return text;
}

bool IsValidRunLabel(const std::string& label) {
  if (label.empty() || label.size() > kMaxRunLabelLength) return false;
  for (const char c : label) {
    const bool allowed = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                         c == '_' || c == '-';
    if (!allowed) return false;
  }
  return true;
}

}  // namespace

// ----------------------------------------------------------------------------

std::string FormatUtcTimestamp(std::chrono::system_clock::time_point time) {
  const std::tm calendar = UtcCalendarTime(time);
  const auto milliseconds = std::chrono::duration_cast<std::chrono::milliseconds>(
                                time - std::chrono::floor<std::chrono::seconds>(time))
                                .count();
  char text[96];  // ample for any int the format could meet
  std::snprintf(text, sizeof(text), "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", calendar.tm_year + 1900,
                calendar.tm_mon + 1, calendar.tm_mday, calendar.tm_hour, calendar.tm_min, calendar.tm_sec,
                static_cast<int>(milliseconds));
  return text;
}

void CheckSession(const Session& session, const std::string& name_for_errors) {
  const std::string& file = name_for_errors;
  if (session.schema_version != kSessionSchemaVersion) {
    ThrowFieldError(file, "schema_version",
                    std::to_string(session.schema_version) + " must be " + std::to_string(kSessionSchemaVersion));
  }
  if (session.sample_name.empty()) ThrowFieldError(file, "sample_name", "\"\" must not be empty");
  CheckTimestamp(session.created, file, "created");
  session_internal::CheckRig(session.rig, file, "rig");
  CheckCamera(session.camera, file);
  CheckFrames(session, file);
  if (session.ground_truth) CheckGroundTruth(*session.ground_truth, file);
}

std::string SessionToJson(const Session& session) {
  return session_internal::DumpJson(SessionToJsonValue(session));
}

Session SessionFromJson(const std::string& text, const std::string& name_for_errors) {
  Session session = SessionFromJsonValue(session_internal::ParseJson(text, name_for_errors), name_for_errors);
  CheckSession(session, name_for_errors);
  return session;
}

Session LoadSession(const fs::path& root, const SessionLoadOptions& options) {
  const fs::path manifest = root / kManifestName;
  const std::string manifest_name = manifest.string();
  std::error_code error;
  if (!fs::is_regular_file(manifest, error)) {
    throw SessionError(manifest_name + ": does not exist (is " + root.string() + " a session folder?)");
  }
  const std::vector<uint8_t> bytes = RethrowAsSessionError([&] { return ReadFileBytes(manifest); });
  Session session = SessionFromJson(std::string(bytes.begin(), bytes.end()), manifest_name);
  for (size_t i = 0; i < session.frames.size(); ++i) {
    const FrameRecord& frame = session.frames[i];
    CheckListedFile(root, manifest_name, ElementPath("frames", i), frame.file, frame.sha256,
                    options.verify_checksums);
  }
  if (session.ground_truth) {
    for (const auto& entry : GroundTruthEntries(*session.ground_truth)) {
      CheckListedFile(root, manifest_name, MemberPath("ground_truth", entry.name), *entry.file, *entry.sha256,
                      options.verify_checksums);
    }
  }
  return session;
}

void WriteSessionManifest(const fs::path& root, const Session& session) {
  const fs::path manifest = root / kManifestName;
  CheckSession(session, manifest.string());
  const std::string text = SessionToJson(session);
  RethrowAsSessionError([&] { WriteFileAtomic(manifest, text, OverwritePolicy::kReplace); });
}

fs::path CreateSessionFolder(const fs::path& root) {
  const fs::path manifest = root / kManifestName;
  std::error_code error;
  if (fs::exists(manifest, error)) {
    throw SessionError(manifest.string() + ": already exists; a new session needs a new folder");
  }
  RethrowAsSessionError([&] {
    fs::create_directories(root / kFramesFolder);
    fs::create_directories(root / kResultsFolder);
  });
  return RethrowAsSessionError([&] { return fs::absolute(root).lexically_normal(); });
}

void AddFrame(const fs::path& root, Session& session, FrameRecord record, std::span<const uint8_t> bytes) {
  const fs::path manifest = root / kManifestName;
  const std::string manifest_name = manifest.string();
  const std::string record_path = ElementPath("frames", session.frames.size());
  const std::string file_path = MemberPath(record_path, "file");
  record.sha256 = Sha256Hex(bytes);

  // Everything is checked before the first byte is written, so a rejected
  // frame leaves no file behind.
  Session updated = session;
  updated.frames.push_back(record);
  CheckSession(updated, manifest_name);
  if (!IsInFramesFolder(record.file)) {
    ThrowFieldError(manifest_name, file_path, FormatValue(record.file) + " must lie in frames/");
  }

  const fs::path target = root / record.file;
  std::error_code error;
  if (fs::exists(target, error)) {
    const std::string existing = RethrowAsSessionError([&] { return Sha256HexOfFile(target); });
    if (existing != record.sha256) {
      ThrowFieldError(manifest_name, file_path,
                      FormatValue(record.file) + " already exists with other content and is never overwritten");
    }
    // Same bytes: an earlier attempt died between writing the frame and the
    // manifest. Adopting it lets the capture resume.
  } else {
    RethrowAsSessionError([&] {
      fs::create_directories(target.parent_path());
      WriteFileAtomic(target, bytes, OverwritePolicy::kRefuse);
    });
  }
  WriteSessionManifest(root, updated);
  session = std::move(updated);
}

fs::path CreateResultFolder(const fs::path& root, const std::string& run_label,
                            std::chrono::system_clock::time_point now) {
  const fs::path manifest = root / kManifestName;
  std::error_code error;
  if (!fs::is_regular_file(manifest, error)) {
    throw SessionError(manifest.string() + ": does not exist; results belong in a session folder");
  }
  const fs::path results = root / kResultsFolder;
  if (!IsValidRunLabel(run_label)) {
    throw SessionError(results.string() + ": run label " + FormatValue(run_label) + " must be 1-" +
                       std::to_string(kMaxRunLabelLength) + " characters of [A-Za-z0-9._-]");
  }
  RethrowAsSessionError([&] { fs::create_directories(results); });
  const std::string base_name = CompactUtcTimestamp(now) + "-" + run_label;
  // mkdir() fails with EEXIST on any existing entry, so even two runs started in
  // the same second by different processes get different folders.
  constexpr int kMaxAttempts = 10000;
  for (int attempt = 1; attempt <= kMaxAttempts; ++attempt) {
    const fs::path folder = results / (attempt == 1 ? base_name : base_name + "-" + std::to_string(attempt));
    if (::mkdir(folder.c_str(), 0777) == 0) return folder;
    if (errno != EEXIST) throw SessionError(folder.string() + ": cannot be created: " + std::strerror(errno));
  }
  throw SessionError(results.string() + ": " + std::to_string(kMaxAttempts) + " folders named " + base_name +
                     "* exist already");
}

std::string FrameStem(std::optional<int> led_index) {
  if (!led_index) return "dark";
  char stem[16];
  std::snprintf(stem, sizeof(stem), "led_%02d", *led_index);
  return stem;
}

std::string FrameFileName(std::optional<int> led_index, const std::string& extension) {
  return std::string(kFramesFolder) + "/" + FrameStem(led_index) + extension;
}

const FrameRecord* FindDarkFrame(const Session& session) {
  for (const FrameRecord& frame : session.frames) {
    if (frame.kind == FrameKind::kDark) return &frame;
  }
  return nullptr;
}

const FrameRecord* FindLedFrame(const Session& session, int led_index) {
  for (const FrameRecord& frame : session.frames) {
    if (frame.kind == FrameKind::kLed && frame.led_index == led_index) return &frame;
  }
  return nullptr;
}

}  // namespace scanbench
