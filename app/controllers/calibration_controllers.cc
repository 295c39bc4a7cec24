#include "app/controllers/calibration_controllers.h"

#include <algorithm>
#include <chrono>
#include <sstream>
#include <stdexcept>

#include "app/io/file_util.h"
#include "app/io/raw_decoder.h"
#include "app/session/calibrated_lighting.h"
#include "app/session/calibration_target.h"
#include "app/session/session.h"
#include "calibration/color_checker.h"
#include "core/parallel_for.h"
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

// ---------------------------------------------------------------------------
// Colour

namespace {

// One thing the chart was shot in: a target session (every LED) or one RAW photo.
struct ColorTarget {
  std::string name;
  std::optional<TargetSession> session;
  DecodedRaw photo;  // when not a session
};

bool IsSessionFolder(const fs::path& path) { return fs::is_regular_file(path / "session.json"); }

// What a perfect white (facing up) reads under LED `led` of `field` at each
// pixel of the chart's bounding box: the calibrated intensity times n.l; zero
// outside it. One LED at a time: ten full-size images would hold 2 GB at 16 MP.
ImageF WhiteResponse(const LightField& field, const ColorChartQuad& quad, int led) {
  const int width = field.width(), height = field.height();
  double x0 = width, y0 = height, x1 = 0, y1 = 0;
  for (const Eigen::Vector2d& c : quad.corners_px) {
    x0 = std::min(x0, c.x()), y0 = std::min(y0, c.y()), x1 = std::max(x1, c.x()), y1 = std::max(y1, c.y());
  }
  const int bx0 = std::clamp(static_cast<int>(x0) - 2, 0, width), by0 = std::clamp(static_cast<int>(y0) - 2, 0, height);
  const int bx1 = std::clamp(static_cast<int>(x1) + 3, 0, width), by1 = std::clamp(static_cast<int>(y1) + 3, 0, height);
  ImageF response(width, height, 3);
  ParallelRows(by1 - by0, 0, {}, 0.0, 1.0, [&](int row) {
    const int y = by0 + row;
    std::vector<float> dirs(3 * field.num_lights()), intensities(3 * field.num_lights());
    for (int x = bx0; x < bx1; ++x) {
      field.Evaluate(x, y, dirs.data(), intensities.data());
      const float n_dot_l = std::max(0.0f, dirs[3 * led + 2]);  // the chart lies flat: n = table up
      float* out = response.data() + (static_cast<size_t>(y) * width + x) * 3;
      for (int c = 0; c < 3; ++c) out[c] = intensities[3 * led + c] * n_dot_l;
    }
  });
  return response;
}

// A photo under unknown light: per-channel gains from the chart's gray row.
void BalanceOnNeutralPatches(std::vector<PatchSample>& patches, const std::string& name) {
  std::string why;
  const std::optional<Eigen::Vector3d> gains = NeutralPatchGains(patches, ColorCheckerClassic(), &why);
  if (!gains) throw std::runtime_error(name + ": " + why);
  for (PatchSample& patch : patches) patch.value = patch.value.cwiseProduct(*gains);
}

// Per patch and channel, the median over the frames where the patch was used.
std::vector<PatchSample> CombineFrames(const std::vector<std::vector<PatchSample>>& frames) {
  const size_t num_patches = frames.front().size();
  std::vector<PatchSample> combined(num_patches);
  for (size_t p = 0; p < num_patches; ++p) {
    PatchSample& out = combined[p];
    out.clipped = true;
    out.too_dark = true;
    std::array<std::vector<double>, 3> values;
    for (const std::vector<PatchSample>& frame : frames) {
      const PatchSample& in = frame[p];
      out.clipped = out.clipped && in.clipped;
      out.too_dark = out.too_dark && in.too_dark;
      if (!in.used) continue;
      for (int c = 0; c < 3; ++c) {
        values[c].push_back(in.value[c]);
        out.samples[c] += in.samples[c];
      }
    }
    out.used = !values[0].empty();
    for (int c = 0; c < 3 && out.used; ++c) {
      std::vector<double>& v = values[c];
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      out.value[c] = v[v.size() / 2];
    }
    if (out.used) out.clipped = out.too_dark = false;
  }
  return combined;
}

}  // namespace

