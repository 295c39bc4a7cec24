// What the capture sequencer needs from the rig's lights: one LED at a time,
// all off, and the board's own account of what is lit (checked before every
// exposure). Implemented by SerialLightController (the Arduino board, real or
// simulated in simavr); tests may implement it in memory.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "app/devices/device_error.h"

namespace scanbench {

// What the firmware reports about itself (banner or VERSION).
struct LightFirmwareInfo {
  std::string name;     // "scanbench-leds"
  std::string version;  // "1.0.0"
  int led_count = 0;    // LEDs the board drives, indices 0..led_count-1
};

// What the board says is lit right now (STATUS).
struct LightStatus {
  std::optional<int> lit_led;   // index of the one lit LED; nullopt = all off
  uint32_t uptime_ms = 0;       // since the board last started
  uint32_t watchdog_ms = 0;     // silence after which the board turns all LEDs off
  uint32_t watchdog_trips = 0;  // times the watchdog did so since the board started
};

// Every call either succeeds or throws DeviceError naming the port and the
// problem; its kind() tells a caller what happened:
//   kDeviceReset  the board restarted (LEDs off, settings lost); the link is
//                 usable again at once, the step should be repeated;
//   kDisconnected the port is gone; Reconnect() once it is back;
//   kTimeout, kRejected, kProtocol  the command failed, the link resyncs.
// Not thread-safe: one owner at a time.
class LightController {
 public:
  virtual ~LightController() = default;

  // "LED board on /dev/ttyACM0", for messages.
  virtual std::string description() const = 0;
  virtual int led_count() const = 0;

  // LED `led` on, every other LED off. Throws std::out_of_range when `led`
  // is not in [0, led_count()).
  virtual void LightOnly(int led) = 0;
  virtual void AllOff() = 0;
  virtual LightStatus Status() = 0;
  virtual LightFirmwareInfo Version() = 0;
  // Silence after which the board turns all LEDs off by itself, so that a
  // crashed host never leaves one burning; lost when the board restarts
  // (implementations re-apply it). Throws std::out_of_range outside the
  // board's range.
  virtual void SetWatchdog(uint32_t silence_ms) = 0;
  // Drops the link and opens it again (the board restarts: all LEDs off).
  virtual void Reconnect() = 0;
};

}  // namespace scanbench
