#include "app/controllers/simulate_controller.h"

#include <chrono>
#include <optional>

#include "app/io/dng_writer.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/session/session.h"
#include "core/field_error.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

bool HasFrame(const Session& session, std::optional<int> led_index) {
  return led_index ? FindLedFrame(session, *led_index) != nullptr : FindDarkFrame(session) != nullptr;
}

Session NewSession(const SimulateOptions& options, const SimulatedRig& rig) {
  Session session;
  session.sample_name = options.sample_name;
  session.notes = options.notes;
  session.created = FormatUtcTimestamp(std::chrono::system_clock::now());
  session.software_version = "scanbench " SCANBENCH_VERSION;
  session.rig = options.rig_description == SimulateOptions::RigDescriptionKind::kMeasured
                    ? MakeMeasuredRigDescription(rig.rig(), options.measured)
                    : rig.rig();
  session.camera.make = "scanbench";
  session.camera.model = "Simulated D5100";
  session.camera.serial = "SIM-" + std::to_string(options.rig.seed);
  session.camera.lens = "simulated prime";
  session.camera.iso = kSimulatedIso;
  session.camera.exposure_time_s = kSimulatedExposureTimeS;
  session.camera.f_number = kSimulatedFNumber;
  session.camera.width = rig.width();
  session.camera.height = rig.height();
  return session;
}

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
    WriteExr(path, truth.normal_in_table, OverwritePolicy::kRefuse);
  });
  std::tie(files.albedo_file, files.albedo_sha256) = commit("albedo.exr", [&](const fs::path& path) {
    WriteExr(path, truth.albedo, OverwritePolicy::kRefuse);
  });
  std::tie(files.height_file, files.height_sha256) = commit("height.exr", [&](const fs::path& path) {
    WriteExr(path, truth.height_mm, OverwritePolicy::kRefuse, {"Z"});
  });
  std::tie(files.mask_file, files.mask_sha256) = commit("sample_mask.png", [&](const fs::path& path) {
    ImageU8 mask = truth.sample_mask;
    for (size_t i = 0; i < mask.size(); ++i) mask.data()[i] = mask.data()[i] ? 255 : 0;
    WritePng(path, mask, OverwritePolicy::kRefuse);
  });
  return files;
}

}  // namespace

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

  const fs::path manifest = session_dir_ / "session.json";
  std::optional<Session> existing;
  if (fs::exists(manifest)) {
    existing = LoadSession(session_dir_);
    if (existing->capture_complete) {
      throw SessionError(manifest.string() + ": capture_complete: the session is complete; simulate into a new folder");
    }
  }

  ReportProgress("prepare scene", 0);
  std::optional<SimulatedRig> rig_storage;
  try {
    rig_storage.emplace(options_.rig, TextileScene(options_.scene),
                        MakeDefaultSimulatedRig(options_.rig.width, options_.rig.height), StageCallback("prepare scene"));
  } catch (const Cancelled&) {
    throw Cancelled("prepare scene");
  }
  const SimulatedRig& rig = *rig_storage;

  Session session = existing ? *existing : NewSession(options_, rig);
  if (!existing) {
    CreateSessionFolder(session_dir_);
    WriteSessionManifest(session_dir_, session);
  } else if (session.camera.width != rig.width() || session.camera.height != rig.height()) {
    throw SessionError(manifest.string() + ": camera.width/height: " + std::to_string(session.camera.width) + "x" +
                       std::to_string(session.camera.height) + " differs from the requested " +
                       std::to_string(rig.width()) + "x" + std::to_string(rig.height()) +
                       "; resume with the options of the interrupted run");
  }

  // Dark frame first, as on the bench; frame_index fixes each frame's noise.
  std::vector<std::optional<int>> frames = {std::nullopt};
  for (int k = 0; k < rig.num_leds(); ++k) frames.push_back(k);
  const int total = static_cast<int>(frames.size());
  for (int i = 0; i < total; ++i) {
    const std::optional<int> led = frames[i];
    if (HasFrame(session, led)) {
      ++summary_.frames_resumed;
      continue;
    }
    const std::string stage = "render frame " + std::to_string(i + 1) + "/" + std::to_string(total);
    RawImage raw;
    try {
      raw = rig.RenderFrame(led, static_cast<uint64_t>(i), [&](double fraction) {
        ReportProgress("simulate", (i + fraction) / total);
        return !IsStopRequested();
      });
    } catch (const Cancelled&) {
      throw Cancelled(stage);  // frames already written stay; a rerun resumes
    }

    FrameRecord record;
    record.kind = led ? FrameKind::kLed : FrameKind::kDark;
    record.led_index = led.value_or(-1);
    record.file = FrameFileName(led, ".dng");
    record.capture_time = FormatUtcTimestamp(std::chrono::system_clock::now());
    record.exposure_time_s = kSimulatedExposureTimeS;
    record.width = raw.width();
    record.height = raw.height();
    DngMetadata metadata;
    metadata.model = session.camera.model;
    metadata.serial = session.camera.serial;
    metadata.software = session.software_version;
    metadata.exposure_time_s = kSimulatedExposureTimeS;
    metadata.iso = kSimulatedIso;
    metadata.f_number = kSimulatedFNumber;
    AddFrame(session_dir_, session, record, EncodeDng(raw, metadata));
    ++summary_.frames_written;
  }

  if (options_.write_ground_truth) {
    ReportProgress("ground truth", 0);
    session.ground_truth = WriteGroundTruth(session_dir_, rig.RenderGroundTruth());
  }
  session.capture_complete = true;
  WriteSessionManifest(session_dir_, session);
  ReportProgress("simulate", 1);
  summary_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace scanbench
