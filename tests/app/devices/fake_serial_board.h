// A scripted stand-in for the LED board on a pseudo-terminal, for the
// controller's error paths that real firmware never takes (no banner, wrong
// firmware, silence, odd replies). Each instance has its own pty.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace scanbench::testing {

// A pty whose master side the test holds.
class TestPty {
 public:
  TestPty() {
    master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (master_ < 0 || ::grantpt(master_) != 0 || ::unlockpt(master_) != 0) throw std::runtime_error("pty");
    char name[128];
    if (::ptsname_r(master_, name, sizeof(name)) != 0) throw std::runtime_error("ptsname");
    path_ = name;
    // Raw, so that nothing is echoed or translated before the controller
    // configures the line.
    const int slave = ::open(name, O_RDWR | O_NOCTTY);
    termios settings{};
    ::tcgetattr(slave, &settings);
    ::cfmakeraw(&settings);
    ::tcsetattr(slave, TCSANOW, &settings);
    ::close(slave);
    ::fcntl(master_, F_SETFL, ::fcntl(master_, F_GETFL) | O_NONBLOCK);
  }
  ~TestPty() { CloseMaster(); }
  TestPty(const TestPty&) = delete;
  TestPty& operator=(const TestPty&) = delete;

  const std::string& path() const { return path_; }
  int master() const { return master_; }
  void CloseMaster() {
    if (master_ >= 0) ::close(master_);
    master_ = -1;
  }

 private:
  int master_ = -1;
  std::string path_;
};

class FakeSerialBoard {
 public:
  // Returns the bytes to send back for one received line ("" = stay silent).
  using Responder = std::function<std::string(const std::string& line)>;

  // `banner` (with its line end) is sent each time the host opens the port;
  // "" sends nothing, like a port with no board behind it.
  FakeSerialBoard(std::string banner, Responder responder)
      : banner_(std::move(banner)), responder_(std::move(responder)) {
    thread_ = std::thread([this] { Run(); });
  }
  ~FakeSerialBoard() { Stop(); }

  const std::string& path() const { return pty_.path(); }

  // Closes the master: the host sees a hang-up, as when a USB board is pulled.
  void Unplug() {
    Stop();
    pty_.CloseMaster();
  }

  // Every non-empty line received so far.
  std::vector<std::string> lines() const {
    std::lock_guard lock(mutex_);
    return lines_;
  }

 private:
  void Stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

  void Run() {
    bool connected = false;
    std::string partial;
    while (!stop_) {
      pollfd wait{pty_.master(), POLLIN, 0};
      ::poll(&wait, 1, 2);
      const bool now_connected = (wait.revents & POLLHUP) == 0;
      if (now_connected && !connected && !banner_.empty()) Send(banner_);
      connected = now_connected;
      if (!connected) continue;
      if ((wait.revents & POLLIN) == 0) continue;
      char buffer[256];
      const ssize_t count = ::read(pty_.master(), buffer, sizeof(buffer));
      if (count <= 0) continue;
      partial.append(buffer, static_cast<size_t>(count));
      for (size_t end; (end = partial.find_first_of("\r\n")) != std::string::npos;) {
        const std::string line = partial.substr(0, end);
        partial.erase(0, end + 1);
        if (line.empty()) continue;
        {
          std::lock_guard lock(mutex_);
          lines_.push_back(line);
        }
        const std::string reply = responder_(line);
        if (!reply.empty()) Send(reply);
      }
    }
  }

  void Send(const std::string& bytes) {
    size_t sent = 0;
    for (int tries = 0; sent < bytes.size() && tries < 1000; ++tries) {
      const ssize_t written = ::write(pty_.master(), bytes.data() + sent, bytes.size() - sent);
      if (written > 0) sent += static_cast<size_t>(written);
    }
  }

  TestPty pty_;
  std::string banner_;
  Responder responder_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  mutable std::mutex mutex_;
  std::vector<std::string> lines_;
};

inline const char* kGoodBanner = "READY scanbench-leds 1.0.0 leds=10\r\n";

// Answers like the firmware for the commands the controller sends.
inline std::string AnswerLikeFirmware(const std::string& line) {
  if (line.rfind("ON ", 0) == 0) return "OK " + line + "\r\n";
  if (line == "OFF") return "OK OFF\r\n";
  if (line == "STATUS") return "OK STATUS led=none uptime_ms=10 watchdog_ms=10000 watchdog_trips=0\r\n";
  if (line == "VERSION") return "OK VERSION scanbench-leds 1.0.0 leds=10\r\n";
  if (line.rfind("WATCHDOG ", 0) == 0) return "OK " + line + "\r\n";
  return "ERR 1 unknown command\r\n";
}

}  // namespace scanbench::testing
