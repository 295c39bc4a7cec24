// devices and led: what is plugged in, and the LED board by hand (bench
// testing, checking the wiring).
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "app/cli/command_util.h"
#include "app/cli/commands.h"
#include "app/cli/run_controller.h"
#include "app/devices/camera/device_discovery.h"
#include "app/devices/serial_light_controller.h"
#include "app/devices/serial_port_list.h"
#include "app/devices/simulated_led_board.h"
#include "firmware/protocol/led_protocol.h"

namespace scanbench {

namespace {

struct LedCommandState {
  std::string port;        // --port; "" = the one recognised Arduino
  bool simulated = false;  // --simulated: the firmware in simavr
  std::string firmware_elf;  // --firmware, with --simulated
  int led = 0;             // on <led>
  double hold_seconds = 0;  // on --hold
  uint32_t watchdog_ms = 0;  // --watchdog-ms; 0 = the firmware's default
};

// Ctrl-C during --hold: finish the hold early and switch the LED off.
std::atomic<bool> interrupted{false};
extern "C" void OnInterrupt(int) { interrupted = true; }

std::string UsbIdText(const SerialPortInfo& port) {
  if (!port.usb_vendor_id || !port.usb_product_id) return "-";
  return FormatUsbId(*port.usb_vendor_id, *port.usb_product_id);
}

// The board to talk to: real or simulated, which the caller keeps alive
// for as long as it uses the controller.
struct Connection {
  std::unique_ptr<SimulatedLedBoard> simulated_board;
  std::unique_ptr<SerialLightController> controller;
};

Connection Connect(const LedCommandState& state, bool all_off_on_close) {
  Connection connection;
  std::string port = state.port;
  if (state.simulated) {
    SimulatedLedBoardOptions options;
    if (!state.firmware_elf.empty()) options.firmware_elf = state.firmware_elf;
    connection.simulated_board = std::make_unique<SimulatedLedBoard>(options);
    port = connection.simulated_board->port_path();
    std::cout << "Simulated LED board (firmware in simavr) on " << port << "\n";
  } else if (port.empty()) {
    port = FindArduinoPort({"name its port with --port", "use --simulated"});  // led's own options
  }
  SerialLightControllerOptions options;
  options.all_off_on_close = all_off_on_close;
  options.watchdog_ms = state.watchdog_ms;
  connection.controller = std::make_unique<SerialLightController>(port, options);
  return connection;
}

void PrintSimulatedPins(const Connection& connection) {
  if (!connection.simulated_board) return;
  const std::vector<int> lit = connection.simulated_board->LitLedIndices();
  std::cout << "Simulated pins: ";
  if (lit.empty()) std::cout << "all LED pins low";
  for (size_t i = 0; i < lit.size(); ++i) {
    std::cout << (i ? ", " : "") << "LED " << lit[i] << " (D" << led_protocol::kFirstLedPin + lit[i] << ") high";
  }
  std::cout << "\n";
}

std::string StatusText(const LightStatus& status) {
  std::ostringstream text;
  text << "lit: " << (status.lit_led ? "LED " + std::to_string(*status.lit_led) : std::string("none"))
       << ", uptime " << std::fixed << std::setprecision(1) << status.uptime_ms / 1000.0 << " s, watchdog "
       << status.watchdog_ms << " ms (tripped " << status.watchdog_trips << " times)";
  return text.str();
}

int LedOn(const LedCommandState& state) {
  const bool hold = state.hold_seconds > 0;
  // Without --hold the LED stays lit after we exit, until the board's
  // watchdog ends it; with --hold we switch it off ourselves.
  Connection connection = Connect(state, /*all_off_on_close=*/hold || state.simulated);
  SerialLightController& controller = *connection.controller;
  controller.LightOnly(state.led);
  const LightStatus status = controller.Status();
  std::cout << controller.description() << ": LED " << state.led << " on (" << StatusText(status) << ")\n";
  PrintSimulatedPins(connection);
  if (!hold) {
    if (connection.simulated_board) {
      std::cout << "The simulated board stops with this command; use --hold to keep it lit.\n";
    } else {
      std::cout << "It stays lit until the board's watchdog turns it off after " << status.watchdog_ms
                << " ms without a command (--hold keeps it lit).\n";
    }
    return kExitSuccess;
  }

  // Keep the watchdog fed well within its period until the hold ends.
  interrupted = false;
  struct sigaction action{};
  struct sigaction previous{};
  action.sa_handler = &OnInterrupt;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, &previous);
  std::cout << "Holding for " << state.hold_seconds << " s (Ctrl-C ends it)...\n";
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(state.hold_seconds);
  const auto ping_every = std::chrono::milliseconds(std::max<uint32_t>(50, status.watchdog_ms / 4));
  int exit_code = kExitSuccess;
  try {
    while (!interrupted && std::chrono::steady_clock::now() < end) {
      std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(
          ping_every, std::chrono::duration_cast<std::chrono::steady_clock::duration>(end - std::chrono::steady_clock::now())));
      const LightStatus now = controller.Status();
      if (now.lit_led != state.led) {
        std::cerr << "scanbench: error: " << controller.description() << " reports "
                  << StatusText(now) << " instead of LED " << state.led << "\n";
        exit_code = kExitFailure;
        break;
      }
    }
  } catch (...) {
    sigaction(SIGINT, &previous, nullptr);
    throw;
  }
  sigaction(SIGINT, &previous, nullptr);
  controller.AllOff();
  std::cout << "LED " << state.led << " off" << (interrupted ? " (interrupted)" : "") << "\n";
  return interrupted ? kExitCancelled : exit_code;
}

