// SerialPort on pseudo-terminals: what a real port does, and every way
// opening one can fail, each with a message naming the port.
#include "app/devices/serial_port.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "tests/app/devices/fake_serial_board.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

DeviceErrorKind KindOfOpening(const std::string& path, int baud_rate = 115200) {
  try {
    SerialPort port(path, baud_rate);
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.device(), path);
    EXPECT_THAT(error.what(), HasSubstr(path));
    return error.kind();
  }
  ADD_FAILURE() << "opening " << path << " succeeded";
  return DeviceErrorKind::kIo;
}

TEST(SerialPort, MissingPortIsNotFound) {
  EXPECT_EQ(KindOfOpening("/dev/ttyScanbenchNoSuchPort"), DeviceErrorKind::kNotFound);
}

TEST(SerialPort, RegularFileIsNotASerialPort) {
  const auto file = std::filesystem::temp_directory_path() / ("scanbench_not_a_tty_" + std::to_string(::getpid()));
  std::ofstream(file) << "x";
  EXPECT_EQ(KindOfOpening(file.string()), DeviceErrorKind::kNotSupported);
  std::filesystem::remove(file);
}

TEST(SerialPort, NonStandardBaudRateIsRefused) {
  testing::TestPty pty;
  EXPECT_EQ(KindOfOpening(pty.path(), 115201), DeviceErrorKind::kNotSupported);
  EXPECT_TRUE(SerialPort::IsSupportedBaudRate(115200));
  EXPECT_FALSE(SerialPort::IsSupportedBaudRate(0));
}

TEST(SerialPort, SecondOpenOfTheSamePortIsBusy) {
  testing::TestPty pty;
  SerialPort first(pty.path(), 115200);
  EXPECT_EQ(KindOfOpening(pty.path()), DeviceErrorKind::kBusy);
}

TEST(SerialPort, PortIsFreeAgainAfterClosing) {
  testing::TestPty pty;
  { SerialPort first(pty.path(), 115200); }
  EXPECT_NO_THROW(SerialPort second(pty.path(), 115200));
}

TEST(SerialPort, NoAccessIsPermissionDenied) {
  testing::TestPty pty;
  ASSERT_EQ(::chmod(pty.path().c_str(), 0), 0);
  if (::geteuid() != 0) {
    EXPECT_EQ(KindOfOpening(pty.path()), DeviceErrorKind::kPermissionDenied);
    return;
  }
  // Root opens anything: try as nobody in a child process.
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    if (::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(2);
    try {
      SerialPort port(pty.path(), 115200);
    } catch (const DeviceError& error) {
      ::_exit(error.kind() == DeviceErrorKind::kPermissionDenied &&
                      std::string(error.what()).find("dialout") != std::string::npos
                  ? 0
                  : 3);
    }
    ::_exit(4);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "2: could not drop privileges, 3: wrong error, 4: opened";
}

TEST(SerialPort, ReadTimesOutWhenNothingArrives) {
  testing::TestPty pty;
  SerialPort port(pty.path(), 115200);
  std::string received;
  const auto start = Clock::now();
  EXPECT_EQ(port.Read(received, start + std::chrono::milliseconds(50)), 0u);
  EXPECT_GE(Clock::now() - start, std::chrono::milliseconds(45));
  EXPECT_TRUE(received.empty());
}

TEST(SerialPort, BytesTravelBothWaysUnchanged) {
  testing::TestPty pty;
  SerialPort port(pty.path(), 115200);
  const std::string binary("ON 3\r\n\x00\xFF\x11\x13", 10);  // no translation, no XON/XOFF
  port.Write(binary, Clock::now() + std::chrono::seconds(1));
  std::string at_master(64, '\0');
  const auto deadline = Clock::now() + std::chrono::seconds(1);
  std::string collected;
  while (collected.size() < binary.size() && Clock::now() < deadline) {
    const ssize_t count = ::read(pty.master(), at_master.data(), at_master.size());
    if (count > 0) collected.append(at_master.data(), static_cast<size_t>(count));
  }
  EXPECT_EQ(collected, binary);

  ASSERT_EQ(::write(pty.master(), binary.data(), binary.size()), static_cast<ssize_t>(binary.size()));
  std::string received;
  while (received.size() < binary.size() && port.Read(received, Clock::now() + std::chrono::seconds(1)) > 0) {
  }
  EXPECT_EQ(received, binary);
}

TEST(SerialPort, HangUpIsDisconnected) {
  testing::TestPty pty;
  SerialPort port(pty.path(), 115200);
  pty.CloseMaster();
  std::string received;
  try {
    port.Read(received, Clock::now() + std::chrono::seconds(1));
    FAIL() << "read after hang-up succeeded";
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kDisconnected);
    EXPECT_THAT(error.what(), HasSubstr(pty.path()));
  }
}

}  // namespace
}  // namespace scanbench
