// The LED board over its serial line (firmware/README.md has the protocol):
// a real Arduino Uno on /dev/ttyACM0, or the simulated one on its pty.
//
// Opening the port resets a real Uno (DTR), so the constructor waits for the
// READY banner before it sends anything. Every command gets exactly one
// reply and every command is idempotent, so a reply that shows line noise
// (ERR 1/6/7, garbage, silence) is answered by draining the line and sending
// the command again. A READY banner in the middle of a session means the
// board restarted: DeviceError kDeviceReset, after the link has been
// resynchronised, all LEDs switched off and the watchdog setting re-applied.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "app/devices/light_controller.h"

namespace scanbench {

class SerialPort;

struct SerialLightControllerOptions {
  int baud_rate = 115200;            // bits/s; the firmware's rate, a standard termios rate
  int banner_timeout_ms = 3000;      // wait for READY after opening (an Uno's bootloader takes ~1 s), [1, 60000]
  int reply_timeout_ms = 500;        // per command; the board answers within a few ms, [1, 60000]
  int attempts = 2;                  // sends per command when the line looks corrupted or silent, [1, 10]
  int resync_quiet_ms = 30;          // line silence that ends draining during a resync, [1, 1000]
  bool probe_without_banner = true;  // no banner (auto-reset disabled): ask VERSION before giving up
  uint32_t watchdog_ms = 0;          // 0 = firmware default; else set on connect and after a board reset, [100, 3600000]
  bool all_off_on_close = true;      // the destructor turns every LED off; false leaves them (scanbench led on)
  int reconnect_pause_ms = 100;      // Reconnect(): port closed this long, so DTR's reset pulse recharges, [0, 5000]

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

class SerialLightController : public LightController {
 public:
  // Opens and locks `port`, waits for the banner (or probes), checks that
  // the firmware is scanbench-leds 1.x and applies the watchdog option.
  // Throws std::invalid_argument for bad options, DeviceError otherwise.
  explicit SerialLightController(std::string port, SerialLightControllerOptions options = {});
  ~SerialLightController() override;

  std::string description() const override;
  int led_count() const override { return firmware_.led_count; }
  void LightOnly(int led) override;
  void AllOff() override;
  LightStatus Status() override;
  LightFirmwareInfo Version() override;
  void SetWatchdog(uint32_t silence_ms) override;
  void Reconnect() override;

  const std::string& port() const { return port_path_; }
  // From the banner (or VERSION) of the last connect or board restart.
  const LightFirmwareInfo& firmware() const { return firmware_; }
  // Board restarts noticed since construction (banner mid-session, uptime going back).
  int board_resets_seen() const { return board_resets_seen_; }

 private:
  struct Reply;
  static Reply ClassifyLine(std::string line);

  void Connect();
  // Sends `command`, returns the text after "OK <WORD> " of its reply.
  std::string Transact(const std::string& command);
  std::optional<std::string> NextLine(std::chrono::steady_clock::time_point deadline);
  // Drains the line until it is quiet; a banner found there means a restart.
  void Resync(const std::string& context);
  // Reads what has arrived without waiting; a banner means a restart.
  void CheckForUnsolicitedLines(const std::string& context);
  [[noreturn]] void HandleBoardReset(const Reply& banner, const std::string& context);
  // Switches all off, re-applies the watchdog and throws kDeviceReset.
  [[noreturn]] void ThrowBoardReset(const std::string& what_happened);
  void ApplyWatchdog();
  void RequirePort() const;

  std::string port_path_;
  SerialLightControllerOptions options_;
  std::unique_ptr<SerialPort> port_;
  std::string received_;  // bytes read but not yet split into lines
  LightFirmwareInfo firmware_;
  bool resync_needed_ = false;
  int board_resets_seen_ = 0;
  std::optional<uint32_t> last_uptime_ms_;
  std::chrono::steady_clock::time_point last_uptime_at_;
};

}  // namespace scanbench