int LedOff(const LedCommandState& state) {
  Connection connection = Connect(state, /*all_off_on_close=*/false);
  connection.controller->AllOff();
  std::cout << connection.controller->description() << ": all LEDs off\n";
  PrintSimulatedPins(connection);
  return kExitSuccess;
}

int LedStatus(const LedCommandState& state) {
  Connection connection = Connect(state, /*all_off_on_close=*/false);
  const LightStatus status = connection.controller->Status();
  std::cout << connection.controller->description() << ": " << StatusText(status) << "\n";
  if (!connection.simulated_board && status.uptime_ms < 5000) {
    std::cout << "(Opening the port restarts an Uno, so this is the state since just now.)\n";
  }
  PrintSimulatedPins(connection);
  return kExitSuccess;
}

int LedVersion(const LedCommandState& state) {
  Connection connection = Connect(state, /*all_off_on_close=*/false);
  const LightFirmwareInfo info = connection.controller->Version();
  std::cout << connection.controller->description() << ": " << info.name << " " << info.version << ", "
            << info.led_count << " LEDs\n";
  return kExitSuccess;
}

int ListDevices() {
  const std::vector<SerialPortInfo> ports = ListSerialPorts();
  std::cout << "Serial ports:\n";
  if (ports.empty()) std::cout << "  (none)\n";
  for (const SerialPortInfo& port : ports) {
    std::cout << "  " << std::left << std::setw(16) << port.path << " " << std::setw(9) << port.transport << " "
              << std::setw(9) << UsbIdText(port) << " "
              << (port.board.empty() ? "-" : port.board) << "  [" << port.description << "]\n";
  }
  std::cout << "Cameras (libgphoto2):\n";
  try {
    const std::vector<DetectedCamera> cameras = DetectCameras();
    if (cameras.empty()) std::cout << "  (none)\n";
    for (const DetectedCamera& camera : cameras) std::cout << "  " << camera.model << " on " << camera.port << "\n";
  } catch (const std::exception& error) {
    std::cout << "  (not probed: " << error.what() << ")\n";
  }
  return kExitSuccess;
}

void AddConnectionOptions(CLI::App& command, LedCommandState& state) {
  auto* port = command.add_option("--port", state.port,
                                  "Serial port of the LED board (default: the one Arduino `scanbench devices` "
                                  "recognises)");
  auto* simulated = command.add_flag("--simulated", state.simulated,
                                     "Use the simulated board: the built firmware running in simavr");
  port->excludes(simulated);
  command.add_option("--firmware", state.firmware_elf, "Firmware ELF for --simulated (default: the build's)")
      ->needs(simulated);
  command.add_option("--watchdog-ms", state.watchdog_ms,
                     "Set the board's watchdog (silence before it turns all LEDs off), 100..3600000 ms")
      ->check(CLI::Range(100, 3600000));
}

}  // namespace

void RegisterDeviceCommands(CLI::App& app, int* exit_code) {
  CLI::App* devices =
      app.add_subcommand("devices", "List serial ports (Arduino boards recognised) and the cameras libgphoto2 finds");
  devices->callback([exit_code] { Guarded(exit_code, [] { return ListDevices(); }); });

  auto state = std::make_shared<LedCommandState>();
  CLI::App* led = app.add_subcommand(
      "led", "Drive the LED board by hand (bench testing): on <n>, off, status, version");
  led->require_subcommand(1);

  CLI::App* on = led->add_subcommand("on", "Light LED <n> (all others off)");
  on->add_option("n", state->led, "LED index, 0-based (LED n is on Arduino pin D(2+n))")
      ->required()
      ->check(CLI::Range(0, 31));
  on->add_option("--hold", state->hold_seconds,
                 "Keep it lit this many seconds (feeding the watchdog), then switch it off; 0 = leave it lit "
                 "and exit")
      ->check(CLI::Range(0.0, 86400.0))
      ->capture_default_str();
  AddConnectionOptions(*on, *state);
  on->callback([state, exit_code] { Guarded(exit_code, [&] { return LedOn(*state); }); });

  CLI::App* off = led->add_subcommand("off", "Switch every LED off");
  AddConnectionOptions(*off, *state);
  off->callback([state, exit_code] { Guarded(exit_code, [&] { return LedOff(*state); }); });

  CLI::App* status = led->add_subcommand("status", "Which LED the board has lit, its uptime and watchdog");
  AddConnectionOptions(*status, *state);
  status->callback([state, exit_code] { Guarded(exit_code, [&] { return LedStatus(*state); }); });

  CLI::App* version = led->add_subcommand("version", "The board's firmware name, version and LED count");
  AddConnectionOptions(*version, *state);
  version->callback([state, exit_code] { Guarded(exit_code, [&] { return LedVersion(*state); }); });
}

}  // namespace scanbench
