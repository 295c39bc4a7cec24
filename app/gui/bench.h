// The scan bench as the GUI holds it: an LED board and a camera, either real
// (serial port, libgphoto2) or simulated (the firmware in simavr, the
// simulated rig's camera), assembled as `scanbench capture` does. Plain C++:
// the pages drive it, the controllers use its lights and camera.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "app/devices/camera/camera.h"
#include "app/devices/light_controller.h"
#include "calibration/raw_image.h"
#include "calibration/rig.h"

namespace scanbench {

class SimulatedCamera;
class SimulatedLedBoard;
class SimulatedRig;

struct BenchOptions {
  bool simulated_lights = true;
  std::string serial_port;          // real board: "/dev/ttyACM0"; "" = the one Arduino found
  bool simulated_camera = true;
  std::string camera_model;         // libgphoto2: "" = autodetect
  std::string camera_port;
  std::filesystem::path rig_file;   // real camera: the bench's rig description (JSON), required
  int sim_width = 1232;             // simulated camera image size, pixels
  int sim_height = 816;
};

// The LED board half of a bench: kept connected when only the camera is
// connected again (a failed camera connect leaves a working board alone).
class BenchLights {
 public:
  // Connects the board the options choose (slow: a board restarts on open).
  // Throws naming the port.
  explicit BenchLights(const BenchOptions& options);
  ~BenchLights();
  BenchLights(const BenchLights&) = delete;
  BenchLights& operator=(const BenchLights&) = delete;

  LightController& lights() { return *lights_; }
  SimulatedLedBoard* board() { return board_.get(); }  // the simulated board; nullptr for a real one
  const LightFirmwareInfo& firmware() const { return firmware_; }
  // Whether `options` choose this same board (then it need not be opened again).
  bool Serves(const BenchOptions& options) const;

 private:
  bool simulated_;
  std::string serial_port_;  // as chosen ("" = the Arduino found)
  std::unique_ptr<SimulatedLedBoard> board_;
  std::unique_ptr<LightController> lights_;
  LightFirmwareInfo firmware_;
};

// What the options say before any device is touched: throws naming the
// field or file (a real camera without a rig file, a rig file that does not
// read); returns the real camera's rig description, nullopt for the
// simulated camera (its rig comes with it).
std::optional<RigDescription> CheckBenchOptions(const BenchOptions& options);

class Bench {
 public:
  // Connects both devices, or the camera only beside `lights` (already
  // connected, and kept by the caller when the camera fails). Throws naming
  // the device or file at fault and what to do.
  explicit Bench(const BenchOptions& options, std::shared_ptr<BenchLights> lights = nullptr);
  ~Bench();
  Bench(const Bench&) = delete;
  Bench& operator=(const Bench&) = delete;

  LightController& lights() { return lights_->lights(); }
  const std::shared_ptr<BenchLights>& lights_part() const { return lights_; }
  Camera& camera() { return *camera_; }
  const RigDescription& rig() const { return rig_; }
  const BenchOptions& options() const { return options_; }
  // Read once at connect (the pages show it; asking again needs the link).
  const LightFirmwareInfo& firmware() const { return lights_->firmware(); }
  const CameraDeviceInfo& camera_info() const { return camera_info_; }
  // ISO, shutter speed and aperture as the camera allowed them at connect
  // (ExposureChoicesOf), in that order: what the Capture page offers.
  const std::vector<ExposureChoices>& exposure_choices() const { return exposure_choices_; }

  // Whether PreviewRaw() can give the RAW data behind a live-view frame: the
  // simulated camera only (a DSLR's live view is a JPEG).
  bool has_raw_preview() const { return sim_camera_ != nullptr; }
  // The RAW frame the simulated camera's next capture would take now
  // (SimulatedCamera::PreviewRaw: the lit LED, its exposure settings,
  // clipped at the white level), for the live view's clipping. Same thread rule as camera(). Throws std::logic_error without
  // has_raw_preview().
  RawImage PreviewRaw();

 private:
  BenchOptions options_;
  std::shared_ptr<BenchLights> lights_;
  std::shared_ptr<SimulatedRig> sim_rig_;
  std::unique_ptr<Camera> camera_;
  SimulatedCamera* sim_camera_ = nullptr;  // camera_ when simulated
  RigDescription rig_;
  CameraDeviceInfo camera_info_;
  std::vector<ExposureChoices> exposure_choices_;
};

}  // namespace scanbench
