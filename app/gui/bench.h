// The scan bench as the GUI holds it: an LED board and a camera, either real
// (serial port, libgphoto2) or simulated (the firmware in simavr, the
// simulated rig's camera), assembled as `scanbench capture` does. Plain C++:
// the pages drive it, the controllers use its lights and camera.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

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

class Bench {
 public:
  // Connects both devices (slow: a board restarts on open). Throws naming
  // the device or file at fault and what to do.
  explicit Bench(const BenchOptions& options);
  ~Bench();
  Bench(const Bench&) = delete;
  Bench& operator=(const Bench&) = delete;

  LightController& lights() { return *lights_; }
  Camera& camera() { return *camera_; }
  const RigDescription& rig() const { return rig_; }
  const BenchOptions& options() const { return options_; }
  // Read once at connect (the pages show it; asking again needs the link).
  const LightFirmwareInfo& firmware() const { return firmware_; }
  const CameraDeviceInfo& camera_info() const { return camera_info_; }

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
  std::unique_ptr<SimulatedLedBoard> board_;
  std::shared_ptr<SimulatedRig> sim_rig_;
  std::unique_ptr<LightController> lights_;
  std::unique_ptr<Camera> camera_;
  SimulatedCamera* sim_camera_ = nullptr;  // camera_ when simulated
  RigDescription rig_;
  LightFirmwareInfo firmware_;
  CameraDeviceInfo camera_info_;
};

}  // namespace scanbench
