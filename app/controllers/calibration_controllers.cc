#include "app/controllers/calibration_controllers.h"

#include <chrono>
#include <stdexcept>

#include "app/io/raw_decoder.h"
#include "app/session/calibration_target.h"
#include "app/session/session.h"
#include "core/summary.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// A complete target session of the expected kind, its frames decoded.
struct TargetSession {
  fs::path dir;
  Session session;
  CalibrationTargetDescription target;
  RawImage dark;
  std::vector<RawImage> leds;
};

TargetSession LoadTargetSession(const fs::path& dir, CalibrationTargetDescription::Kind kind, bool verify_checksums,
                                const BaseController& controller, const std::string& stage) {
  TargetSession t;
  t.dir = dir;
  SessionLoadOptions load;
  load.verify_checksums = verify_checksums;
  t.session = LoadSession(dir, load);
  const std::string manifest = (dir / "session.json").string();
  if (!t.session.capture_complete) {
    throw SessionError(manifest + ": capture.complete: false; finish the target capture first");
  }
  t.target = LoadCalibrationTarget(dir);
  if (t.target.kind != kind) {
    throw SessionError((dir / kCalibrationTargetFileName).string() + ": kind: \"" +
                       CalibrationTargetKindName(t.target.kind) + "\" but this calibration needs a \"" +
                       CalibrationTargetKindName(kind) + "\" session");
  }
  auto decode = [&](const FrameRecord& record) {
    const fs::path path = dir / record.file;
    RawImage raw = DecodeRawFile(path);
    CheckRawSize(raw, t.session.camera.width, t.session.camera.height, path.string());
    return raw;
  };
  t.dark = decode(*FindDarkFrame(t.session));
  for (size_t k = 0; k < t.session.rig.leds.size(); ++k) {
    if (controller.IsStopRequested()) throw Cancelled(stage);
    t.leds.push_back(decode(*FindLedFrame(t.session, static_cast<int>(k))));
  }
  return t;
}

CalibratedCameraIdentity IdentityOf(const Session& session) {
  CalibratedCameraIdentity id;
  id.make = session.camera.make;
  id.model = session.camera.model;
  id.serial = session.camera.serial;
  id.lens = session.camera.lens;
  id.width = session.camera.width;
  id.height = session.camera.height;
  return id;
}

std::string Now() { return FormatUtcTimestamp(std::chrono::system_clock::now()); }

// The set's camera identity only: a white or light calibration defines the
// LED set itself.
void CheckSameCamera(const CalibratedCameraIdentity& camera, const std::string& name, const TargetSession& target) {
  CalibrationSet camera_only;
  camera_only.camera = camera;
  CheckCalibrationFitsSession(camera_only, name, target.session, (target.dir / "session.json").string());
}

// A calibration set with a camera section, fitting the target session.
CalibrationSet LoadSetForTargets(const fs::path& calibration_dir, const TargetSession& target) {
  CalibrationSet set = LoadCalibrationSet(calibration_dir);
  if (!set.camera_calibration) {
    throw SessionError((calibration_dir / kCalibrationManifestName).string() +
                       ": camera_calibration: missing; run `scanbench calibrate camera` into this set first");
  }
  CheckSameCamera(set.camera, (calibration_dir / kCalibrationManifestName).string(), target);
  return set;
}

// A checkerboard view from a target session: every LED frame developed and
// summed (an evenly lit board), balanced to gray.
CalibrationView CheckerboardView(const TargetSession& t, const std::string& name) {
  RawDevelopOptions develop;
  develop.demosaic = RawDevelopOptions::Demosaic::kBilinear;
  ImageF sum;
  for (const RawImage& raw : t.leds) {
    const DevelopedFrame developed = DevelopRaw(raw, &t.dark, develop);
    if (sum.empty()) sum = ImageF(developed.rgb.width(), developed.rgb.height(), 3);
    for (size_t v = 0; v < sum.size(); ++v) sum.data()[v] += developed.rgb.data()[v];
  }
  CalibrationView view;
  view.name = name;
  view.gray = BalancedGray(sum);
  view.on_table = t.target.on_table;
  view.board_height_mm = t.target.board_height_mm;
  return view;
}

// Throws SessionError when `other` holds another board than the first session.
void CheckSameBoard(const CheckerboardTarget& board, const fs::path& first_session, const TargetSession& other) {
  const CheckerboardTarget& b = other.target.checkerboard;
  if (b.inner_corners_x != board.inner_corners_x || b.inner_corners_y != board.inner_corners_y ||
      b.square_mm != board.square_mm) {
    throw SessionError((other.dir / kCalibrationTargetFileName).string() + ": checkerboard: another board than in " +
                       first_session.string() + "; one calibration uses one board");
  }
}

}  // namespace

void CameraCalibrationJobOptions::Check() const { calibration.Check(); }

