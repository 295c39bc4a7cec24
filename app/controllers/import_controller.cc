#include "app/controllers/import_controller.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "app/io/file_util.h"
#include "app/io/raw_decoder.h"
#include "core/field_error.h"
#include "core/format.h"

namespace scanbench {
namespace fs = std::filesystem;

// What one RAW file says about itself; the mosaic is not kept.
struct ImportFileFacts {
  fs::path file;
  std::string sha256;
  CameraInfo camera;         // as session.json records it: make ... exposure, RAW size
  int orientation = 0;       // DecodedRaw::orientation
  std::string capture_time;  // "YYYY:MM:DD HH:MM:SS" or ""
};

namespace {

constexpr char kLedPlaceholder[] = "{led}";

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

// Files a camera or a RAW tool writes beside the RAWs; never frames.
bool IsSidecar(const fs::path& file) {
  static const std::set<std::string> kSidecars = {".xmp", ".txt", ".json", ".md",  ".csv", ".pp3",
                                                  ".dop", ".thm", ".log",  ".ini", ".nksc"};
  return kSidecars.count(Lower(file.extension().string())) != 0;
}

bool HasJpegExtension(const fs::path& file) {
  const std::string extension = Lower(file.extension().string());
  return extension == ".jpg" || extension == ".jpeg" || extension == ".jpe";
}

std::string JpegRefusal(const fs::path& file) {
  return file.string() +
         ": is a JPEG, not a RAW file (a photometric solve needs the sensor's linear data): set the camera to "
         "RAW (NEF) only, or take the JPEGs out of the folder";
}

// The candidate frames: regular, visible files that are not sidecars,
// sorted by name.
std::vector<fs::path> ListFolder(const fs::path& folder, const fs::path& skip) {
  if (!fs::is_directory(folder)) throw std::runtime_error(folder.string() + ": not a folder of RAW files");
  std::vector<fs::path> files;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    const fs::path path = entry.path();
    if (!entry.is_regular_file() || path.filename().string().starts_with(".") || IsSidecar(path)) continue;
    if (!skip.empty() && fs::equivalent(path, skip)) continue;
    files.push_back(path);
  }
  std::sort(files.begin(), files.end());
  return files;
}

// `given` is a file name of the folder or a path to a file in it.
fs::path ResolveInFolder(const fs::path& folder, const fs::path& given, const std::string& what) {
  const fs::path path = given.has_parent_path() ? fs::absolute(given) : folder / given;
  if (!fs::is_regular_file(path))
    throw std::runtime_error(what + " " + given.string() + ": no such file in " + folder.string());
  if (fs::weakly_canonical(path).parent_path() != fs::weakly_canonical(folder)) {
    throw std::runtime_error(what + " " + given.string() + ": is not a file of the RAW folder " + folder.string());
  }
  return folder / path.filename();
}

// The LED index a file stem carries under `pattern`, nullopt if it does not match.
std::optional<int> MatchPattern(const std::string& pattern, const std::string& stem) {
  const size_t at = pattern.find(kLedPlaceholder);
  const std::string prefix = pattern.substr(0, at);
  const std::string suffix = pattern.substr(at + std::string(kLedPlaceholder).size());
  if (stem.size() <= prefix.size() + suffix.size() || !stem.starts_with(prefix) || !stem.ends_with(suffix)) {
    return std::nullopt;
  }
  const std::string digits = stem.substr(prefix.size(), stem.size() - prefix.size() - suffix.size());
  if (digits.size() > 6 ||
      !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); })) {
    return std::nullopt;
  }
  return std::stoi(digits);
}

