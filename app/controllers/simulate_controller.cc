#include "app/controllers/simulate_controller.h"

#include <chrono>
#include <optional>

#include "app/io/dng_writer.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/session/session.h"
#include "app/sim/sensor_color.h"
#include "core/field_error.h"
#include "core/format.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// session.json of an interrupted run, when there is one; a complete session is refused.
std::optional<Session> LoadInterruptedSession(const fs::path& session_dir) {
  const fs::path manifest = session_dir / "session.json";
  if (!fs::exists(manifest)) return std::nullopt;
  Session session = LoadSession(session_dir);
  if (session.capture_complete) {
    throw SessionError(manifest.string() + ": capture_complete: the session is complete; simulate into a new folder");
  }
  return session;
}

// An interrupted run is resumed with the same options only: its frames are of
// that size, colour model and scene.
void CheckResumedSize(const fs::path& session_dir, const Session& session, const SimulatedRig& rig) {
  CheckResumedSimulation(session_dir / "session.json", session,
                         SimulatedSceneOf(rig.options(), rig.scene().options()));
  const std::string model = SimulatedCameraModel(rig.options().color);
  if (session.camera.model != model) {
    throw SessionError((session_dir / "session.json").string() + ": camera.model: '" + session.camera.model +
                       "' differs from the requested '" + model +
                       "' (--camera-color); resume with the options of the interrupted run");
  }
  if (session.camera.width == rig.width() && session.camera.height == rig.height()) return;
  throw SessionError((session_dir / "session.json").string() + ": camera.width/height: " +
                     std::to_string(session.camera.width) + "x" + std::to_string(session.camera.height) +
                     " differs from the requested " + std::to_string(rig.width()) + "x" +
                     std::to_string(rig.height()) + "; resume with the options of the interrupted run");
}

// The ground truth's EXRs: 32-bit float, every value as in memory, and
// uncompressed: each solve and export of the session decodes them again, and
// at 16 MP decoding zip took seconds of CPU per solve (issue #14). Sessions
// simulated before, with zip, read the same.
const ExrEncoding kGroundTruthExrEncoding{ExrSampleType::kFloat32, ExrCompression::kNone};

// Ground truth files go beside the frames, checksummed like them.
GroundTruthFiles WriteGroundTruth(const fs::path& root, const GroundTruthMaps& truth) {
  const fs::path folder = root / "ground_truth";
  fs::create_directories(folder);
  GroundTruthFiles files;
  files.mm_per_pixel = truth.mm_per_pixel;
  auto commit = [&](const std::string& name, auto&& write) {
    const fs::path path = folder / name;
    if (!fs::exists(path)) write(path);  // an interrupted run may have written it already
    return std::pair{"ground_truth/" + name, Sha256HexOfFile(path)};
  };
  std::tie(files.normal_file, files.normal_sha256) = commit("normal.exr", [&](const fs::path& path) {
    WriteExr(path, truth.normal_in_table, OverwritePolicy::kRefuse, {}, {}, kGroundTruthExrEncoding);
  });
  std::tie(files.albedo_file, files.albedo_sha256) = commit("albedo.exr", [&](const fs::path& path) {
    WriteExr(path, truth.albedo, OverwritePolicy::kRefuse, {}, {}, kGroundTruthExrEncoding);
  });
  std::tie(files.height_file, files.height_sha256) = commit("height.exr", [&](const fs::path& path) {
    WriteExr(path, truth.height_mm, OverwritePolicy::kRefuse, {"Z"}, {}, kGroundTruthExrEncoding);
  });
  std::tie(files.mask_file, files.mask_sha256) = commit("sample_mask.png", [&](const fs::path& path) {
    ImageU8 mask = truth.sample_mask;
    for (size_t i = 0; i < mask.size(); ++i) mask.data()[i] = mask.data()[i] ? 255 : 0;
    WritePng(path, mask, OverwritePolicy::kRefuse);
  });
  return files;
}

}  // namespace

SimulatedSceneRecord SimulatedSceneOf(const SimulatedRigOptions& rig, const TextileSceneOptions& scene) {
  SimulatedSceneRecord record;
  record.sample = scene.sample == SampleKind::kColorChecker ? "colorchecker" : "twill";
  record.material = SurfaceMaterialName(scene.material);
  record.scene_seed = std::to_string(scene.seed);
  record.warp_pitch_mm = scene.warp_pitch_mm;
  record.weft_pitch_mm = scene.weft_pitch_mm;
  record.noise_seed = std::to_string(rig.seed);
  record.noise = rig.add_noise;
  record.cast_shadows = rig.cast_shadows;
  record.fold_amplitude_mm = scene.fold_amplitude_mm;
  return record;
}

std::string SimulatedCameraModel(SensorColorModel color) {
  return color == SensorColorModel::kSrgbPrimaries ? "Simulated D5100 (sRGB primaries)" : "Simulated D5100";
}

