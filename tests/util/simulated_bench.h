// The simulated bench the capture tests drive: a simulated rig, the LED
// firmware running in simavr, the serial light controller on its port and the
// simulated camera, which renders the LED the board has lit.
#pragma once

#include <functional>
#include <memory>
#include <optional>

#include "app/devices/camera/simulated_camera.h"
#include "app/devices/serial_light_controller.h"
#include "app/devices/simulated_led_board.h"
#include "app/sim/simulated_rig.h"

namespace scanbench::testing {

struct SimulatedBench {
  // Members in construction order, so that the camera goes first and the rig last.
  std::shared_ptr<SimulatedRig> rig;
  std::unique_ptr<SimulatedLedBoard> board;
  std::unique_ptr<SerialLightController> lights;
  std::unique_ptr<SimulatedCamera> camera;
};

// Which LED the camera sees, asked of the board at each exposure.
using BoardLitLed = std::function<std::optional<int>(const SimulatedLedBoard&)>;

// A bench at width x height with the default textile scene; `lit_led` decides
// what the camera sees (default: the one lit LED, none when zero or several are lit).
inline SimulatedBench MakeSimulatedBench(int width, int height, BoardLitLed lit_led = {}) {
  if (!lit_led) lit_led = [](const SimulatedLedBoard& board) { return board.SingleLitLed(); };
  SimulatedRigOptions rig_options;
  rig_options.width = width;
  rig_options.height = height;
  SimulatedBench bench;
  bench.rig = std::make_shared<SimulatedRig>(rig_options, TextileScene(), MakeDefaultSimulatedRig(width, height));
  bench.board = std::make_unique<SimulatedLedBoard>();
  bench.lights = std::make_unique<SerialLightController>(bench.board->port_path());
  bench.camera = std::make_unique<SimulatedCamera>(
      bench.rig, [board = bench.board.get(), lit_led = std::move(lit_led)]() { return lit_led(*board); });
  return bench;
}

}  // namespace scanbench::testing