// 1/60 s reads "0.0166667", ISO 100 "100".
std::string Number(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

std::string FrameName(std::optional<int> led) { return led ? "LED " + std::to_string(*led) : "the dark frame"; }

// Fills one frame; refuses a second file for it, naming both.
void Assign(std::map<int, fs::path>& frames, int key, const fs::path& file, const std::string& how) {
  const auto [it, inserted] = frames.emplace(key, file);
  if (!inserted && it->second != file) {
    throw std::runtime_error(file.string() + ": duplicate: " + FrameName(key < 0 ? std::nullopt : std::optional(key)) +
                             " is already " + it->second.filename().string() + " (" + how + ")");
  }
}

ImportPlan Finish(std::map<int, fs::path> frames, int num_leds, const std::vector<fs::path>& files, ImportPlan plan,
                  const std::string& hint) {
  if (frames.count(-1) == 0) {
    throw std::runtime_error("no dark frame in " +
                             (files.empty() ? std::string("the folder") : files.front().parent_path().string()) +
                             ": name it with --dark FILE (" + plan.match + ")");
  }
  for (int k = 0; k < num_leds; ++k) {
    if (frames.count(k) == 0) throw std::runtime_error("missing LED " + std::to_string(k) + ": " + hint);
  }
  std::map<fs::path, int> used;
  for (const auto& [key, file] : frames) {
    if (key >= num_leds) {
      throw std::runtime_error(file.string() + ": LED " + std::to_string(key) + " is not in the rig (LEDs 0.." +
                               std::to_string(num_leds - 1) + ")");
    }
    const auto [it, inserted] = used.emplace(file, key);
    if (!inserted) {
      throw std::runtime_error(file.string() + ": duplicate: used for both " +
                               FrameName(it->second < 0 ? std::nullopt : std::optional(it->second)) + " and " +
                               FrameName(key < 0 ? std::nullopt : std::optional(key)));
    }
  }
  for (const auto& [key, file] : frames) {
    if (HasJpegExtension(file)) throw std::runtime_error(JpegRefusal(file));
    plan.entries.push_back({key < 0 ? std::nullopt : std::optional(key), file});
  }
  for (const fs::path& file : files) {
    if (used.count(file) == 0) plan.ignored.push_back(file.filename().string());
  }
  return plan;
}

std::map<int, fs::path> ListFileFrames(const fs::path& folder, const fs::path& list_file) {
  std::ifstream in(list_file);
  if (!in) throw std::runtime_error(list_file.string() + ": cannot be read");
  std::map<int, fs::path> frames;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string where = list_file.string() + ": line " + std::to_string(number);
    if (const size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::string key, file;
    if (!(fields >> key)) continue;
    std::getline(fields >> std::ws, file);
    while (!file.empty() && std::isspace(static_cast<unsigned char>(file.back()))) file.pop_back();
    if (file.empty())
      throw std::runtime_error(where + ": '" + key + "' names no file (expected 'dark FILE' or 'INDEX FILE')");
    int led = -1;
    if (key != "dark") {
      if (!std::all_of(key.begin(), key.end(), [](unsigned char c) { return std::isdigit(c); }) || key.size() > 6) {
        throw std::runtime_error(where + ": '" + key + "' must be 'dark' or an LED index (0-based)");
      }
      led = std::stoi(key);
    }
    Assign(frames, led, ResolveInFolder(folder, file, where + ": file"), "list " + list_file.string());
  }
  return frames;
}

// ---- the checks on the opened files -----------------------------------------

ImportFileFacts OpenRawFile(const fs::path& file) {
  const std::vector<uint8_t> bytes = ReadFileBytes(file);
  if (bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF) {
    throw std::runtime_error(JpegRefusal(file));
  }
  // The decoder refuses what cannot be solved (not a 2x2 Bayer mosaic,
  // truncated, no pixels) and names the file.
  const DecodedRaw decoded = DecodeRawWithInfo(bytes, file.string());
  ImportFileFacts facts;
  facts.file = file;
  facts.sha256 = Sha256Hex(bytes);
  facts.camera = {decoded.make,     decoded.model,         decoded.serial,
                  decoded.lens,     decoded.iso,           decoded.exposure_time_s,
                  decoded.f_number, decoded.image.width(), decoded.image.height()};
  facts.orientation = decoded.orientation;
  facts.capture_time = decoded.capture_time;
  if (!(facts.camera.exposure_time_s > 0)) {
    throw std::runtime_error(file.string() + ": records no exposure time; the solve needs it to compare frames");
  }
  return facts;
}

std::string CameraText(const ImportFileFacts& facts) {
  return facts.camera.make + " " + facts.camera.model +
         (facts.camera.serial.empty() ? "" : " (serial " + facts.camera.serial + ")");
}

std::string OrientationText(int flip) {
  switch (flip) {
    case 0:
      return "as stored";
    case 3:
      return "rotated 180 deg";
    case 5:
      return "rotated 90 deg counter-clockwise";
    case 6:
      return "rotated 90 deg clockwise";
    default:
      return "orientation code " + std::to_string(flip);
  }
}

// Refuses frames that cannot belong to one photometric set; returns the
// warnings (exposure times only).
std::vector<std::string> CheckFramesAgree(const std::vector<ImportFileFacts>& facts, const std::vector<std::string>& names) {
  const ImportFileFacts& ref = facts.front();
  const std::string ref_name = ref.file.string() + " (" + names.front() + ")";
  std::vector<std::string> warnings;
  for (size_t i = 1; i < facts.size(); ++i) {
    const ImportFileFacts& f = facts[i];
    const std::string file = f.file.string();
    if (f.camera.make != ref.camera.make || f.camera.model != ref.camera.model ||
        f.camera.serial != ref.camera.serial) {
      throw std::runtime_error(file + ": mixed cameras: taken with " + CameraText(f) + " but " + ref_name + " with " +
                               CameraText(ref));
    }
    if (f.camera.width != ref.camera.width || f.camera.height != ref.camera.height) {
      throw std::runtime_error(file + ": mixed sizes: " + std::to_string(f.camera.width) + "x" +
                               std::to_string(f.camera.height) + " but " + ref_name + " is " +
                               std::to_string(ref.camera.width) + "x" + std::to_string(ref.camera.height));
    }
    if (f.orientation != ref.orientation) {
      throw std::runtime_error(file + ": mixed orientations: " + OrientationText(f.orientation) + " but " + ref_name +
                               " is " + OrientationText(ref.orientation) + "; the camera moved between frames");
    }
    if (f.camera.iso != ref.camera.iso) {
      throw std::runtime_error(file + ": differing ISO: " + Number(f.camera.iso) + " but " + ref_name + " has " +
                               Number(ref.camera.iso) + "; capture every frame at one ISO (the camera's base ISO)");
    }
    if (f.camera.f_number != ref.camera.f_number) {
      throw std::runtime_error(file + ": differing aperture: f/" + Number(f.camera.f_number) + " but " + ref_name +
                               " has f/" + Number(ref.camera.f_number) + "; fix the aperture for the whole set");
    }
  }
  // Exposure: the LED frames against the first LED frame, and the dark frame.
  const ImportFileFacts& first_led = facts.size() > 1 ? facts[1] : ref;
  for (size_t i = 0; i < facts.size(); ++i) {
    if (facts[i].camera.exposure_time_s != first_led.camera.exposure_time_s) {
      warnings.push_back(facts[i].file.string() + " (" + names[i] + "): exposure " +
                         Number(facts[i].camera.exposure_time_s) + " s differs from " + first_led.file.string() + " (" +
                         Number(first_led.camera.exposure_time_s) + " s); the solve scales each frame to " +
                         Number(first_led.camera.exposure_time_s) + " s");
    }
  }
  return warnings;
}

// The session records UTC; a camera clock has no zone, so its reading is
// recorded as is. A file without one gets its modification time.
std::string CaptureTimeOf(const ImportFileFacts& facts) {
  const std::string& t = facts.capture_time;
  if (t.size() == 19) {
    return t.substr(0, 4) + "-" + t.substr(5, 2) + "-" + t.substr(8, 2) + "T" + t.substr(11, 8) + ".000Z";
  }
  const auto written = std::chrono::file_clock::to_sys(fs::last_write_time(facts.file));
  return FormatUtcTimestamp(std::chrono::time_point_cast<std::chrono::system_clock::duration>(written));
}

bool IsInside(const fs::path& inner, const fs::path& outer) {
  const fs::path a = fs::weakly_canonical(inner), b = fs::weakly_canonical(outer);
  auto it = a.begin();
  for (auto part = b.begin(); part != b.end(); ++part, ++it) {
    if (part->empty()) continue;  // trailing separator
    if (it == a.end() || *it != *part) return false;
  }
  return true;
}

// An interrupted import of the same folder resumes; anything else is refused.
std::optional<Session> LoadInterruptedImport(const fs::path& session_dir, const fs::path& folder,
                                             const RigDescription& rig) {
  const fs::path manifest = session_dir / "session.json";
  if (!fs::exists(manifest)) return std::nullopt;
  Session session = LoadSession(session_dir);
  if (session.capture_complete) {
    throw SessionError(manifest.string() + ": capture_complete: the session is complete; import into a new folder");
  }
  if (!session.import || session.import->source_folder != folder.string()) {
    throw SessionError(manifest.string() + ": import.source_folder: " +
                       (session.import ? "'" + session.import->source_folder + "'" : std::string("absent")) +
                       ": not an interrupted import of " + folder.string() + "; import into a new folder");
  }
  if (session.rig.leds.size() != rig.leds.size()) {
    throw SessionError(manifest.string() + ": rig.leds: " + std::to_string(session.rig.leds.size()) +
                       " LEDs recorded but the rig file has " + std::to_string(rig.leds.size()));
  }
  return session;
}

// The session's camera and exposure are LED 0's frame's: the exposure the
// solve scales every frame to (FrameExposureScale).
Session NewImportSession(const ImportOptions& options, const RigDescription& rig, const ImportFileFacts& first_led,
                         const fs::path& folder, const std::string& match) {
  Session session = NewSessionManifest(options.sample_name, options.notes, rig, first_led.camera);
  session.import = ImportRecord{folder.string(), match};
  return session;
}

}  // namespace

