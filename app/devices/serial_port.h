// A serial line through termios: raw 8N1, non-blocking, exclusively locked.
// Works on real ports (/dev/ttyACM0) and on pseudo-terminals, which the
// simulated board uses and libserialport cannot open.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>
#include <string_view>

#include "app/devices/device_error.h"

namespace scanbench {

class SerialPort {
 public:
  using Clock = std::chrono::steady_clock;

  // Opens `path` at `baud_rate` (one of the standard rates, 1200..4000000).
  // Locks it with flock() and TIOCEXCL so that a second scanbench, the
  // Arduino serial monitor or avrdude cannot talk over us. Throws
  // DeviceError: kNotFound, kPermissionDenied, kBusy, kNotSupported (not a
  // tty, or a rate it refuses), kIo.
  SerialPort(std::string path, int baud_rate);
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  const std::string& path() const { return path_; }

  // Writes every byte, waiting until `deadline` for room. Throws DeviceError
  // kTimeout, kDisconnected or kIo.
  void Write(std::string_view bytes, Clock::time_point deadline);

  // Appends whatever has arrived to `out`, waiting until `deadline` for the
  // first byte (a deadline in the past only collects what is there). Returns
  // the number of bytes appended, 0 on timeout. Throws DeviceError
  // kDisconnected (device gone, pty closed) or kIo.
  size_t Read(std::string& out, Clock::time_point deadline);

  // True for the rates termios knows (B1200 ... B4000000).
  static bool IsSupportedBaudRate(int baud_rate);

 private:
  [[noreturn]] void ThrowIo(const std::string& what, int error_number) const;

  std::string path_;
  int fd_ = -1;
};

}  // namespace scanbench