// ---------------------------------------------------------------------------
struct CameraCalibrationController::Inputs {
  std::vector<CalibrationView> views;
  std::vector<TargetCaptureRecord> records;
  CalibratedCameraIdentity identity;
  CheckerboardTarget board;
};

CameraCalibrationController::CameraCalibrationController(std::vector<fs::path> target_sessions, fs::path calibration_dir,
                                                         CameraCalibrationJobOptions options)
    : sessions_(std::move(target_sessions)), calibration_dir_(std::move(calibration_dir)),
      options_(std::move(options)) {}

void CameraCalibrationController::Run() {
  options_.Check();
  summary_ = CameraCalibrationSummary();
  CheckOutputFolder();
  const Inputs inputs = ReadCheckerboardSessions();
  Calibrate(inputs);
  WriteSet(inputs);
}

void CameraCalibrationController::CheckOutputFolder() const {
  const fs::path manifest = calibration_dir_ / kCalibrationManifestName;
  if (fs::exists(manifest) && !options_.replace) {
    throw SessionError(manifest.string() +
                       ": already exists; a camera calibration starts a new calibration set (choose another folder, "
                       "or replace it)");
  }
  if (sessions_.empty()) throw std::invalid_argument("camera calibration: no checkerboard sessions given");
}

CameraCalibrationController::Inputs CameraCalibrationController::ReadCheckerboardSessions() const {
  const std::string stage = "read checkerboard sessions";
  Inputs inputs;
  for (size_t i = 0; i < sessions_.size(); ++i) {
    ReportProgress(stage, double(i) / sessions_.size());
    const TargetSession t = LoadTargetSession(sessions_[i], CalibrationTargetDescription::Kind::kCheckerboard,
                                              options_.verify_checksums, *this, stage);
    if (i == 0) {
      inputs.identity = IdentityOf(t.session);
      inputs.board = t.target.checkerboard;
    } else {
      CheckSameCamera(inputs.identity, (sessions_[0] / "session.json").string() + " (first checkerboard session)", t);
      CheckSameBoard(inputs.board, sessions_[0], t);
    }
    inputs.views.push_back(CheckerboardView(t, sessions_[i].string()));
    inputs.records.push_back(MakeTargetCaptureRecord(t.dir, t.session, "checkerboard"));
    ThrowIfStopRequested(stage);
  }
  return inputs;
}

void CameraCalibrationController::Calibrate(const Inputs& inputs) {
  const std::string stage = "calibrate camera";
  BeginStage(stage);
  summary_ = CalibrateCamera(options_.calibration, inputs.board, inputs.views, StageCallback(stage));
  ThrowIfStopRequested(stage);
  if (summary_.IsCancelled()) throw Cancelled(stage);
  if (!summary_.IsUsable()) {
    std::string reasons;
    for (const CalibrationViewReport& view : summary_.views) {
      if (!view.used) reasons += "\n  " + view.name + ": " + view.reason;
    }
    throw std::runtime_error("camera calibration failed: " + summary_.message + reasons);
  }
}

void CameraCalibrationController::WriteSet(const Inputs& inputs) const {
  CalibrationSet set;
  set.created = Now();
  set.software_version = "scanbench " SCANBENCH_VERSION;
  set.camera = inputs.identity;
  CameraCalibrationSection section;
  section.date = set.created;
  section.targets = inputs.records;
  section.board = inputs.board;
  section.summary = summary_;
  set.camera_calibration = section;
  if (options_.replace && fs::exists(calibration_dir_ / "lights")) fs::remove_all(calibration_dir_ / "lights");
  WriteCalibrationSet(calibration_dir_, set);
  ReportProgress("calibrate camera", 1);
}

// ---------------------------------------------------------------------------
struct WhiteBalanceController::Inputs {
  TargetSession target;
  CalibrationSet set;
};

WhiteBalanceController::WhiteBalanceController(fs::path target_session, fs::path calibration_dir,
                                               WhiteBalanceJobOptions options)
    : session_(std::move(target_session)), calibration_dir_(std::move(calibration_dir)),
      options_(std::move(options)) {}

void WhiteBalanceController::Run() {
  options_.Check();
  summary_ = WhiteBalanceSummary();
  Inputs inputs = ReadInputs();
  Calibrate(inputs);
  WriteSet(inputs);
}

WhiteBalanceController::Inputs WhiteBalanceController::ReadInputs() const {
  const std::string stage = "read gray chart session";
  BeginStage(stage);
  Inputs inputs;
  inputs.target = LoadTargetSession(session_, CalibrationTargetDescription::Kind::kGrayChart, options_.verify_checksums,
                                    *this, stage);
  inputs.set = LoadSetForTargets(calibration_dir_, inputs.target);
  return inputs;
}