void ImportOptions::Check() const {
  const char* where = "ImportOptions";
  if (sample_name.empty()) throw FieldError(where, "sample_name", "''", "must not be empty");
  if (!pattern.empty() && !list_file.empty()) {
    throw FieldError(where, "pattern", "'" + pattern + "'", "cannot be combined with list_file");
  }
  if (!pattern.empty()) {
    const size_t at = pattern.find(kLedPlaceholder);
    if (at == std::string::npos || pattern.find(kLedPlaceholder, at + 1) != std::string::npos) {
      throw FieldError(where, "pattern", "'" + pattern + "'", "must contain {led} exactly once");
    }
    if (pattern.find('/') != std::string::npos) {
      throw FieldError(where, "pattern", "'" + pattern + "'", "matches file names, without folders");
    }
  }
}

ImportPlan PlanImport(const fs::path& folder_given, int num_leds, const ImportOptions& options,
                      const std::function<std::string(const fs::path&)>& capture_time_of) {
  const fs::path folder = fs::absolute(folder_given).lexically_normal();
  const fs::path list_file = options.list_file.empty() ? fs::path() : fs::absolute(options.list_file);
  const std::vector<fs::path> files = ListFolder(folder, list_file);
  std::map<int, fs::path> frames;  // -1 = dark
  if (!options.dark_file.empty()) frames[-1] = ResolveInFolder(folder, options.dark_file, "--dark");

  ImportPlan plan;
  if (!list_file.empty()) {
    plan.match = "list " + list_file.string();
    for (auto& [key, file] : ListFileFrames(folder, list_file)) Assign(frames, key, file, "--dark and the list");
    return Finish(std::move(frames), num_leds, files, std::move(plan),
                  list_file.string() + " has no line for it ('INDEX FILE', INDEX 0-based)");
  }
  auto named_dark = [&]() {
    for (const fs::path& file : files) {
      if (Lower(file.stem().string()) == "dark" && frames.count(-1) == 0) frames[-1] = file;
    }
  };
  if (!options.pattern.empty()) {
    plan.match = "pattern '" + options.pattern + "'";
    named_dark();
    for (const fs::path& file : files) {
      if (frames.count(-1) && frames[-1] == file) continue;
      if (const std::optional<int> led = MatchPattern(options.pattern, file.stem().string())) {
        Assign(frames, *led, file, "pattern '" + options.pattern + "'");
      }
    }
    return Finish(std::move(frames), num_leds, files, std::move(plan),
                  "no file of " + folder.string() + " matches the pattern '" + options.pattern + "' with it");
  }

  // Capture order: as `capture` takes them, the dark frame first, then LED 0, 1, ...
  plan.match = "capture order";
  named_dark();
  std::vector<std::pair<std::string, fs::path>> ordered;
  bool all_timed = true;
  for (const fs::path& file : files) {
    if (frames.count(-1) && frames[-1] == file) continue;
    if (HasJpegExtension(file)) throw std::runtime_error(JpegRefusal(file));
    ordered.emplace_back(capture_time_of(file), file);
    all_timed = all_timed && !ordered.back().first.empty();
  }
  if (!all_timed) {
    plan.warnings.push_back("some files record no capture time: frames ordered by file name");
    for (auto& entry : ordered) entry.first.clear();
  }
  std::stable_sort(ordered.begin(), ordered.end());  // time (1 s resolution), then name
  size_t next = 0;
  if (frames.count(-1) == 0 && !ordered.empty()) frames[-1] = ordered[next++].second;
  const size_t expected = static_cast<size_t>(num_leds) + next;
  if (ordered.size() < expected) {
    throw std::runtime_error("missing LED " + std::to_string(ordered.size() - next) + ": " + folder.string() + " has " +
                             std::to_string(ordered.size() - next) + " LED frames in capture order but the rig has " +
                             std::to_string(num_leds) + " LEDs");
  }
  if (ordered.size() > expected) {
    throw std::runtime_error(ordered[expected].second.string() + ": one file more than the rig's " +
                             std::to_string(num_leds) +
                             " LEDs and a dark frame (in capture order); remove it or "
                             "match with --pattern or --list");
  }
  for (int k = 0; k < num_leds; ++k) Assign(frames, k, ordered[next + k].second, "capture order");
  return Finish(std::move(frames), num_leds, files, std::move(plan), "");
}

