// The one exception type of app/devices: what went wrong (kind, for code
// that recovers) and a message for the operator that names the device or
// port, the value at fault and what to do.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>

namespace scanbench {

enum class DeviceErrorKind {
  kNotFound,          // port or file does not exist (board unplugged?)
  kBusy,              // another program holds the port
  kPermissionDenied,  // no access (not in the dialout group?)
  kNotSupported,      // not a serial port, or a setting it cannot take
  kIo,                // any other system error
  kDisconnected,      // the device went away mid-session
  kNoResponse,        // nothing that speaks our protocol answered on connect
  kWrongDevice,       // something answered, but not the expected firmware
  kTimeout,           // no reply to a command in time
  kRejected,          // the device answered ERR
  kDeviceReset,       // the device restarted mid-session (its state is lost)
  kProtocol,          // a reply we cannot make sense of
};

const char* DeviceErrorKindName(DeviceErrorKind kind);

class DeviceError : public std::runtime_error {
 public:
  DeviceError(DeviceErrorKind kind, std::string device, const std::string& message)
      : std::runtime_error(message), kind_(kind), device_(std::move(device)) {}

  DeviceErrorKind kind() const { return kind_; }
  // The port or device path the error is about ("/dev/ttyACM0").
  const std::string& device() const { return device_; }

 private:
  DeviceErrorKind kind_;
  std::string device_;
};

}  // namespace scanbench
