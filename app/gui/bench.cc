#include "app/gui/bench.h"

#include <optional>
#include <stdexcept>
#include <vector>

#include "app/devices/camera/gphoto2_camera.h"
#include "app/devices/camera/simulated_camera.h"
#include "app/devices/serial_light_controller.h"
#include "app/devices/serial_port_list.h"
#include "app/devices/simulated_led_board.h"
#include "app/io/file_util.h"
#include "app/session/rig_json.h"
#include "app/sim/simulated_rig.h"
#include "app/sim/textile_scene.h"

namespace scanbench {

BenchLights::BenchLights(const BenchOptions& options)
    : simulated_(options.simulated_lights), serial_port_(options.serial_port) {
  if (options.simulated_lights) {
    board_ = std::make_unique<SimulatedLedBoard>();
    lights_ = std::make_unique<SerialLightController>(board_->port_path());
  } else {
    lights_ = std::make_unique<SerialLightController>(options.serial_port.empty() ? FindArduinoPort()
                                                                                  : options.serial_port);
  }
  firmware_ = lights_->Version();
}

// The controller goes before the board it talks to.
BenchLights::~BenchLights() { lights_.reset(); }

bool BenchLights::Serves(const BenchOptions& options) const {
  return options.simulated_lights == simulated_ && (simulated_ || options.serial_port == serial_port_);
}

std::optional<RigDescription> CheckBenchOptions(const BenchOptions& options) {
  if (options.simulated_camera) return std::nullopt;
  if (options.rig_file.empty()) {
    throw std::invalid_argument(
        "a real camera needs the bench's rig description: choose its JSON file (LED positions, camera) "
        "in the Rig file field");
  }
  const std::vector<uint8_t> bytes = ReadFileBytes(options.rig_file);
  return RigDescriptionFromJson(std::string(bytes.begin(), bytes.end()), options.rig_file.string());
}

Bench::Bench(const BenchOptions& options, std::shared_ptr<BenchLights> lights)
    : options_(options), lights_(std::move(lights)) {
  const std::optional<RigDescription> real_rig = CheckBenchOptions(options);  // before any device
  if (!lights_) lights_ = std::make_shared<BenchLights>(options);

  if (options.simulated_camera) {
    SimulatedRigOptions rig_options;
    rig_options.width = options.sim_width;
    rig_options.height = options.sim_height;
    sim_rig_ = std::make_shared<SimulatedRig>(rig_options, TextileScene(),
                                              MakeDefaultSimulatedRig(options.sim_width, options.sim_height));
    rig_ = sim_rig_->rig();
    // The simulated camera renders whichever LED is lit: the simulated
    // board's pins when there is one, else what the real board reports
    // (asked on the capture thread, the lights' one owner during a run).
    SimulatedCamera::LitLedCallback lit;
    if (SimulatedLedBoard* board = lights_->board()) {
      lit = [board]() { return board->SingleLitLed(); };
    } else {
      lit = [lights = &lights_->lights()]() { return lights->Status().lit_led; };
    }
    auto camera = std::make_unique<SimulatedCamera>(sim_rig_, lit);
    sim_camera_ = camera.get();
    camera_ = std::move(camera);
  } else {
    rig_ = *real_rig;
    GPhotoCameraOptions camera_options;
    camera_options.model = options.camera_model;
    camera_options.port = options.camera_port;
    camera_ = std::make_unique<GPhotoCamera>(camera_options);
  }
  camera_info_ = camera_->Info();
  for (const CameraSetting setting : {CameraSetting::kIso, CameraSetting::kShutter, CameraSetting::kAperture}) {
    exposure_choices_.push_back(ExposureChoicesOf(*camera_, setting));
  }
}

RawImage Bench::PreviewRaw() {
  if (!sim_camera_) throw std::logic_error("Bench::PreviewRaw: only the simulated camera gives its RAW preview");
  return sim_camera_->PreviewRaw();
}

// The camera goes before the lights and rig it asks.
Bench::~Bench() {
  camera_.reset();
  lights_.reset();
}

}  // namespace scanbench
