#include "app/controllers/capture_controller.h"

#include <algorithm>
#include <optional>
#include <thread>

#include "app/io/file_util.h"
#include "app/io/raw_decoder.h"
#include "app/session/capture_folder.h"
#include "app/session/session.h"
#include "core/field_error.h"
#include "core/format.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// The board's account of the LEDs did not match what the frame needs.
class SpoiledFrame : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Whatever happens, the LEDs end dark.
class AllOffOnExit {
 public:
  explicit AllOffOnExit(LightController* lights) : lights_(lights) {}
  ~AllOffOnExit() {
    try {
      lights_->AllOff();
    } catch (...) {
      // The board may be gone; its watchdog turns the LEDs off then.
    }
  }

 private:
  LightController* lights_;
};

FrameExposure MeasureExposure(const RawImage& raw, const std::string& name, double clip_fraction) {
  FrameExposure exposure;
  exposure.frame = name;
  const int clip_level = static_cast<int>(clip_fraction * raw.white_level);
  size_t clipped = 0;
  std::vector<float> signal;
  signal.reserve(raw.mosaic.num_pixels() / 7 + 1);
  for (int y = 0; y < raw.height(); ++y) {
    const uint16_t* row = raw.mosaic.row(y);
    for (int x = 0; x < raw.width(); ++x) {
      clipped += row[x] >= clip_level;
      // A sparse sample is plenty for a percentile.
      if ((x + y * raw.width()) % 7 == 0) {
        const float black = raw.BlackAt(x, y);
        signal.push_back((row[x] - black) / (raw.white_level - black));
      }
    }
  }
  exposure.clipped_fraction = double(clipped) / raw.mosaic.num_pixels();
  if (!signal.empty()) {
    auto at = signal.begin() + static_cast<long>(0.99 * (signal.size() - 1));
    std::nth_element(signal.begin(), at, signal.end());
    exposure.signal_p99 = *at;
  }
  return exposure;
}

bool IsRetryable(const DeviceError& error) {
  switch (error.kind()) {
    case DeviceErrorKind::kDeviceReset:
    case DeviceErrorKind::kTimeout:
    case DeviceErrorKind::kProtocol:
    case DeviceErrorKind::kDisconnected:
      return true;
    default:
      return false;
  }
}

bool IsRetryable(const CameraError& error) {
  switch (error.kind()) {
    case CameraErrorKind::kBusy:
    case CameraErrorKind::kTimeout:
    case CameraErrorKind::kIo:
    case CameraErrorKind::kDisconnected:
    case CameraErrorKind::kBadFile:
      return true;
    default:
      return false;
  }
}

struct Shot {
  CapturedFrame frame;
  RawImage raw;
};

// Takes one frame: sets the LEDs, verifies them before and after the
// exposure, decodes the RAW; retries the failures a second try can cure and
// records each retry in the summary.
class FrameTaker {
 public:
  FrameTaker(const RigDescription& rig, Camera* camera, LightController* lights, const CaptureOptions& options,
             const BaseController& controller, CaptureSummary* summary)
      : rig_(rig), camera_(camera), lights_(lights), options_(options), controller_(controller), summary_(summary) {}

  // led: nullopt = the dark frame. stage: what a stop is reported as.
  Shot Take(std::optional<int> led, const std::string& stage) {
    const std::string name = FrameStem(led);
    for (int attempt = 1;; ++attempt) {
      if (controller_.IsStopRequested()) throw Cancelled(stage);
      std::string reason;
      try {
        return TakeOnce(led, name);
      } catch (const DeviceError& error) {
        if (!IsRetryable(error) || attempt == options_.max_attempts) throw;
        if (error.kind() == DeviceErrorKind::kDisconnected) lights_->Reconnect();
        reason = error.what();
      } catch (const CameraError& error) {
        if (!IsRetryable(error) || attempt == options_.max_attempts) throw;
        if (error.kind() == CameraErrorKind::kDisconnected) camera_->Reconnect();
        reason = error.what();
      } catch (const SpoiledFrame& error) {
        if (attempt == options_.max_attempts) throw;
        reason = error.what();
      }
      ++summary_->retries;
      summary_->retry_reasons.push_back(name + " attempt " + std::to_string(attempt) + ": " + reason);
    }
  }

