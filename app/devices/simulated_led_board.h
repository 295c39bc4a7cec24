// The LED board without hardware: the built firmware ELF runs on a simulated
// ATmega328P (simavr) in a thread of its own, its UART bridged to a
// pseudo-terminal that SerialLightController opens exactly like a real port,
// and its LED pins watched. Each board has its own pty, so any number run
// side by side (parallel tests) without sharing anything.
//
// Like a real Uno it restarts when the host opens the port (DTR), loses what
// it sends while nobody listens, and runs in real time, so the host's
// timeouts and the firmware's watchdog mean what they mean on the bench.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace scanbench {

// The ELF the build made (firmware/), or $SCANBENCH_FIRMWARE_ELF when set.
std::filesystem::path DefaultFirmwareElfPath();

struct SimulatedLedBoardOptions {
  std::filesystem::path firmware_elf;  // "" = DefaultFirmwareElfPath()
  std::string mcu = "atmega328p";      // simavr part name (the Uno's)
  uint32_t cpu_frequency_hz = 16000000;  // must match the ELF's F_CPU, [1000000, 32000000]
  double speed = 1.0;                  // simulated seconds per wall second, (0, 100]; 1 = real time
  bool reset_on_open = true;           // restart when the host opens the port, as DTR does on an Uno
  int first_led_pin = 2;               // Arduino digital pin of LED 0, LED n on pin first + n, [2, 19]
  int led_count = 10;                  // LEDs watched, [1, 18]; first_led_pin + led_count - 1 <= 19 (A5)

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

class SimulatedLedBoard {
 public:
  // Bit n set: LED n lit (its pin an output driven high).
  using LedMask = uint32_t;
  // Called on the simulation thread at every change of the lit LEDs, with
  // the simulated time of the change. Keep it short; it must not call back
  // into the board except for the const getters.
  using LedObserver = std::function<void(LedMask lit, double simulated_seconds)>;

  // Loads the ELF, creates the pty and starts the simulation. Throws
  // std::invalid_argument for bad options, std::runtime_error naming the
  // ELF or the system call that failed.
  explicit SimulatedLedBoard(SimulatedLedBoardOptions options = {});
  ~SimulatedLedBoard();  // Stop()
  SimulatedLedBoard(const SimulatedLedBoard&) = delete;
  SimulatedLedBoard& operator=(const SimulatedLedBoard&) = delete;

  // The pty to open ("/dev/pts/7"); gone after Stop().
  const std::string& port_path() const;
  int led_count() const;

  LedMask lit_leds() const;
  // Indices of the lit LEDs, ascending.
  std::vector<int> LitLedIndices() const;
  // The one LED lit, nullopt when none or several are: what a simulated
  // camera renders (SimulatedCamera's LitLedCallback).
  std::optional<int> SingleLitLed() const;
  // Waits until exactly `mask` is lit; false on timeout.
  bool WaitForLitLeds(LedMask mask, std::chrono::milliseconds timeout) const;
  // Most LEDs lit at the same instant since the last restart (the firmware
  // promises 1).
  int max_lit_at_once() const;
  void SetLedObserver(LedObserver observer);

  // The reset button: returns once the CPU has restarted (the banner follows
  // a few ms later). Throws std::runtime_error if the simulation is not running.
  void Reset();
  // Restarts so far, by Reset() and by the host opening the port.
  int reset_count() const;
  // Whether the host side of the pty is open.
  bool host_connected() const;
  double simulated_seconds() const;

  // Line noise: bytes that reach the board's UART as if sent by the host,
  // or the host as if sent by the board. Delivered at the line's pace.
  void InjectNoiseToBoard(std::string_view bytes);
  void InjectNoiseToHost(std::string_view bytes);

  // Stops the simulation and closes the pty (the host then reads a hang-up).
  void Stop();
  bool running() const;
  // Why the simulation stopped by itself ("firmware crashed at pc 0x..."),
  // "" while it runs or after Stop().
  std::string failure() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace scanbench
