#include "app/devices/device_error.h"

namespace scanbench {

const char* DeviceErrorKindName(DeviceErrorKind kind) {
  switch (kind) {
    case DeviceErrorKind::kNotFound:
      return "not found";
    case DeviceErrorKind::kBusy:
      return "busy";
    case DeviceErrorKind::kPermissionDenied:
      return "permission denied";
    case DeviceErrorKind::kNotSupported:
      return "not supported";
    case DeviceErrorKind::kIo:
      return "i/o error";
    case DeviceErrorKind::kDisconnected:
      return "disconnected";
    case DeviceErrorKind::kNoResponse:
      return "no response";
    case DeviceErrorKind::kWrongDevice:
      return "wrong device";
    case DeviceErrorKind::kTimeout:
      return "timeout";
    case DeviceErrorKind::kRejected:
      return "rejected";
    case DeviceErrorKind::kDeviceReset:
      return "device reset";
    case DeviceErrorKind::kProtocol:
      return "protocol error";
  }
  return "unknown";
}

}  // namespace scanbench