 private:
  Shot TakeOnce(std::optional<int> led, const std::string& name) {
    if (led) {
      lights_->LightOnly(rig_.leds[*led].id);
    } else {
      lights_->AllOff();
    }
    std::this_thread::sleep_for(options_.led_settle);
    VerifyLights(led, "before");
    Shot shot;
    shot.frame = camera_->Capture();
    VerifyLights(led, "after");
    shot.raw = DecodeRaw(shot.frame.bytes, name + shot.frame.extension + " from " + camera_->description());
    return shot;
  }

  void VerifyLights(std::optional<int> led, const char* when) {
    const std::optional<int> expected = led ? std::optional<int>(rig_.leds[*led].id) : std::nullopt;
    const LightStatus status = lights_->Status();
    if (status.lit_led == expected) return;
    auto text = [](std::optional<int> channel) {
      return channel ? "LED channel " + std::to_string(*channel) + " lit" : std::string("all LEDs off");
    };
    throw SpoiledFrame(lights_->description() + " reports " + text(status.lit_led) + " " + when +
                       " the exposure, expected " + text(expected));
  }

  const RigDescription& rig_;
  Camera* camera_;
  LightController* lights_;
  const CaptureOptions& options_;
  const BaseController& controller_;
  CaptureSummary* summary_;
};

// The steps of CaptureController::Run, in order.

void CheckLedChannels(const RigDescription& rig, const LightController& lights) {
  for (size_t k = 0; k < rig.leds.size(); ++k) {
    if (rig.leds[k].id < 0 || rig.leds[k].id >= lights.led_count()) {
      throw std::invalid_argument("rig.leds[" + std::to_string(k) + "].id = " + std::to_string(rig.leds[k].id) +
                                  " is not a channel of " + lights.description() + " (0.." +
                                  std::to_string(lights.led_count() - 1) + ")");
    }
  }
}

// What an earlier, interrupted run journalled; resumed with the same camera
// and LED count only. nullopt for a new session.
std::optional<Session> LoadInterruptedSession(const fs::path& session_dir, const Camera& camera,
                                              const CameraDeviceInfo& info, const RigDescription& rig,
                                              const std::optional<SimulatedSceneRecord>& simulation) {
  const fs::path manifest = session_dir / "session.json";
  if (!fs::exists(manifest)) return std::nullopt;
  Session session = LoadSession(session_dir);
  if (session.capture_complete) {
    throw SessionError(manifest.string() + ": capture_complete: the session is complete; capture into a new folder");
  }
  if (session.camera.model != info.model || session.camera.serial != info.serial) {
    throw SessionError(manifest.string() + ": camera: recorded " + session.camera.model + " serial '" +
                       session.camera.serial + "' but " + camera.description() + " has serial '" + info.serial +
                       "'; resume with the camera that started the capture");
  }
  if (session.rig.leds.size() != rig.leds.size()) {
    throw SessionError(manifest.string() + ": rig.leds: " + std::to_string(session.rig.leds.size()) +
                       " LEDs recorded but the bench has " + std::to_string(rig.leds.size()));
  }
  if (simulation) CheckResumedSimulation(manifest, session, *simulation);
  return session;
}

// Refuses a camera that is not ready; applies the requested exposure.
void PrepareCamera(Camera& camera, const ExposureSettings& exposure) {
  const std::vector<std::string> problems = camera.CheckReady();
  if (!problems.empty()) {
    std::string message = camera.description() + " is not ready:";
    for (const std::string& problem : problems) message += " " + problem + ";";
    throw CameraError(CameraErrorKind::kWrongMode, camera.description(), message);
  }
  if (exposure.iso > 0) camera.SetIso(exposure.iso);
  if (exposure.exposure_time_s > 0) camera.SetExposureTime(exposure.exposure_time_s);
  if (exposure.f_number > 0) camera.SetFNumber(exposure.f_number);
}

