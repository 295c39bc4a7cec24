#include "app/devices/camera/simulated_camera.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <stdexcept>
#include <thread>

#include "app/devices/camera/raw_preview.h"
#include "app/io/dng_writer.h"
#include "app/sim/sensor_color.h"

namespace scanbench {

namespace {

// "YYYY:MM:DD HH:MM:SS" in local time, as EXIF records it.
std::string ExifTime(std::chrono::system_clock::time_point time) {
  const std::time_t seconds = std::chrono::system_clock::to_time_t(time);
  std::tm local{};
  localtime_r(&seconds, &local);
  char text[32];
  std::strftime(text, sizeof(text), "%Y:%m:%d %H:%M:%S", &local);
  return text;
}

constexpr CameraSetting kSettings[] = {CameraSetting::kIso, CameraSetting::kShutter, CameraSetting::kAperture};

CameraSettingState StateOf(CameraSetting setting, const std::string& current) {
  CameraSettingState state;
  state.setting = setting;
  state.current = current;
  state.choices = SimulatedCameraChoices(setting);
  state.source = "simulated D5100";
  return state;
}

std::string ToText(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6g", value);
  return text;
}

}  // namespace

const std::vector<std::string>& SimulatedCameraChoices(CameraSetting setting) {
  static const std::vector<std::string> iso = {"100",  "125",  "160",  "200",  "250",  "320",  "400",
                                               "500",  "640",  "800",  "1000", "1250", "1600", "2000",
                                               "2500", "3200", "4000", "5000", "6400"};
  static const std::vector<std::string> shutter = {
      "30",    "25",    "20",    "15",    "13",     "10",     "8",      "6",      "5",      "4",     "3",
      "2.5",   "2",     "1.6",   "1.3",   "1",      "0.8",    "0.6",    "1/2",    "1/2.5",  "1/3",   "1/4",
      "1/5",   "1/6",   "1/8",   "1/10",  "1/13",   "1/15",   "1/20",   "1/25",   "1/30",   "1/40",  "1/50",
      "1/60",  "1/80",  "1/100", "1/125", "1/160",  "1/200",  "1/250",  "1/320",  "1/400",  "1/500", "1/640",
      "1/800", "1/1000", "1/1250", "1/1600", "1/2000", "1/2500", "1/3200", "1/4000"};
  static const std::vector<std::string> aperture = {"f/1.8", "f/2",  "f/2.2", "f/2.5", "f/2.8", "f/3.2",
                                                    "f/3.5", "f/4",  "f/4.5", "f/5",   "f/5.6", "f/6.3",
                                                    "f/7.1", "f/8",  "f/9",   "f/10",  "f/11",  "f/13",
                                                    "f/14",  "f/16", "f/18",  "f/20",  "f/22"};
  return ForSetting(setting, iso, shutter, aperture);
}

void SimulatedCameraOptions::Check() const {
  for (const CameraSetting setting : kSettings) {
    const std::string name = CameraSettingName(setting);
    const double reference_value = ExposureValue(reference, setting);
    if (!(reference_value > 0) || !std::isfinite(reference_value)) {
      throw std::invalid_argument("SimulatedCameraOptions.reference " + name + " = " + ToText(reference_value) +
                                  " must be > 0");
    }
    const double initial_value = ExposureValue(initial, setting);
    try {
      MatchSettingValue(StateOf(setting, ""), ToText(initial_value), "simulated camera");
    } catch (const CameraError& error) {
      throw std::invalid_argument("SimulatedCameraOptions.initial " + name + " = " + ToText(initial_value) +
                                  " must be one of the simulated camera's values: " + error.what());
    }
  }
}

SimulatedCamera::SimulatedCamera(std::shared_ptr<const SimulatedRig> rig, LitLedCallback lit_led,
                                 SimulatedCameraOptions options)
    : rig_(std::move(rig)), lit_led_(std::move(lit_led)), options_(std::move(options)) {
  options_.Check();
  if (!rig_) throw std::invalid_argument("SimulatedCamera: the rig is null");
  if (!lit_led_) throw std::invalid_argument("SimulatedCamera: the lit-LED callback is empty");
  for (const CameraSetting setting : kSettings) {
    values_[static_cast<int>(setting)] =
        MatchSettingValue(StateOf(setting, ""), ToText(ExposureValue(options_.initial, setting)), description());
  }
}

CameraDeviceInfo SimulatedCamera::Info() {
  CameraDeviceInfo info;
  info.backend = "simulated";
  const DngMetadata defaults;
  info.make = defaults.make;
  info.model = defaults.model;
  info.serial = options_.serial;
  info.lens = "simulated 85 mm prime";
  info.firmware = SCANBENCH_VERSION;
  info.port = "simulated";
  return info;
}

CameraSettingState SimulatedCamera::GetSetting(CameraSetting setting) {
  return StateOf(setting, values_[static_cast<int>(setting)]);
}

void SimulatedCamera::SetSetting(CameraSetting setting, const std::string& value) {
  values_[static_cast<int>(setting)] = MatchSettingValue(GetSetting(setting), value, description());
}

double SimulatedCamera::SignalScale() const {
  const auto value = [this](CameraSetting setting) {
    return ParseSettingValue(setting, values_[static_cast<int>(setting)]).value_or(1.0);
  };
  const ExposureSettings& reference = options_.reference;
  const double f_ratio = reference.f_number / value(CameraSetting::kAperture);
  return (value(CameraSetting::kShutter) / reference.exposure_time_s) * (value(CameraSetting::kIso) / reference.iso) *
         f_ratio * f_ratio;
}

std::optional<int> SimulatedCamera::ReadLitLed() const {
  std::optional<int> led;
  try {
    led = lit_led_();
  } catch (const std::exception& error) {
    throw CameraError(CameraErrorKind::kIo, description(), std::string("reading which LED is lit failed: ") +
                                                                   error.what());
  }
  if (led && (*led < 0 || *led >= rig_->num_leds())) {
    throw CameraError(CameraErrorKind::kNotSupported, description(),
                      "LED " + std::to_string(*led) + " is lit but the simulated rig has LEDs 0.." +
                          std::to_string(rig_->num_leds() - 1));
  }
  return led;
}

RawImage SimulatedCamera::Render(std::optional<int> led, uint64_t frame_index) const {
  RawImage raw = rig_->RenderFrame(led, frame_index);
  const double scale = SignalScale();
  if (std::abs(scale - 1.0) < 1e-12) return raw;
  for (int y = 0; y < raw.height(); ++y) {
    uint16_t* row = raw.mosaic.row(y);
    for (int x = 0; x < raw.width(); ++x) {
      const double black = raw.BlackAt(x, y);
      const double value = black + (row[x] - black) * scale;
      row[x] = static_cast<uint16_t>(std::lround(std::clamp(value, 0.0, double(raw.white_level))));
    }
  }
  return raw;
}

CapturedFrame SimulatedCamera::Capture() {
  const std::optional<int> led = ReadLitLed();
  const uint64_t frame_index = options_.first_frame_index + capture_count_;
  CapturedFrame frame;
  frame.capture_time = std::chrono::system_clock::now();
  frame.settings = CurrentExposure();
  if (options_.real_time) {
    std::this_thread::sleep_for(std::chrono::duration<double>(frame.settings.exposure_time_s));
  }
  DngMetadata metadata;
  metadata.serial = options_.serial;
  metadata.software = "scanbench " SCANBENCH_VERSION " simulated camera";
  metadata.exposure_time_s = frame.settings.exposure_time_s;
  metadata.iso = frame.settings.iso;
  metadata.f_number = frame.settings.f_number;
  metadata.capture_time = ExifTime(frame.capture_time);
  // The simulated camera's colour data, as a real camera's DNG carries it (issue #12).
  metadata.camera_from_xyz_d65 = SimulatedCameraFromXyzD65(rig_->options().color);
  metadata.as_shot_neutral = SimulatedAsShotNeutral(rig_->options().color);
  frame.bytes = EncodeDng(Render(led, frame_index), metadata);
  frame.extension = ".dng";
  char name[32];
  std::snprintf(name, sizeof(name), "SIM_%04llu.DNG", static_cast<unsigned long long>(frame_index % 10000));
  frame.source_name = name;
  ++capture_count_;
  last_lit_led_ = led;
  events_.push_back({CameraEvent::Type::kFileAdded, std::string("/") + name, frame.capture_time});
  events_.push_back({CameraEvent::Type::kCaptureComplete,
                     led ? "LED " + std::to_string(*led) + " lit" : std::string("no LED lit"), frame.capture_time});
  return frame;
}

RawImage SimulatedCamera::PreviewRaw() const {
  return Render(ReadLitLed(), options_.first_frame_index + capture_count_);
}

PreviewFrame SimulatedCamera::CapturePreview() {
  PreviewFrame preview;
  preview.bytes = EncodePreviewPpm(PreviewRaw());
  preview.mime_type = "image/x-portable-pixmap";
  preview.extension = ".ppm";
  preview.time = std::chrono::system_clock::now();
  return preview;
}

std::vector<CameraEvent> SimulatedCamera::DrainEvents(std::chrono::milliseconds) {
  std::vector<CameraEvent> events;
  events.swap(events_);
  return events;
}

}  // namespace scanbench