ImportController::ImportController(fs::path raw_folder, fs::path session_dir, RigDescription rig, ImportOptions options)
    : raw_folder_(fs::absolute(raw_folder).lexically_normal()),
      session_dir_(std::move(session_dir)),
      rig_(std::move(rig)),
      options_(std::move(options)) {}

// Refuses what it can before anything is written: the rig, the folders, the
// plan, every file opened and checked against the others; then copies into
// the session, locked, as a capture would journal it.
void ImportController::Run() {
  options_.Check();
  const auto start = std::chrono::steady_clock::now();
  summary_ = ImportSummary();
  summary_.session_dir = session_dir_;
  CheckRigAndFolders();
  std::map<fs::path, ImportFileFacts> opened;  // each file opened once
  const ImportPlan plan = Match(&opened);
  std::vector<std::string> names;
  const std::vector<ImportFileFacts> facts = OpenFrames(plan, &opened, &names);

  BeginStage("copy");
  // Every refusal above wrote nothing; from here on the session is ours, and
  // refused while a capture, simulate or another import holds it
  // (app/io/file_util.h; the kernel drops the lock if we crash).
  const FolderLock session_lock(session_dir_);
  Session session = ResumeOrCreateSession(plan, facts);
  for (size_t i = 0; i < plan.entries.size(); ++i) {
    ImportedFrame imported{names[i], plan.entries[i].file.string(), facts[i].camera.exposure_time_s, false};
    imported.resumed = IsImportedAlready(session, plan.entries[i], facts[i], names[i]);
    if (imported.resumed) {
      ++summary_.frames_resumed;
    } else {
      ThrowIfStopRequested("copy");
      ReportProgress("copy", double(i) / plan.entries.size(), plan.entries[i].file.filename().string());
      CopyFrame(plan.entries[i], facts[i], &session);
      ++summary_.frames_copied;
    }
    summary_.frames.push_back(imported);
  }
  session.capture_complete = true;
  WriteSessionManifest(session_dir_, session);
  ReportProgress("copy", 1);
  summary_.seconds = SecondsSince(start);
}