// Why an exposure-check frame fails the check; "" when it passes.
std::string ExposureProblem(const FrameExposure& exposure, const CaptureOptions& options) {
  if (exposure.clipped_fraction > options.max_clipped_fraction) {
    return " " + exposure.frame + ": " + std::to_string(100 * exposure.clipped_fraction) +
           " % of raw samples clipped (limit " + std::to_string(100 * options.max_clipped_fraction) +
           " %): shorten the exposure or close the aperture;";
  }
  if (exposure.signal_p99 < options.min_signal) {
    return " " + exposure.frame + ": 99th percentile at " + std::to_string(100 * exposure.signal_p99) +
           " % of the raw range (need " + std::to_string(100 * options.min_signal) +
           " %): lengthen the exposure or open the aperture;";
  }
  return "";
}

// Every LED once, before anything is kept; throws naming every frame that fails.
std::vector<FrameExposure> CheckExposure(FrameTaker& taker, int num_leds, const CaptureOptions& options,
                                         const ProgressCallback& progress) {
  std::vector<FrameExposure> exposures;
  std::string failures;
  for (int k = 0; k < num_leds; ++k) {
    progress(double(k) / num_leds);  // a stop is noticed by Take
    const Shot shot = taker.Take(k, "exposure check");
    exposures.push_back(MeasureExposure(shot.raw, FrameStem(k), options.clip_fraction));
    failures += ExposureProblem(exposures.back(), options);
  }
  progress(1);
  if (!failures.empty()) throw std::runtime_error("exposure check failed, nothing was kept:" + failures);
  return exposures;
}

// session.json of a new capture, written once its first frame has arrived
// (which gives the image size).
Session NewCaptureSession(const CaptureOptions& options, const RigDescription& rig, const CameraDeviceInfo& info,
                          const ExposureSettings& settings, const RawImage& first_frame) {
  CameraInfo camera;
  camera.make = info.make;
  camera.model = info.model;
  camera.serial = info.serial;
  camera.lens = info.lens;
  camera.iso = settings.iso;
  camera.exposure_time_s = settings.exposure_time_s;
  camera.f_number = settings.f_number;
  camera.width = first_frame.width();
  camera.height = first_frame.height();
  Session session = NewSessionManifest(options.sample_name, options.notes, rig, camera);
  session.simulation = options.simulation;
  return session;
}

// Writes the frame into the session and journals it in session.json.
void JournalFrame(const fs::path& session_dir, Session& session, std::optional<int> led, const Shot& shot) {
  FrameRecord record;
  record.kind = led ? FrameKind::kLed : FrameKind::kDark;
  record.led_index = led.value_or(-1);
  record.file = FrameFileName(led, shot.frame.extension.empty() ? ".raw" : shot.frame.extension);
  record.capture_time = FormatUtcTimestamp(shot.frame.capture_time);
  record.exposure_time_s = shot.frame.settings.exposure_time_s > 0 ? shot.frame.settings.exposure_time_s
                                                                   : session.camera.exposure_time_s;
  record.width = shot.raw.width();
  record.height = shot.raw.height();
  AddFrame(session_dir, session, record, shot.frame.bytes);
}

}  // namespace

