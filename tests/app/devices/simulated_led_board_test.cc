// The simulated board itself: options, loading, the pty bridge as a plain
// serial line (no controller), pin watching, reset and stop.
#include "app/devices/simulated_led_board.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <mutex>
#include <thread>
#include <vector>

#include "app/devices/serial_port.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// Reads from `port` until `count` lines have arrived or a second passed.
std::vector<std::string> ReadLines(SerialPort& port, size_t count) {
  std::vector<std::string> lines;
  std::string buffer;
  const auto deadline = Clock::now() + std::chrono::seconds(1);
  while (lines.size() < count && Clock::now() < deadline) {
    port.Read(buffer, deadline);
    for (size_t end; (end = buffer.find("\r\n")) != std::string::npos;) {
      lines.push_back(buffer.substr(0, end));
      buffer.erase(0, end + 2);
    }
  }
  return lines;
}

void Send(SerialPort& port, const std::string& bytes) { port.Write(bytes, Clock::now() + std::chrono::seconds(1)); }

TEST(SimulatedLedBoardOptions, CheckNamesFieldValueAndRule) {
  const auto message_for = [](const std::function<void(SimulatedLedBoardOptions&)>& change) -> std::string {
    SimulatedLedBoardOptions options;
    change(options);
    try {
      options.Check();
    } catch (const std::invalid_argument& error) {
      return error.what();
    }
    return "";
  };
  EXPECT_NO_THROW(SimulatedLedBoardOptions().Check());
  EXPECT_THAT(message_for([](auto& o) { o.speed = 0; }), HasSubstr("speed = 0"));
  EXPECT_THAT(message_for([](auto& o) { o.cpu_frequency_hz = 100; }), HasSubstr("cpu_frequency_hz = 100"));
  EXPECT_THAT(message_for([](auto& o) { o.first_led_pin = 1; }), HasSubstr("first_led_pin = 1: must be in [2, 19]"));
  EXPECT_THAT(message_for([](auto& o) { o.led_count = 19; }), HasSubstr("led_count = 19"));
  EXPECT_THAT(message_for([](auto& o) { o.mcu.clear(); }), HasSubstr("mcu"));
}

TEST(SimulatedLedBoard, MissingElfIsNamedWithTheFix) {
  SimulatedLedBoardOptions options;
  options.firmware_elf = "/nonexistent/scanbench_leds.elf";
  try {
    SimulatedLedBoard board(options);
    FAIL() << "started without firmware";
  } catch (const std::runtime_error& error) {
    EXPECT_THAT(error.what(), HasSubstr("/nonexistent/scanbench_leds.elf"));
    EXPECT_THAT(error.what(), HasSubstr("scanbench_leds"));
  }
}

TEST(SimulatedLedBoard, UnknownPartIsRefused) {
  SimulatedLedBoardOptions options;
  options.mcu = "atmega9999";
  EXPECT_THROW(SimulatedLedBoard board(options), std::runtime_error);
}

TEST(SimulatedLedBoard, DefaultElfIsTheBuiltFirmware) {
  EXPECT_TRUE(std::filesystem::is_regular_file(DefaultFirmwareElfPath())) << DefaultFirmwareElfPath();
}

TEST(SimulatedLedBoard, SpeaksTheProtocolOnItsPtyLikeARealPort) {
  SimulatedLedBoard board;
  EXPECT_THAT(board.port_path(), HasSubstr("/dev/pts/"));
  EXPECT_EQ(board.reset_count(), 0);
  SerialPort port(board.port_path(), 115200);
  // Opening the port restarted the board, which greets the host.
  EXPECT_THAT(ReadLines(port, 1), ::testing::ElementsAre("READY scanbench-leds 1.0.0 leds=10"));
  EXPECT_EQ(board.reset_count(), 1);
  EXPECT_TRUE(board.host_connected());

  // LF, CR LF and CR line ends, lower case, an overlong line, noise.
  Send(port, "ON 3\n");
  Send(port, "on 4\r\n");
  Send(port, "  STATUS \r");
  Send(port, std::string(50, 'A') + "\n");
  Send(port, std::string("\x01\xFF", 2) + "OFF\n");
  Send(port, "OFF\n");
  const auto lines = ReadLines(port, 6);
  ASSERT_EQ(lines.size(), 6u);
  EXPECT_EQ(lines[0], "OK ON 3");
  EXPECT_EQ(lines[1], "OK ON 4");
  EXPECT_THAT(lines[2], ::testing::StartsWith("OK STATUS led=4 uptime_ms="));
  EXPECT_EQ(lines[3], "ERR 6 line longer than 32 characters");
  EXPECT_EQ(lines[4], "ERR 7 non-printable character in line");
  EXPECT_EQ(lines[5], "OK OFF");
  EXPECT_EQ(board.lit_leds(), 0u);
  EXPECT_EQ(board.max_lit_at_once(), 1);
}