// The rig, and the session outside the RAW folder (and not holding it): the
// source is never written to.
void ImportController::CheckRigAndFolders() const {
  CheckRigDescription(rig_, "rig");
  if (IsInside(session_dir_, raw_folder_) || IsInside(raw_folder_, session_dir_)) {
    throw std::runtime_error(session_dir_.string() + ": the session folder must lie outside the RAW folder " +
                             raw_folder_.string() + " (and not contain it): the source is never written to");
  }
}

// `file` opened through LibRaw, once: later calls get what the first found.
const ImportFileFacts& ImportController::Open(const fs::path& file, std::map<fs::path, ImportFileFacts>* opened) {
  auto it = opened->find(file);
  if (it == opened->end()) {
    ThrowIfStopRequested("open");
    it = opened->emplace(file, OpenRawFile(file)).first;
  }
  return it->second;
}

// The plan (PlanImport); capture order opens every file for its time, and
// what it found is kept in `opened`.
ImportPlan ImportController::Match(std::map<fs::path, ImportFileFacts>* opened) {
  BeginStage("match");
  ImportPlan plan = PlanImport(raw_folder_, static_cast<int>(rig_.leds.size()), options_,
                               [&](const fs::path& file) { return Open(file, opened).capture_time; });
  summary_.match = plan.match;
  summary_.ignored = plan.ignored;
  summary_.warnings = plan.warnings;
  return plan;
}

