#include "app/controllers/capture_controller.h"

#include <algorithm>
#include <optional>
#include <thread>

#include "app/io/raw_decoder.h"
#include "app/session/session.h"

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

}  // namespace

void CaptureOptions::Check() const {
  auto fail = [](const std::string& field, double value, const std::string& rule) {
    throw std::invalid_argument("CaptureOptions." + field + " = " + std::to_string(value) + " " + rule);
  };
  if (sample_name.empty()) throw std::invalid_argument("CaptureOptions.sample_name must not be empty");
  if (exposure.iso < 0) fail("exposure.iso", exposure.iso, "must be >= 0");
  if (exposure.exposure_time_s < 0) fail("exposure.exposure_time_s", exposure.exposure_time_s, "must be >= 0");
  if (exposure.f_number < 0) fail("exposure.f_number", exposure.f_number, "must be >= 0");
  if (!(clip_fraction > 0 && clip_fraction <= 1)) fail("clip_fraction", clip_fraction, "must lie in (0, 1]");
  if (!(max_clipped_fraction >= 0 && max_clipped_fraction <= 1)) {
    fail("max_clipped_fraction", max_clipped_fraction, "must lie in [0, 1]");
  }
  if (!(min_signal >= 0 && min_signal < 1)) fail("min_signal", min_signal, "must lie in [0, 1)");
  if (max_attempts < 1 || max_attempts > 10) fail("max_attempts", max_attempts, "must lie in [1, 10]");
  if (led_settle.count() < 0 || led_settle.count() > 10000) {
    fail("led_settle (ms)", static_cast<double>(led_settle.count()), "must lie in [0, 10000]");
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
  const int num_leds = static_cast<int>(rig_.leds.size());
  for (int k = 0; k < num_leds; ++k) {
    if (rig_.leds[k].id < 0 || rig_.leds[k].id >= lights_->led_count()) {
      throw std::invalid_argument("rig.leds[" + std::to_string(k) + "].id = " + std::to_string(rig_.leds[k].id) +
                                  " is not a channel of " + lights_->description() + " (0.." +
                                  std::to_string(lights_->led_count() - 1) + ")");
    }
  }

  // Resume what an earlier run journalled, with the same camera only.
  const fs::path manifest = session_dir_ / "session.json";
  std::optional<Session> session;
  const CameraDeviceInfo info = camera_->Info();
  if (fs::exists(manifest)) {
    session = LoadSession(session_dir_);
    if (session->capture_complete) {
      throw SessionError(manifest.string() + ": capture_complete: the session is complete; capture into a new folder");
    }
    if (session->camera.model != info.model || session->camera.serial != info.serial) {
      throw SessionError(manifest.string() + ": camera: recorded " + session->camera.model + " serial '" +
                         session->camera.serial + "' but " + camera_->description() + " has serial '" + info.serial +
                         "'; resume with the camera that started the capture");
    }
    if (session->rig.leds.size() != rig_.leds.size()) {
      throw SessionError(manifest.string() + ": rig.leds: " + std::to_string(session->rig.leds.size()) +
                         " LEDs recorded but the bench has " + std::to_string(num_leds));
    }
  }

  AllOffOnExit lights_off(lights_);
  if (options_.watchdog_ms > 0) lights_->SetWatchdog(options_.watchdog_ms);
  const std::vector<std::string> problems = camera_->CheckReady();
  if (!problems.empty()) {
    std::string message = camera_->description() + " is not ready:";
    for (const std::string& problem : problems) message += " " + problem + ";";
    throw CameraError(CameraErrorKind::kWrongMode, camera_->description(), message);
  }
  if (options_.exposure.iso > 0) camera_->SetIso(options_.exposure.iso);
  if (options_.exposure.exposure_time_s > 0) camera_->SetExposureTime(options_.exposure.exposure_time_s);
  if (options_.exposure.f_number > 0) camera_->SetFNumber(options_.exposure.f_number);

  auto set_lights = [&](std::optional<int> led) {
    if (led) {
      lights_->LightOnly(rig_.leds[*led].id);
    } else {
      lights_->AllOff();
    }
  };
  auto verify_lights = [&](std::optional<int> led, const char* when) {
    const std::optional<int> expected = led ? std::optional<int>(rig_.leds[*led].id) : std::nullopt;
    const LightStatus status = lights_->Status();
    if (status.lit_led != expected) {
      auto text = [](std::optional<int> channel) {
        return channel ? "LED channel " + std::to_string(*channel) + " lit" : std::string("all LEDs off");
      };
      throw SpoiledFrame(lights_->description() + " reports " + text(status.lit_led) + " " + when +
                         " the exposure, expected " + text(expected));
    }
  };
  // One frame, verified before and after its exposure, retried on failures
  // that a second try can cure.
  auto take = [&](std::optional<int> led, const std::string& stage) {
    const std::string name = FrameStem(led);
    for (int attempt = 1;; ++attempt) {
      ThrowIfStopRequested(stage);
      std::string reason;
      try {
        set_lights(led);
        std::this_thread::sleep_for(options_.led_settle);
        verify_lights(led, "before");
        Shot shot;
        shot.frame = camera_->Capture();
        verify_lights(led, "after");
        shot.raw = DecodeRaw(shot.frame.bytes, name + shot.frame.extension + " from " + camera_->description());
        return shot;
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
      ++summary_.retries;
      summary_.retry_reasons.push_back(name + " attempt " + std::to_string(attempt) + ": " + reason);
    }
  };

  // Exposure check: every LED once, before anything is kept.
  const bool new_capture = !session || session->frames.empty();
  if (options_.check_exposure && new_capture) {
    std::string failures;
    for (int k = 0; k < num_leds; ++k) {
      ReportProgress("exposure check", double(k) / num_leds);
      const Shot shot = take(k, "exposure check");
      const FrameExposure exposure = MeasureExposure(shot.raw, FrameStem(k), options_.clip_fraction);
      summary_.exposure_check.push_back(exposure);
      if (exposure.clipped_fraction > options_.max_clipped_fraction) {
        failures += " " + exposure.frame + ": " + std::to_string(100 * exposure.clipped_fraction) +
                    " % of raw samples clipped (limit " + std::to_string(100 * options_.max_clipped_fraction) +
                    " %): shorten the exposure or close the aperture;";
      } else if (exposure.signal_p99 < options_.min_signal) {
        failures += " " + exposure.frame + ": 99th percentile at " + std::to_string(100 * exposure.signal_p99) +
                    " % of the raw range (need " + std::to_string(100 * options_.min_signal) +
                    " %): lengthen the exposure or open the aperture;";
      }
    }
    ReportProgress("exposure check", 1);
    if (!failures.empty()) throw std::runtime_error("exposure check failed, nothing was kept:" + failures);
  }

  // Dark frame first, then one frame per LED; each journalled as it arrives.
  std::vector<std::optional<int>> frames = {std::nullopt};
  for (int k = 0; k < num_leds; ++k) frames.push_back(k);
  const int total = static_cast<int>(frames.size());
  for (int i = 0; i < total; ++i) {
    const std::optional<int> led = frames[i];
    if (session && (led ? FindLedFrame(*session, *led) : FindDarkFrame(*session)) != nullptr) {
      ++summary_.frames_resumed;
      continue;
    }
    ReportProgress("capture", double(i) / total);
    const Shot shot = take(led, "capture");
    if (!session) {
      const ExposureSettings settings = camera_->CurrentExposure();
      Session created;
      created.sample_name = options_.sample_name;
      created.notes = options_.notes;
      created.created = FormatUtcTimestamp(std::chrono::system_clock::now());
      created.software_version = "scanbench " SCANBENCH_VERSION;
      created.rig = rig_;
      created.camera.make = info.make;
      created.camera.model = info.model;
      created.camera.serial = info.serial;
      created.camera.lens = info.lens;
      created.camera.iso = settings.iso;
      created.camera.exposure_time_s = settings.exposure_time_s;
      created.camera.f_number = settings.f_number;
      created.camera.width = shot.raw.width();
      created.camera.height = shot.raw.height();
      CreateSessionFolder(session_dir_);
      WriteSessionManifest(session_dir_, created);
      session = std::move(created);
    }
    FrameRecord record;
    record.kind = led ? FrameKind::kLed : FrameKind::kDark;
    record.led_index = led.value_or(-1);
    record.file = FrameFileName(led, shot.frame.extension.empty() ? ".raw" : shot.frame.extension);
    record.capture_time = FormatUtcTimestamp(shot.frame.capture_time);
    record.exposure_time_s = shot.frame.settings.exposure_time_s > 0 ? shot.frame.settings.exposure_time_s
                                                                     : session->camera.exposure_time_s;
    record.width = shot.raw.width();
    record.height = shot.raw.height();
    AddFrame(session_dir_, *session, record, shot.frame.bytes);
    ++summary_.frames_captured;
  }
  lights_->AllOff();
  session->capture_complete = true;
  WriteSessionManifest(session_dir_, *session);
  ReportProgress("capture", 1);
  summary_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace scanbench