void ColorCalibrationJobOptions::Check() const {
  detection.Check();
  sampling.Check();
  correction.Check();
}

std::string ColorCalibrationJobSummary::FullReport() const {
  std::ostringstream out;
  for (const std::string& detection : detections) out << "  " << detection << "\n";
  out << "  white reference: "
      << (white_reference == "light_field"
              ? "the set's light calibration (absolute reflectance, the solver's albedo space)"
              : "the chart's gray row per frame (relative: no light calibration)")
      << ", " << num_frames << " frame(s)\n";
  out << "  " << fit.BriefReport() << "\n" << fit.PatchTable();
  return out.str();
}

struct ColorCalibrationController::Inputs {
  std::vector<ColorTarget> targets;
  CalibrationSet set;
  bool new_set = false;
};

ColorCalibrationController::ColorCalibrationController(std::vector<fs::path> targets, fs::path calibration_dir,
                                                       ColorCalibrationJobOptions options)
    : targets_(std::move(targets)), calibration_dir_(std::move(calibration_dir)), options_(std::move(options)) {}

void ColorCalibrationController::Run() {
  options_.Check();
  summary_ = ColorCalibrationJobSummary();
  if (targets_.empty()) throw std::invalid_argument("colour calibration: no chart sessions or RAW photos given");
  Inputs inputs = ReadTargets();
  const std::vector<PatchSample> patches = MeasurePatches(inputs);
  Fit(patches);
  WriteSet(inputs);
}

ColorCalibrationController::Inputs ColorCalibrationController::ReadTargets() const {
  const std::string stage = "read colour chart captures";
  const fs::path manifest = calibration_dir_ / kCalibrationManifestName;
  Inputs inputs;
  inputs.new_set = !fs::exists(manifest);
  if (!inputs.new_set) inputs.set = LoadCalibrationSet(calibration_dir_);
  for (size_t i = 0; i < targets_.size(); ++i) {
    ReportProgress(stage, double(i) / targets_.size(), targets_[i].filename().string());
    ColorTarget target;
    target.name = targets_[i].string();
    if (IsSessionFolder(targets_[i])) {
      if (inputs.new_set) {
        throw SessionError(manifest.string() + ": does not exist; a colour chart session is calibrated into an "
                                               "existing set (scanbench calibrate camera makes one)");
      }
      target.session = LoadTargetSession(targets_[i], CalibrationTargetDescription::Kind::kColorChart,
                                         options_.verify_checksums, *this, stage);
      CheckSameCamera(inputs.set.camera, manifest.string(), *target.session);
    } else {
      target.photo = DecodeRawFileWithInfo(targets_[i]);
      CalibratedCameraIdentity id;
      id.make = target.photo.make;
      id.model = target.photo.model;
      id.serial = target.photo.serial;
      id.width = target.photo.image.width();
      id.height = target.photo.image.height();
      if (inputs.new_set && i == 0) {
        inputs.set.created = Now();
        inputs.set.software_version = "scanbench " SCANBENCH_VERSION;
        inputs.set.camera = id;
      } else if (id.make != inputs.set.camera.make || id.model != inputs.set.camera.model ||
                 id.width != inputs.set.camera.width || id.height != inputs.set.camera.height ||
                 (!id.serial.empty() && !inputs.set.camera.serial.empty() && id.serial != inputs.set.camera.serial)) {
        throw SessionError(target.name + ": a " + id.make + " " + id.model + " (serial \"" + id.serial + "\") photo of " +
                           std::to_string(id.width) + "x" + std::to_string(id.height) + " px, but " + manifest.string() +
                           " is for a " + inputs.set.camera.make + " " + inputs.set.camera.model + " (serial \"" +
                           inputs.set.camera.serial + "\") at " + std::to_string(inputs.set.camera.width) + "x" +
                           std::to_string(inputs.set.camera.height) + ": a colour calibration serves one camera body");
      }
    }
    if (IsStopRequested()) throw Cancelled(stage);
    inputs.targets.push_back(std::move(target));
  }
  return inputs;
}

