#include "app/session/session.h"

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <ctime>
#include <exception>
#include <map>
#include <string_view>
#include <type_traits>

#include "app/io/file_util.h"
#include "app/session/json_field.h"
#include "core/parallel_for.h"

namespace scanbench {
namespace fs = std::filesystem;
using session_internal::CheckSha256Format;
using session_internal::ElementPath;
using session_internal::FormatValue;
using session_internal::Json;
using session_internal::JsonField;
using session_internal::MemberPath;
using session_internal::Presence;
using session_internal::RethrowAsSessionError;
using session_internal::ThrowFieldError;

namespace {

constexpr char kManifestName[] = "session.json";
constexpr char kFramesFolder[] = "frames";
constexpr char kResultsFolder[] = "results";
constexpr size_t kMaxRunLabelLength = 64;

// ----------------------------------------------------------------------------
// Field rules

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

void CheckTimestamp(const std::string& time, const std::string& file, const std::string& path) {
  session_internal::ParseIso8601Utc(time, file + ": " + path);
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

// A file listed in the manifest: where session.json lists it, its record.
struct ListedFile {
  std::string path;      // the member path in session.json, for errors
  std::string relative;  // as listed
  std::string sha256;    // as recorded
};

// Every listed file must exist and, if asked, hash to its record. The files
// are hashed several at once (num_threads, 0 = all; 0.6 GB at 16 MP), then
// checked in the manifest's order, so the error is the first file's as when
// they are hashed one after another.
void CheckListedFiles(const fs::path& root, const std::string& manifest, const std::vector<ListedFile>& files,
                      bool verify_checksums, int num_threads) {
  std::vector<std::string> actual(files.size());
  std::vector<std::exception_ptr> failed(files.size());
  if (verify_checksums) {
    ParallelFor(static_cast<int>(files.size()), ResolveThreadCount(num_threads), 1, [&](int first, int last, int) {
      for (int i = first; i < last; ++i) {
        std::error_code error;
        const fs::path full = root / files[i].relative;
        if (!fs::is_regular_file(full, error)) continue;  // reported below, in order
        try {
          actual[i] = RethrowAsSessionError([&] { return Sha256HexOfFile(full); });
        } catch (...) {
          failed[i] = std::current_exception();
        }
      }
    });
  }
  for (size_t i = 0; i < files.size(); ++i) {
    const ListedFile& file = files[i];
    const fs::path full = root / file.relative;
    std::error_code error;
    if (!fs::is_regular_file(full, error)) {
      const std::string problem = fs::exists(full, error) ? " is not a regular file"
                                                          : " does not exist in the session folder " + root.string();
      ThrowFieldError(manifest, MemberPath(file.path, "file"), FormatValue(file.relative) + problem);
    }
    if (!verify_checksums) continue;
    if (failed[i]) std::rethrow_exception(failed[i]);
    if (actual[i] != file.sha256) {
      ThrowFieldError(manifest, MemberPath(file.path, "sha256"),
                      FormatValue(file.sha256) + " mismatch: file " + file.relative + " has " + actual[i]);
    }
  }
}

// ----------------------------------------------------------------------------
// JSON

const char* FrameKindName(FrameKind kind) { return kind == FrameKind::kDark ? "dark" : "led"; }

template <typename Io>
void FrameFields(Io& io, FrameRecord& frame) {
  io.Custom(
      "kind", [&] { return Json(FrameKindName(frame.kind)); },
      [&](const JsonField& kind) {
        const std::string name = kind.String();
        if (name == "dark") {
          frame.kind = FrameKind::kDark;
        } else if (name == "led") {
          frame.kind = FrameKind::kLed;
        } else {
          kind.Fail("must be \"dark\" or \"led\"");
        }
      });
  // An LED frame names its LED; a dark frame has none. The kind is read first.
  io.Custom(
      "led_index",
      [&]() -> std::optional<Json> {
        if (frame.kind != FrameKind::kLed) return std::nullopt;
        return Json(frame.led_index);
      },
      [&](const JsonField& led_index) {
        if (frame.kind == FrameKind::kDark) led_index.Fail("must be absent or null for a dark frame");
        frame.led_index = led_index.Int();
      },
      frame.kind == FrameKind::kLed ? Presence::kRequired : Presence::kOptionalOnRead);
  io.Field("file", frame.file);
  io.Field("sha256", frame.sha256);
  io.Field("capture_time", frame.capture_time);
  io.Field("exposure_time_s", frame.exposure_time_s);
  io.Field("width", frame.width);
  io.Field("height", frame.height);
  // Written for imported frames only, so captured sessions keep their layout.
  io.Custom(
      "source",
      [&]() -> std::optional<Json> {
        if (frame.source.empty()) return std::nullopt;
        return Json(frame.source);
      },
      [&](const JsonField& source) { frame.source = source.String(); }, Presence::kOptionalOnRead);
}

template <typename Io>
void CameraFields(Io& io, CameraInfo& camera) {
  io.Field("make", camera.make);
  io.Field("model", camera.model);
  io.Field("serial", camera.serial);
  io.Field("lens", camera.lens);
  io.Object("settings", [&](auto& settings) {
    settings.Field("iso", camera.iso);
    settings.Field("exposure_time_s", camera.exposure_time_s);
    settings.Field("f_number", camera.f_number);
    settings.Field("width", camera.width);
    settings.Field("height", camera.height);
  });
}

template <typename Io>
void GroundTruthFields(Io& io, GroundTruthFiles& truth) {
  io.Field("mm_per_pixel", truth.mm_per_pixel);
  for (const auto& entry : GroundTruthEntries(truth)) {
    io.Object(entry.name, [&](auto& map) {
      map.Field("file", *entry.file);
      map.Field("sha256", *entry.sha256);
    });
  }
}

template <typename Io>
void SimulationFields(Io& io, SimulatedSceneRecord& scene) {
  io.Field("sample", scene.sample);
  io.Field("material", scene.material);
  io.Field("scene_seed", scene.scene_seed);
  io.Field("warp_pitch_mm", scene.warp_pitch_mm);
  io.Field("weft_pitch_mm", scene.weft_pitch_mm);
  io.Field("noise_seed", scene.noise_seed);
  io.Field("noise", scene.noise);
  io.Field("cast_shadows", scene.cast_shadows);
  io.Field("fold_amplitude_mm", scene.fold_amplitude_mm, Presence::kOptionalOnRead);  // issue #15
}

template <typename Io>
void SessionFields(Io& io, Session& session) {
  io.Field("schema_version", session.schema_version);
  io.Field("sample_name", session.sample_name);
  io.Field("notes", session.notes, Presence::kOptionalOnRead);
  io.Field("created", session.created);
  io.Field("software_version", session.software_version);
  io.Object("capture", [&](auto& capture) { capture.Field("complete", session.capture_complete); },
            Presence::kOptionalOnRead);
  io.Object("camera", [&](auto& camera) { CameraFields(camera, session.camera); });
  io.Custom(
      "rig", [&] { return session_internal::RigToJson(session.rig); },
      [&](const JsonField& rig) { session.rig = session_internal::RigFromJson(rig); });
  io.Optional("ground_truth", session.ground_truth, [](auto& truth_io, GroundTruthFiles& truth) {
    GroundTruthFields(truth_io, truth);
  });
  io.Optional("simulation", session.simulation, [](auto& scene_io, SimulatedSceneRecord& scene) {
    SimulationFields(scene_io, scene);
  });
  io.Optional("import", session.import, [](auto& import_io, ImportRecord& import) {
    import_io.Field("source_folder", import.source_folder);
    import_io.Field("match", import.match);
  });
  io.Array("frames", session.frames, [](auto& frame_io, FrameRecord& frame) { FrameFields(frame_io, frame); });
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
  Session session;
  // Sessions written without journalling (e.g. simulated ones) are whole by construction.
  session.capture_complete = true;
  session_internal::ReadObject(root, [&](auto& io) { SessionFields(io, session); });
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
  return session_internal::DumpJson(session_internal::ToJsonObject(session, [](auto& io, Session& value) {
    SessionFields(io, value);
  }));
}

void CheckResumedSimulation(const fs::path& manifest, const Session& session, const SimulatedSceneRecord& requested) {
  const std::string resume = "; resume with the options of the interrupted run, or simulate into a new folder";
  if (!session.simulation) {
    throw SessionError(manifest.string() + ": simulation: not recorded (a session from before scene options were "
                       "recorded), so nothing shows its frames match the requested material '" +
                       requested.material + "'" + resume);
  }
  const SimulatedSceneRecord& recorded = *session.simulation;
  auto differs = [&](const std::string& field, const std::string& was, const std::string& now) {
    if (was == now) return;
    throw SessionError(manifest.string() + ": simulation." + field + ": recorded '" + was + "' but requested '" +
                       now + "'" + resume);
  };
  differs("sample", recorded.sample, requested.sample);
  differs("material", recorded.material, requested.material);
  differs("scene_seed", recorded.scene_seed, requested.scene_seed);
  differs("warp_pitch_mm", FormatValue(recorded.warp_pitch_mm), FormatValue(requested.warp_pitch_mm));
  differs("weft_pitch_mm", FormatValue(recorded.weft_pitch_mm), FormatValue(requested.weft_pitch_mm));
  differs("noise_seed", recorded.noise_seed, requested.noise_seed);
  differs("noise", recorded.noise ? "true" : "false", requested.noise ? "true" : "false");
  differs("cast_shadows", recorded.cast_shadows ? "true" : "false", requested.cast_shadows ? "true" : "false");
  differs("fold_amplitude_mm", FormatValue(recorded.fold_amplitude_mm), FormatValue(requested.fold_amplitude_mm));
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
  std::vector<ListedFile> listed;
  for (size_t i = 0; i < session.frames.size(); ++i) {
    const FrameRecord& frame = session.frames[i];
    listed.push_back({ElementPath("frames", i), frame.file, frame.sha256});
  }
  if (session.ground_truth) {
    for (const auto& entry : GroundTruthEntries(*session.ground_truth)) {
      listed.push_back({MemberPath("ground_truth", entry.name), *entry.file, *entry.sha256});
    }
  }
  CheckListedFiles(root, manifest_name, listed, options.verify_checksums, options.num_threads);
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
    // The new folders' names on disk before a frame is reported written in them.
    fs::path absolute = fs::absolute(root).lexically_normal();
    if (!absolute.has_filename()) absolute = absolute.parent_path();  // "session/"
    FsyncDirectory(absolute);
    FsyncDirectory(absolute.parent_path());
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

StagedFolder ReserveResultFolder(const fs::path& root, const std::string& run_label,
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
  // Even two runs started in the same second by different processes get
  // different names: the reservation is an exclusive link.
  try {
    return StagedFolder::ReserveNumbered(results, CompactUtcTimestamp(now) + "-" + run_label);
  } catch (const std::runtime_error& e) {
    throw SessionError(e.what());
  }
}

std::vector<fs::path> ListResultFolders(const fs::path& root) {
  std::vector<fs::path> folders;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(root / kResultsFolder, error)) {
    if (entry.is_directory(error) && !entry.path().filename().string().starts_with(".")) {
      folders.push_back(entry.path());
    }
  }
  std::sort(folders.begin(), folders.end());
  return folders;
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

Session NewSessionManifest(const std::string& sample_name, const std::string& notes, const RigDescription& rig,
                           const CameraInfo& camera) {
  Session session;
  session.sample_name = sample_name;
  session.notes = notes;
  session.created = FormatUtcTimestamp(std::chrono::system_clock::now());
  session.software_version = "scanbench " SCANBENCH_VERSION;
  session.rig = rig;
  session.camera = camera;
  return session;
}

double FrameExposureScale(const Session& session, const FrameRecord& frame) {
  if (!(session.camera.exposure_time_s > 0) || frame.exposure_time_s == session.camera.exposure_time_s) return 1;
  return session.camera.exposure_time_s / frame.exposure_time_s;
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