TEST(SimulatedLedBoard, ObserverSeesEveryChangeWithItsTime) {
  SimulatedLedBoard board;
  std::mutex mutex;
  std::vector<std::pair<SimulatedLedBoard::LedMask, double>> changes;
  board.SetLedObserver([&](SimulatedLedBoard::LedMask lit, double seconds) {
    std::lock_guard lock(mutex);
    changes.emplace_back(lit, seconds);
  });
  SerialPort port(board.port_path(), 115200);
  ReadLines(port, 1);
  Send(port, "ON 0\nON 9\nOFF\n");
  ReadLines(port, 3);
  std::lock_guard lock(mutex);
  ASSERT_EQ(changes.size(), 4u);  // on 0, off 0, on 9, off 9
  EXPECT_EQ(changes[0].first, 1u << 0);
  EXPECT_EQ(changes[1].first, 0u);
  EXPECT_EQ(changes[2].first, 1u << 9);
  EXPECT_EQ(changes[3].first, 0u);
  for (size_t i = 1; i < changes.size(); ++i) EXPECT_GE(changes[i].second, changes[i - 1].second);
  EXPECT_GT(changes[0].second, 0.0);
}

TEST(SimulatedLedBoard, ResetButtonTurnsLedsOffAndGreetsAgain) {
  SimulatedLedBoard board;
  SerialPort port(board.port_path(), 115200);
  ReadLines(port, 1);
  Send(port, "ON 5\n");
  ReadLines(port, 1);
  EXPECT_EQ(board.LitLedIndices(), std::vector<int>{5});
  EXPECT_EQ(board.SingleLitLed(), std::optional<int>(5));
  board.Reset();
  EXPECT_EQ(board.lit_leds(), 0u);
  EXPECT_EQ(board.SingleLitLed(), std::nullopt);
  EXPECT_EQ(board.reset_count(), 2);
  EXPECT_THAT(ReadLines(port, 1), ::testing::ElementsAre("READY scanbench-leds 1.0.0 leds=10"));
}

TEST(SimulatedLedBoard, RunsInRealTime) {
  SimulatedLedBoard board;
  const double start = board.simulated_seconds();
  const auto wall_start = Clock::now();
  std::this_thread::sleep_for(milliseconds(300));
  const double simulated = board.simulated_seconds() - start;
  const double wall = std::chrono::duration<double>(Clock::now() - wall_start).count();
  EXPECT_NEAR(simulated, wall, 0.1);
}

TEST(SimulatedLedBoard, WhatItSaysWhileNobodyListensIsLost) {
  SimulatedLedBoardOptions options;
  options.reset_on_open = false;
  SimulatedLedBoard board(options);
  std::this_thread::sleep_for(milliseconds(50));  // the power-on banner goes out unheard
  SerialPort port(board.port_path(), 115200);
  std::string received;
  EXPECT_EQ(port.Read(received, Clock::now() + milliseconds(100)), 0u);
  EXPECT_EQ(board.reset_count(), 0);
  Send(port, "VERSION\n");
  EXPECT_THAT(ReadLines(port, 1), ::testing::ElementsAre("OK VERSION scanbench-leds 1.0.0 leds=10"));
}

TEST(SimulatedLedBoard, NoiseReachesEitherSide) {
  SimulatedLedBoard board;
  SerialPort port(board.port_path(), 115200);
  ReadLines(port, 1);
  board.InjectNoiseToHost("noise\r\n");
  EXPECT_THAT(ReadLines(port, 1), ::testing::ElementsAre("noise"));
  board.InjectNoiseToBoard("XYZ\n");
  EXPECT_THAT(ReadLines(port, 1), ::testing::ElementsAre(::testing::StartsWith("ERR 1 ")));
}

TEST(SimulatedLedBoard, StopHangsUpThePort) {
  SimulatedLedBoard board;
  SerialPort port(board.port_path(), 115200);
  ReadLines(port, 1);
  board.Stop();
  EXPECT_FALSE(board.running());
  EXPECT_EQ(board.failure(), "");
  std::string received;
  try {
    port.Read(received, Clock::now() + std::chrono::seconds(1));
    FAIL() << "read after stop succeeded";
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), DeviceErrorKind::kDisconnected);
  }
  EXPECT_THROW(board.Reset(), std::runtime_error);
}

TEST(SimulatedLedBoard, ManyBoardsRunSideBySide) {
  std::vector<std::unique_ptr<SimulatedLedBoard>> boards;
  std::vector<std::unique_ptr<SerialPort>> ports;
  for (int i = 0; i < 4; ++i) {
    boards.push_back(std::make_unique<SimulatedLedBoard>());
    ports.push_back(std::make_unique<SerialPort>(boards.back()->port_path(), 115200));
  }
  for (int i = 0; i < 4; ++i) {
    ReadLines(*ports[i], 1);
    Send(*ports[i], "ON " + std::to_string(i * 2) + "\n");
  }
  for (int i = 0; i < 4; ++i) {
    ReadLines(*ports[i], 1);
    EXPECT_EQ(boards[i]->LitLedIndices(), std::vector<int>{i * 2}) << "board " << i;
  }
}

}  // namespace
}  // namespace scanbench