std::vector<PatchSample> ColorCalibrationController::MeasurePatches(const Inputs& inputs) {
  const std::string stage = "find and sample the chart";
  BeginStage(stage);
  const bool have_lights = inputs.set.lights.has_value();
  std::vector<std::vector<PatchSample>> frames;
  bool any_relative = false, any_absolute = false;
  for (size_t t = 0; t < inputs.targets.size(); ++t) {
    const ColorTarget& target = inputs.targets[t];
    const ProgressCallback progress = SubRange(StageCallback(stage), double(t) / inputs.targets.size(),
                                               double(t + 1) / inputs.targets.size());
    if (!target.session) {
      const ColorChartDetectionSummary found = DetectColorChart(options_.detection, target.photo.image, nullptr);
      if (found.IsCancelled()) throw Cancelled(stage);
      if (!found.IsUsable()) throw std::runtime_error(target.name + ": " + found.message);
      summary_.detections.push_back(target.name + ": " + found.BriefReport());
      std::vector<PatchSample> patches =
          SampleColorChartPatches(options_.sampling, target.photo.image, nullptr, found.quad, nullptr);
      BalanceOnNeutralPatches(patches, target.name);
      frames.push_back(std::move(patches));
      any_relative = true;
      continue;
    }
    const TargetSession& s = *target.session;
    // Camera and chart do not move between LEDs: find it once, in the first frame where it is found.
    std::optional<ColorChartDetectionSummary> found;
    std::string why;
    for (const RawImage& frame : s.leds) {
      ColorChartDetectionSummary attempt = DetectColorChart(options_.detection, frame, &s.dark);
      if (attempt.IsUsable()) {
        found = std::move(attempt);
        break;
      }
      why = attempt.message;
      ThrowIfStopRequested(stage);
    }
    if (!found) throw std::runtime_error(target.name + ": in none of its LED frames: " + why);
    summary_.detections.push_back(target.name + ": " + found->BriefReport());
    std::optional<CalibratedLighting> lighting;
    if (have_lights) {
      lighting = MakeCalibratedLighting(inputs.set, (calibration_dir_ / kCalibrationManifestName).string(), s.session,
                                        (s.dir / "session.json").string());
      any_absolute = true;
    } else {
      any_relative = true;
    }
    for (size_t k = 0; k < s.leds.size(); ++k) {
      const ImageF white =
          lighting ? WhiteResponse(*lighting->light_field, found->quad, static_cast<int>(k)) : ImageF();
      std::vector<PatchSample> patches = SampleColorChartPatches(options_.sampling, s.leds[k], &s.dark, found->quad,
                                                                 lighting ? &white : nullptr);
      if (!have_lights) BalanceOnNeutralPatches(patches, target.name + " LED " + std::to_string(k));
      frames.push_back(std::move(patches));
      if (!progress(double(k + 1) / s.leds.size())) throw Cancelled(stage);
    }
  }
  // Absolute (light field) and relative (gray row) values do not mix in one fit.
  if (any_relative && any_absolute) {
    throw std::invalid_argument("colour calibration: RAW photos (balanced on the gray row, relative) and chart "
                                "sessions measured through the set's light calibration (absolute) cannot be fitted "
                                "together; calibrate from one kind");
  }
  summary_.white_reference = any_absolute ? "light_field" : "neutral_patches";
  summary_.num_frames = static_cast<int>(frames.size());
  return CombineFrames(frames);
}

void ColorCalibrationController::Fit(const std::vector<PatchSample>& patches) {
  const std::string stage = "fit colour correction";
  BeginStage(stage);
  summary_.fit = FitColorCorrection(options_.correction, patches, ColorCheckerClassic());
  RequireSuccess(summary_.fit, "colour calibration failed");
}

void ColorCalibrationController::WriteSet(Inputs& inputs) const {
  ColorSection section;
  section.date = Now();
  for (const ColorTarget& target : inputs.targets) {
    if (target.session) {
      section.targets.push_back(MakeTargetCaptureRecord(target.session->dir, target.session->session, "color_chart"));
    } else {
      section.raw_files.push_back({target.name, Sha256HexOfFile(target.name)});
    }
  }
  section.white_reference = summary_.white_reference;
  section.num_frames = summary_.num_frames;
  section.summary = summary_.fit;
  inputs.set.color = section;
  WriteCalibrationSet(calibration_dir_, inputs.set);
  ReportProgress("fit colour correction", 1);
}

}  // namespace scanbench
