// The camera of the simulated rig: each Capture() asks which LED is lit
// right now (in the firmware-in-the-loop test: the simulated board's pins)
// and renders that frame with SimulatedRig::RenderFrame, encoded as DNG like
// a camera's RAW file. ISO, shutter and aperture take D5100-like values and
// scale the signal; the rig's own rendering is the reference exposure.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "app/devices/camera/camera.h"
#include "app/sim/simulated_rig.h"

namespace scanbench {

struct SimulatedCameraOptions {
  ExposureSettings initial{100, 1.0 / 60, 8};    // settings at start, each one of the allowed values
  ExposureSettings reference{100, 1.0 / 60, 8};  // exposure the rig renders as is; > 0 each
  uint64_t first_frame_index = 0;  // noise index of the first capture (then +1 per capture); resume with another
  bool real_time = false;          // sleep for the exposure time, so timing around a capture is as on the bench
  std::string serial = "SIM-0001";  // recorded in the DNG and Info()

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

class SimulatedCamera : public Camera {
 public:
  // Which LED is lit now (nullopt: none, the dark frame). May throw; the
  // error becomes a CameraError (kIo) naming the camera.
  using LitLedCallback = std::function<std::optional<int>()>;

  // Throws std::invalid_argument for bad options, an empty callback or a
  // null rig.
  SimulatedCamera(std::shared_ptr<const SimulatedRig> rig, LitLedCallback lit_led,
                  SimulatedCameraOptions options = {});

  std::string description() const override { return "simulated camera"; }
  CameraDeviceInfo Info() override;
  CameraSettingState GetSetting(CameraSetting setting) override;
  void SetSetting(CameraSetting setting, const std::string& value) override;
  std::vector<std::string> CheckReady() override { return {}; }
  // Renders the frame for the LED lit at the call; the signal above black is
  // scaled by (t / t_ref) (ISO / ISO_ref) (N_ref / N)^2 and clipped at the
  // white level (noise scales with it: close enough for exposure checks).
  // Throws CameraError: kIo when the callback fails, kNotSupported when it
  // names an LED the rig does not have.
  CapturedFrame Capture() override;
  // PreviewRaw() as a small PPM.
  PreviewFrame CapturePreview() override;
  void StopPreview() override {}
  std::vector<CameraEvent> DrainEvents(std::chrono::milliseconds wait) override;
  void Reconnect() override {}

  // Captures so far.
  uint64_t capture_count() const { return capture_count_; }
  // The LED the last Capture() rendered (nullopt: the dark frame, or no capture yet).
  std::optional<int> last_lit_led() const { return last_lit_led_; }
  // Factor applied to the rig's signal at the current settings.
  double SignalScale() const;
  // The RAW frame the next Capture() would take now, sample for sample: the
  // LED lit at the call, the current settings, the next capture's noise; but
  // no capture is counted, no event queued and no exposure time waited. For
  // a live view that judges clipping on what the capture will record. Throws
  // CameraError as Capture() does.
  RawImage PreviewRaw() const;

 private:
  RawImage Render(std::optional<int> led, uint64_t frame_index) const;
  std::optional<int> ReadLitLed() const;

  std::shared_ptr<const SimulatedRig> rig_;
  LitLedCallback lit_led_;
  SimulatedCameraOptions options_;
  std::string values_[3];  // current ISO, shutter, aperture text
  uint64_t capture_count_ = 0;
  std::optional<int> last_lit_led_;
  std::vector<CameraEvent> events_;
};

// The allowed values of the simulated camera (a D5100 with an f/1.8 lens):
// ISO 100..6400 and shutter 30 s..1/4000 s in third stops, f/1.8..f/22.
const std::vector<std::string>& SimulatedCameraChoices(CameraSetting setting);

}  // namespace scanbench