void WhiteBalanceController::Calibrate(const Inputs& inputs) {
  const std::string stage = "white balance";
  BeginStage(stage);
  const TargetSession& t = inputs.target;
  summary_ = CalibrateWhiteBalance(options_.white_balance, t.target.gray_chart,
                                   inputs.set.camera_calibration->summary.camera, t.session.rig.leds, t.dark, t.leds,
                                   StageCallback(stage));
  ThrowIfStopRequested(stage);
  if (summary_.IsCancelled()) throw Cancelled(stage);
  RequireSuccess(summary_, "white balance failed");
}

void WhiteBalanceController::WriteSet(Inputs& inputs) const {
  const TargetSession& t = inputs.target;
  WhiteBalanceSection section;
  section.date = Now();
  section.targets = {MakeTargetCaptureRecord(t.dir, t.session, "gray_chart")};
  for (const LedDescription& led : t.session.rig.leds) section.led_ids.push_back(led.id);
  section.summary = summary_;
  CalibrationSet& set = inputs.set;
  set.white_balance = section;
  if (set.lights && set.lights->summary.model.size() != section.led_ids.size()) {
    set.lights.reset();  // another LED set: the old light calibration no longer applies
  }
  WriteCalibrationSet(calibration_dir_, set);
  ReportProgress("white balance", 1);
}

// ---------------------------------------------------------------------------
struct LightCalibrationController::Inputs {
  std::vector<TargetSession> targets;
  CalibrationSet set;
};

LightCalibrationController::LightCalibrationController(std::vector<fs::path> target_sessions, fs::path calibration_dir,
                                                       LightCalibrationJobOptions options)
    : sessions_(std::move(target_sessions)), calibration_dir_(std::move(calibration_dir)),
      options_(std::move(options)) {}

void LightCalibrationController::Run() {
  options_.Check();
  summary_ = LightCalibrationSummary();
  if (sessions_.empty()) throw std::invalid_argument("light calibration: no white sheet sessions given");
  Inputs inputs = ReadWhiteSheetSessions();
  Calibrate(inputs);
  WriteSet(inputs);
}

LightCalibrationController::Inputs LightCalibrationController::ReadWhiteSheetSessions() const {
  const std::string stage = "read white sheet sessions";
  Inputs inputs;
  std::vector<TargetSession>& targets = inputs.targets;
  for (size_t i = 0; i < sessions_.size(); ++i) {
    ReportProgress(stage, double(i) / sessions_.size());
    targets.push_back(LoadTargetSession(sessions_[i], CalibrationTargetDescription::Kind::kWhiteSheet,
                                        options_.verify_checksums, *this, stage));
    if (i == 0) inputs.set = LoadSetForTargets(calibration_dir_, targets.back());
    CheckSameCamera(inputs.set.camera, (calibration_dir_ / kCalibrationManifestName).string(), targets.back());
    if (targets.back().session.rig.leds.size() != targets[0].session.rig.leds.size()) {
      throw SessionError((sessions_[i] / "session.json").string() + ": rig.leds: " +
                         std::to_string(targets.back().session.rig.leds.size()) + " LEDs, but " +
                         sessions_[0].string() + " has " + std::to_string(targets[0].session.rig.leds.size()));
    }
  }
  return inputs;
}

void LightCalibrationController::Calibrate(const Inputs& inputs) {
  const std::string stage = "calibrate lights";
  std::vector<WhiteSheetCapture> captures;
  for (const TargetSession& t : inputs.targets) {
    WhiteSheetCapture capture;
    capture.name = t.dir.string();
    capture.sheet = t.target.white_sheet;
    capture.dark = &t.dark;
    for (const RawImage& raw : t.leds) capture.led_frames.push_back(&raw);
    captures.push_back(capture);
  }
  BeginStage(stage);
  // The measured LED positions of the first session are the start.
  summary_ = CalibrateLights(options_.lights, inputs.set.camera_calibration->summary.camera,
                             inputs.targets[0].session.rig.leds, captures, StageCallback(stage));
  ThrowIfStopRequested(stage);
  if (summary_.IsCancelled()) throw Cancelled(stage);
  RequireSuccess(summary_, "light calibration failed");
}

void LightCalibrationController::WriteSet(Inputs& inputs) const {
  LightsSection section;
  section.date = Now();
  for (const TargetSession& t : inputs.targets) {
    section.targets.push_back(MakeTargetCaptureRecord(t.dir, t.session, "white_sheet"));
    section.sheets.push_back(t.target.white_sheet);
  }
  section.summary = summary_;
  CalibrationSet& set = inputs.set;
  set.lights = section;
  if (set.white_balance && set.white_balance->summary.leds.size() != summary_.model.size()) {
    set.white_balance.reset();  // another LED set
  }
  WriteCalibrationSet(calibration_dir_, set);
  ReportProgress("calibrate lights", 1);
}

}  // namespace scanbench