Session NewSimulatedSession(const std::string& sample_name, const std::string& notes, const RigDescription& rig,
                            const SimulatedRigOptions& rig_options, double exposure_time_s) {
  CameraInfo camera;
  camera.make = "scanbench";
  camera.model = SimulatedCameraModel(rig_options.color);
  camera.serial = "SIM-" + std::to_string(rig_options.seed);
  camera.lens = "simulated prime";
  camera.iso = kSimulatedIso;
  camera.exposure_time_s = exposure_time_s;
  camera.f_number = kSimulatedFNumber;
  camera.width = rig_options.width;
  camera.height = rig_options.height;
  return NewSessionManifest(sample_name, notes, rig, camera);
}

void AddSimulatedFrame(const fs::path& session_dir, Session& session, std::optional<int> led, const RawImage& raw,
                       SensorColorModel color) {
  FrameRecord record;
  record.kind = led ? FrameKind::kLed : FrameKind::kDark;
  record.led_index = led.value_or(-1);
  record.file = FrameFileName(led, ".dng");
  record.capture_time = FormatUtcTimestamp(std::chrono::system_clock::now());
  record.exposure_time_s = session.camera.exposure_time_s;
  record.width = raw.width();
  record.height = raw.height();
  DngMetadata metadata;
  metadata.model = session.camera.model;
  metadata.serial = session.camera.serial;
  metadata.software = session.software_version;
  metadata.exposure_time_s = session.camera.exposure_time_s;
  metadata.iso = kSimulatedIso;
  metadata.f_number = kSimulatedFNumber;
  metadata.camera_from_xyz_d65 = SimulatedCameraFromXyzD65(color);
  metadata.as_shot_neutral = SimulatedAsShotNeutral(color);
  AddFrame(session_dir, session, record, EncodeDng(raw, metadata));
}

void SimulateOptions::Check() const {
  rig.Check();
  scene.Check();
  measured.Check();
  if (sample_name.empty()) throw FieldError("SimulateOptions", "sample_name", "''", "must not be empty");
}

SimulateController::SimulateController(fs::path session_dir, SimulateOptions options)
    : session_dir_(std::move(session_dir)), options_(std::move(options)) {}

void SimulateController::Run() {
  options_.Check();
  const auto start = std::chrono::steady_clock::now();
  summary_ = SimulateSummary();
  summary_.session_dir = session_dir_;
  const FolderLock session_lock(session_dir_);  // as capture: one writer per session
  const std::optional<Session> existing = LoadInterruptedSession(session_dir_);

  BeginStage("prepare scene");
  const SimulatedRig rig(options_.rig, TextileScene(options_.scene),
                         MakeDefaultSimulatedRig(options_.rig.width, options_.rig.height, options_.rig.color),
                         RenderCallback("prepare scene", "prepare scene", 0, 1));

  Session session = existing ? *existing : NewSession(rig);
  if (existing) {
    CheckResumedSize(session_dir_, session, rig);
  } else {
    CreateSessionFolder(session_dir_);
    WriteSessionManifest(session_dir_, session);
  }

  // Dark frame first, as on the bench; frame_index fixes each frame's noise.
  std::vector<std::optional<int>> frames = {std::nullopt};
  for (int k = 0; k < rig.num_leds(); ++k) frames.push_back(k);
  const int total = static_cast<int>(frames.size());
  for (int i = 0; i < total; ++i) {
    const std::optional<int> led = frames[i];
    if (led ? FindLedFrame(session, *led) != nullptr : FindDarkFrame(session) != nullptr) {
      ++summary_.frames_resumed;
      continue;
    }
    const std::string stage = "render frame " + std::to_string(i + 1) + "/" + std::to_string(total);
    const RawImage raw = rig.RenderFrame(led, static_cast<uint64_t>(i), RenderCallback(stage, "simulate", i, total));
    AddSimulatedFrame(session_dir_, session, led, raw, options_.rig.color);
    ++summary_.frames_written;
  }

  if (options_.write_ground_truth) {
    ReportProgress("ground truth", 0);
    session.ground_truth = WriteGroundTruth(session_dir_, rig.RenderGroundTruth());
  }
  session.capture_complete = true;
  WriteSessionManifest(session_dir_, session);
  ReportProgress("simulate", 1);
  summary_.seconds = SecondsSince(start);
}

ProgressCallback SimulateController::RenderCallback(const std::string& stage, const std::string& reported_stage,
                                                    int part, int parts) const {
  return [this, stage, reported_stage, part, parts](double fraction) {
    ReportProgress(reported_stage, (part + fraction) / parts);
    ThrowIfStopRequested(stage);  // from inside the render: frames already written stay, a rerun resumes
    return true;
  };
}

Session SimulateController::NewSession(const SimulatedRig& rig) const {
  const RigDescription recorded = options_.rig_description == SimulateOptions::RigDescriptionKind::kMeasured
                                      ? MakeMeasuredRigDescription(rig.rig(), options_.measured)
                                      : rig.rig();
  Session session =
      NewSimulatedSession(options_.sample_name, options_.notes, recorded, options_.rig, kSimulatedExposureTimeS);
  session.simulation = SimulatedSceneOf(options_.rig, options_.scene);
  return session;
}

}  // namespace scanbench