// Every frame of the plan opened, in its order, with its name ("dark",
// "led_03") in `names`; refuses two frames of the same bytes and frames that
// cannot belong to one photometric set (CheckFramesAgree).
std::vector<ImportFileFacts> ImportController::OpenFrames(const ImportPlan& plan,
                                                          std::map<fs::path, ImportFileFacts>* opened,
                                                          std::vector<std::string>* names) {
  std::vector<ImportFileFacts> facts;
  for (size_t i = 0; i < plan.entries.size(); ++i) {
    ReportProgress("open", double(i) / plan.entries.size(), plan.entries[i].file.filename().string());
    facts.push_back(Open(plan.entries[i].file, opened));
    names->push_back(FrameStem(plan.entries[i].led));
  }
  for (size_t i = 0; i < facts.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (facts[i].sha256 == facts[j].sha256) {
        throw std::runtime_error(facts[i].file.string() + ": duplicate: the same bytes as " + facts[j].file.string() +
                                 " (" + (*names)[j] + "), but it is " + (*names)[i]);
      }
    }
  }
  for (std::string& warning : CheckFramesAgree(facts, *names)) summary_.warnings.push_back(std::move(warning));
  summary_.camera = CameraText(facts.front());
  return facts;
}

// An interrupted import of the same folder, or a new session (its manifest
// written) with LED 0's frame's camera and exposure.
Session ImportController::ResumeOrCreateSession(const ImportPlan& plan, const std::vector<ImportFileFacts>& facts) {
  std::optional<Session> session = LoadInterruptedImport(session_dir_, raw_folder_, rig_);
  if (!session) {
    session = NewImportSession(options_, rig_, facts[1 % facts.size()], raw_folder_, plan.match);
    CreateSessionFolder(session_dir_);
    WriteSessionManifest(session_dir_, *session);
  }
  return std::move(*session);
}

// True when an interrupted import copied this frame already (from the same
// file, the same bytes); refuses a frame imported from another file or bytes.
bool ImportController::IsImportedAlready(const Session& session, const ImportPlanEntry& entry,
                                         const ImportFileFacts& facts, const std::string& name) const {
  const FrameRecord* done = entry.led ? FindLedFrame(session, *entry.led) : FindDarkFrame(session);
  if (done == nullptr) return false;
  if (done->source != entry.file.string() || done->sha256 != facts.sha256) {
    throw SessionError((session_dir_ / "session.json").string() + ": " + name + " was imported from " +
                       done->source + " (sha256 " + done->sha256.substr(0, 12) + "...) but is now " +
                       entry.file.string() + " (sha256 " + facts.sha256.substr(0, 12) +
                       "...); import into a new folder");
  }
  return true;
}

// One frame copied into the session's frames/ and journalled, its bytes
// checked against what was opened.
void ImportController::CopyFrame(const ImportPlanEntry& entry, const ImportFileFacts& facts, Session* session) {
  const std::vector<uint8_t> bytes = ReadFileBytes(entry.file);
  if (Sha256Hex(bytes) != facts.sha256) {
    throw std::runtime_error(entry.file.string() + ": changed while it was being imported; import again");
  }
  FrameRecord record;
  record.kind = entry.led ? FrameKind::kLed : FrameKind::kDark;
  record.led_index = entry.led.value_or(-1);
  const std::string extension = Lower(entry.file.extension().string());
  record.file = FrameFileName(entry.led, extension.empty() ? ".raw" : extension);
  record.capture_time = CaptureTimeOf(facts);
  record.exposure_time_s = facts.camera.exposure_time_s;
  record.width = facts.camera.width;
  record.height = facts.camera.height;
  record.source = entry.file.string();
  AddFrame(session_dir_, *session, record, bytes);
}

}  // namespace scanbench
