#include "app/devices/serial_port.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

namespace scanbench {

namespace {

struct BaudEntry {
  int rate;
  speed_t code;
};

constexpr BaudEntry kBaudRates[] = {
    {1200, B1200},       {2400, B2400},       {4800, B4800},       {9600, B9600},       {19200, B19200},
    {38400, B38400},     {57600, B57600},     {115200, B115200},   {230400, B230400},   {460800, B460800},
    {500000, B500000},   {576000, B576000},   {921600, B921600},   {1000000, B1000000}, {1152000, B1152000},
    {1500000, B1500000}, {2000000, B2000000}, {2500000, B2500000}, {3000000, B3000000}, {3500000, B3500000},
    {4000000, B4000000},
};

int MillisecondsUntil(SerialPort::Clock::time_point deadline) {
  const auto remaining = std::chrono::ceil<std::chrono::milliseconds>(deadline - SerialPort::Clock::now());
  return static_cast<int>(std::clamp<int64_t>(remaining.count(), 0, 1 << 30));
}

}  // namespace

bool SerialPort::IsSupportedBaudRate(int baud_rate) {
  return std::any_of(std::begin(kBaudRates), std::end(kBaudRates),
                     [baud_rate](const BaudEntry& entry) { return entry.rate == baud_rate; });
}

SerialPort::SerialPort(std::string path, int baud_rate) : path_(std::move(path)) {
  const auto baud = std::find_if(std::begin(kBaudRates), std::end(kBaudRates),
                                 [baud_rate](const BaudEntry& entry) { return entry.rate == baud_rate; });
  if (baud == std::end(kBaudRates)) {
    throw DeviceError(DeviceErrorKind::kNotSupported, path_,
                      "serial port " + path_ + ": baud rate " + std::to_string(baud_rate) +
                          " is not a standard termios rate (1200, 9600, 115200, ... 4000000)");
  }

  // Non-blocking so that a port whose modem lines never settle cannot hang
  // open(); no controlling terminal, or Ctrl-C on the board would be ours.
  fd_ = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int error = errno;
    switch (error) {
      case ENOENT:
      case ENODEV:
      case ENXIO:
        throw DeviceError(DeviceErrorKind::kNotFound, path_,
                          "serial port " + path_ + " does not exist (" + std::strerror(error) +
                              "): is the board plugged in? `scanbench devices` lists the ports");
      case EACCES:
      case EPERM:
        throw DeviceError(DeviceErrorKind::kPermissionDenied, path_,
                          "permission denied opening serial port " + path_ +
                              ": add your user to the group owning it (usually dialout: "
                              "sudo usermod -aG dialout $USER) and log in again");
      case EBUSY:
        throw DeviceError(DeviceErrorKind::kBusy, path_,
                          "serial port " + path_ +
                              " is busy: another program has it open exclusively (Arduino serial monitor, "
                              "avrdude, another scanbench?); close it and retry");
      default:
        ThrowIo("cannot open", error);
    }
  }

  try {
    termios settings{};
    if (::tcgetattr(fd_, &settings) != 0) {
      const int error = errno;
      if (error == ENOTTY || error == EINVAL) {
        throw DeviceError(DeviceErrorKind::kNotSupported, path_, path_ + " is not a serial port (" +
                                                                     std::strerror(error) + ")");
      }
      ThrowIo("cannot read the settings of", error);
    }
    // flock first: unlike TIOCEXCL it also holds against root and against
    // programs that open the port without O_EXCL semantics.
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      const int error = errno;
      if (error == EWOULDBLOCK) {
        throw DeviceError(DeviceErrorKind::kBusy, path_,
                          "serial port " + path_ +
                              " is locked by another program (another scanbench, avrdude?); close it and retry");
      }
      ThrowIo("cannot lock", error);
    }
    if (::ioctl(fd_, TIOCEXCL) != 0) ThrowIo("cannot claim exclusive use of", errno);

    // Raw bytes, 8N1, no flow control, no echo, reads that never block.
    ::cfmakeraw(&settings);
    settings.c_cflag |= CLOCAL | CREAD;
    settings.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | PARENB | CRTSCTS | CSIZE);
    settings.c_cflag |= CS8;
    settings.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
    settings.c_cc[VMIN] = 0;
    settings.c_cc[VTIME] = 0;
    if (::cfsetispeed(&settings, baud->code) != 0 || ::cfsetospeed(&settings, baud->code) != 0) {
      throw DeviceError(DeviceErrorKind::kNotSupported, path_,
                        "serial port " + path_ + " refuses baud rate " + std::to_string(baud_rate));
    }
    if (::tcsetattr(fd_, TCSANOW, &settings) != 0) ThrowIo("cannot configure", errno);
  } catch (...) {
    ::close(fd_);
    fd_ = -1;
    throw;
  }
}

SerialPort::~SerialPort() {
  if (fd_ >= 0) ::close(fd_);  // also releases flock and TIOCEXCL
}

void SerialPort::ThrowIo(const std::string& what, int error_number) const {
  throw DeviceError(DeviceErrorKind::kIo, path_,
                    what + " serial port " + path_ + ": " + std::strerror(error_number));
}

void SerialPort::Write(std::string_view bytes, Clock::time_point deadline) {
  while (!bytes.empty()) {
    const ssize_t written = ::write(fd_, bytes.data(), bytes.size());
    if (written > 0) {
      bytes.remove_prefix(static_cast<size_t>(written));
      continue;
    }
    const int error = errno;
    if (written < 0 && error == EINTR) continue;
    if (written < 0 && error != EAGAIN) {
      if (error == EIO || error == ENXIO || error == ENODEV) {
        throw DeviceError(DeviceErrorKind::kDisconnected, path_,
                          "serial port " + path_ + " disconnected while writing (" + std::strerror(error) +
                              "): board unplugged or reset by USB?");
      }
      ThrowIo("cannot write to", error);
    }
    pollfd wait{fd_, POLLOUT, 0};
    const int ready = ::poll(&wait, 1, MillisecondsUntil(deadline));
    if (ready == 0) {
      throw DeviceError(DeviceErrorKind::kTimeout, path_,
                        "serial port " + path_ + " accepted no data in time (output stalled)");
    }
    if (ready < 0 && errno != EINTR) ThrowIo("cannot wait for", errno);
  }
}

size_t SerialPort::Read(std::string& out, Clock::time_point deadline) {
  while (true) {
    pollfd wait{fd_, POLLIN, 0};
    const int ready = ::poll(&wait, 1, MillisecondsUntil(deadline));
    if (ready < 0) {
      if (errno == EINTR) continue;
      ThrowIo("cannot wait for", errno);
    }
    if (ready == 0) return 0;
    char buffer[512];
    const ssize_t count = ::read(fd_, buffer, sizeof(buffer));
    if (count > 0) {
      out.append(buffer, static_cast<size_t>(count));
      return static_cast<size_t>(count);
    }
    const int error = errno;
    if (count < 0 && (error == EINTR || error == EAGAIN)) continue;
    // A hang-up with nothing to read: USB unplugged, or the pty's other side closed.
    if (count == 0 || error == EIO || error == ENXIO || error == ENODEV) {
      throw DeviceError(DeviceErrorKind::kDisconnected, path_,
                        "serial port " + path_ + " disconnected (" +
                            (count == 0 ? std::string("hang-up") : std::string(std::strerror(error))) +
                            "): board unplugged?");
    }
    ThrowIo("cannot read from", error);
  }
}

}  // namespace scanbench