void CaptureOptions::Check() const {
  const char* where = "CaptureOptions";
  if (sample_name.empty()) throw FieldError(where, "sample_name", "''", "must not be empty");
  SCANBENCH_REQUIRE_GE(where, "exposure.iso", exposure.iso, 0);
  SCANBENCH_REQUIRE_GE(where, "exposure.exposure_time_s", exposure.exposure_time_s, 0);
  SCANBENCH_REQUIRE_GE(where, "exposure.f_number", exposure.f_number, 0);
  SCANBENCH_REQUIRE_GT_LE(where, "clip_fraction", clip_fraction, 0, 1);
  SCANBENCH_REQUIRE_GE_LE(where, "max_clipped_fraction", max_clipped_fraction, 0, 1);
  SCANBENCH_REQUIRE_GE_LT(where, "min_signal", min_signal, 0, 1);
  SCANBENCH_REQUIRE_GE_LE(where, "max_attempts", max_attempts, 1, 10);
  if (led_settle.count() < 0 || led_settle.count() > 10000) {
    throw FieldError(where, "led_settle", std::to_string(led_settle.count()) + " ms", "must lie in [0, 10000] ms");
  }
}

CaptureController::CaptureController(fs::path session_dir, RigDescription rig, Camera* camera,
                                     LightController* lights, CaptureOptions options)
    : session_dir_(std::move(session_dir)), rig_(std::move(rig)), camera_(camera), lights_(lights),
      options_(std::move(options)) {}

void CaptureController::Run() {
  options_.Check();
  if (camera_ == nullptr || lights_ == nullptr) throw std::invalid_argument("capture: camera and lights are required");
  const auto start = std::chrono::steady_clock::now();
  summary_ = CaptureSummary();
  summary_.session_dir = session_dir_;
  // A resume of a folder that is not there is refused before the lock would
  // make it.
  std::error_code missing;
  if (options_.resume && !fs::exists(session_dir_, missing)) CheckCaptureFolder(session_dir_, true);
  // Refused up front, not at the first colliding frame, while another capture
  // (or simulate) holds the session; the kernel drops the lock if we crash.
  const FolderLock session_lock(session_dir_);
  // A new capture never lands beside other files, a resume never starts a
  // new session (the lock file does not count).
  CheckCaptureFolder(session_dir_, options_.resume);
  CheckLedChannels(rig_, *lights_);
  const CameraDeviceInfo info = camera_->Info();
  std::optional<Session> session = LoadInterruptedSession(session_dir_, *camera_, info, rig_, options_.simulation);

  AllOffOnExit lights_off(lights_);
  if (options_.watchdog_ms > 0) lights_->SetWatchdog(options_.watchdog_ms);
  PrepareCamera(*camera_, options_.exposure);
  FrameTaker taker(rig_, camera_, lights_, options_, *this, &summary_);
  const int num_leds = static_cast<int>(rig_.leds.size());
  if (options_.check_exposure && (!session || session->frames.empty())) {
    summary_.exposure_check = CheckExposure(taker, num_leds, options_, StageCallback("exposure check"));
  }

  // Dark frame first, then one frame per LED; each journalled as it arrives.
  std::vector<std::optional<int>> frames = {std::nullopt};
  for (int k = 0; k < num_leds; ++k) frames.push_back(k);
  const int total = static_cast<int>(frames.size());
  for (int i = 0; i < total; ++i) {
    const std::optional<int> led = frames[i];
    if (const FrameRecord* journalled =
            session ? (led ? FindLedFrame(*session, *led) : FindDarkFrame(*session)) : nullptr) {
      ++summary_.frames_resumed;
      if (frame_journalled_) frame_journalled_(*session, *journalled);
      continue;
    }
    ReportProgress("capture", double(i) / total);
    const Shot shot = taker.Take(led, "capture");
    if (!session) {
      session = NewCaptureSession(options_, rig_, info, camera_->CurrentExposure(), shot.raw);
      CreateSessionFolder(session_dir_);
      WriteSessionManifest(session_dir_, *session);
    }
    JournalFrame(session_dir_, *session, led, shot);
    ++summary_.frames_captured;
    if (frame_journalled_) frame_journalled_(*session, session->frames.back());
  }
  lights_->AllOff();
  session->capture_complete = true;
  WriteSessionManifest(session_dir_, *session);
  ReportProgress("capture", 1);
  summary_.seconds = SecondsSince(start);
}

}  // namespace scanbench
