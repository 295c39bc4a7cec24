// SerialLightController against a scripted board on a pty: connecting,
// and every failure that real firmware does not produce on demand.
#include "app/devices/serial_light_controller.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <functional>

#include "tests/app/devices/fake_serial_board.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;
using testing::AnswerLikeFirmware;
using testing::FakeSerialBoard;
using testing::kGoodBanner;
using Clock = std::chrono::steady_clock;

SerialLightControllerOptions FastOptions() {
  SerialLightControllerOptions options;
  options.banner_timeout_ms = 300;
  options.reply_timeout_ms = 150;
  options.resync_quiet_ms = 10;
  return options;
}

// Runs `action`, expects DeviceError of `kind` naming `port`; returns its message.
std::string ExpectDeviceError(DeviceErrorKind kind, const std::string& port, const std::function<void()>& action) {
  try {
    action();
  } catch (const DeviceError& error) {
    EXPECT_EQ(error.kind(), kind) << DeviceErrorKindName(error.kind()) << ": " << error.what();
    EXPECT_EQ(error.device(), port);
    EXPECT_THAT(error.what(), HasSubstr(port));
    return error.what();
  }
  ADD_FAILURE() << "no DeviceError (" << DeviceErrorKindName(kind) << ")";
  return "";
}

TEST(SerialLightControllerOptions, CheckNamesFieldValueAndRule) {
  const auto message_for = [](const std::function<void(SerialLightControllerOptions&)>& change) -> std::string {
    SerialLightControllerOptions options;
    change(options);
    try {
      options.Check();
    } catch (const std::invalid_argument& error) {
      return error.what();
    }
    return "";
  };
  EXPECT_NO_THROW(SerialLightControllerOptions().Check());
  EXPECT_THAT(message_for([](auto& o) { o.baud_rate = 12345; }), HasSubstr("baud_rate = 12345"));
  EXPECT_THAT(message_for([](auto& o) { o.banner_timeout_ms = 0; }), HasSubstr("banner_timeout_ms = 0: must be in [1, 60000]"));
  EXPECT_THAT(message_for([](auto& o) { o.reply_timeout_ms = 70000; }), HasSubstr("reply_timeout_ms = 70000"));
  EXPECT_THAT(message_for([](auto& o) { o.attempts = 0; }), HasSubstr("attempts = 0"));
  EXPECT_THAT(message_for([](auto& o) { o.resync_quiet_ms = 5000; }), HasSubstr("resync_quiet_ms = 5000"));
  EXPECT_THAT(message_for([](auto& o) { o.watchdog_ms = 50; }), HasSubstr("watchdog_ms = 50: must be in [100, 3600000]"));
}

TEST(SerialLightController, ConnectsAfterTheBannerAndReadsIt) {
  FakeSerialBoard board(kGoodBanner, AnswerLikeFirmware);
  SerialLightController controller(board.path(), FastOptions());
  EXPECT_EQ(controller.firmware().name, "scanbench-leds");
  EXPECT_EQ(controller.firmware().version, "1.0.0");
  EXPECT_EQ(controller.led_count(), 10);
  EXPECT_EQ(controller.description(), "LED board on " + board.path());
  EXPECT_TRUE(board.lines().empty());  // nothing sent before a command
}

TEST(SerialLightController, MissingPortIsNotFound) {
  ExpectDeviceError(DeviceErrorKind::kNotFound, "/dev/ttyScanbenchGone",
                    [] { SerialLightController controller("/dev/ttyScanbenchGone", FastOptions()); });
}

TEST(SerialLightController, PortInUseIsBusy) {
  FakeSerialBoard board(kGoodBanner, AnswerLikeFirmware);
  SerialLightController first(board.path(), FastOptions());
  ExpectDeviceError(DeviceErrorKind::kBusy, board.path(),
                    [&] { SerialLightController second(board.path(), FastOptions()); });
}

TEST(SerialLightController, SilentPortIsNoResponseQuickly) {
  FakeSerialBoard nobody("", [](const std::string&) { return std::string(); });
  const auto start = Clock::now();
  const std::string message = ExpectDeviceError(DeviceErrorKind::kNoResponse, nobody.path(), [&] {
    SerialLightController controller(nobody.path(), FastOptions());
  });
  EXPECT_THAT(message, HasSubstr("no READY banner"));
  EXPECT_THAT(message, HasSubstr("300 ms"));
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(2));
  // It asked VERSION before giving up.
  EXPECT_THAT(nobody.lines(), ::testing::Contains("VERSION"));
}

TEST(SerialLightController, BoardWithoutAutoResetIsFoundByAskingVersion) {
  FakeSerialBoard board("", AnswerLikeFirmware);
  SerialLightController controller(board.path(), FastOptions());
  EXPECT_EQ(controller.firmware().version, "1.0.0");
}

TEST(SerialLightController, NoProbeMeansNoResponse) {
  FakeSerialBoard board("", AnswerLikeFirmware);
  auto options = FastOptions();
  options.probe_without_banner = false;
  ExpectDeviceError(DeviceErrorKind::kNoResponse, board.path(),
                    [&] { SerialLightController controller(board.path(), options); });
  EXPECT_TRUE(board.lines().empty());
}

TEST(SerialLightController, NoiseBeforeTheBannerIsSkipped) {
  FakeSerialBoard board(std::string("\xF0\x00\xFFREADY scan", 14) + "junk\r\n" + kGoodBanner, AnswerLikeFirmware);
  SerialLightController controller(board.path(), FastOptions());
  EXPECT_EQ(controller.led_count(), 10);
}

TEST(SerialLightController, OtherFirmwareIsWrongDevice) {
  FakeSerialBoard board("READY grbl-shield 0.9 leds=4\r\n", AnswerLikeFirmware);
  const std::string message = ExpectDeviceError(DeviceErrorKind::kWrongDevice, board.path(), [&] {
    SerialLightController controller(board.path(), FastOptions());
  });
  EXPECT_THAT(message, HasSubstr("grbl-shield 0.9"));
}

TEST(SerialLightController, NewerProtocolIsWrongDevice) {
  FakeSerialBoard board("READY scanbench-leds 2.0.0 leds=10\r\n", AnswerLikeFirmware);
  ExpectDeviceError(DeviceErrorKind::kWrongDevice, board.path(),
                    [&] { SerialLightController controller(board.path(), FastOptions()); });
}

TEST(SerialLightController, SendsOneLinePerCommand) {
  FakeSerialBoard board(kGoodBanner, AnswerLikeFirmware);
  {
    SerialLightController controller(board.path(), FastOptions());
    controller.LightOnly(3);
    controller.AllOff();
    const LightStatus status = controller.Status();
    EXPECT_FALSE(status.lit_led.has_value());
    EXPECT_EQ(status.uptime_ms, 10u);
    EXPECT_EQ(status.watchdog_ms, 10000u);
    EXPECT_EQ(controller.Version().led_count, 10);
    controller.SetWatchdog(2500);
  }
  EXPECT_THAT(board.lines(),
              ::testing::ElementsAre("ON 3", "OFF", "STATUS", "VERSION", "WATCHDOG 2500", "OFF"));  // OFF on close
}

TEST(SerialLightController, LeavesLedsAloneOnCloseWhenAsked) {
  FakeSerialBoard board(kGoodBanner, AnswerLikeFirmware);
  {
    auto options = FastOptions();
    options.all_off_on_close = false;
    SerialLightController controller(board.path(), options);
    controller.LightOnly(1);
  }
  EXPECT_THAT(board.lines(), ::testing::ElementsAre("ON 1"));
}

TEST(SerialLightController, WatchdogOptionIsAppliedOnConnect) {
  FakeSerialBoard board(kGoodBanner, AnswerLikeFirmware);
  auto options = FastOptions();
  options.watchdog_ms = 750;
  SerialLightController controller(board.path(), options);
  EXPECT_THAT(board.lines(), ::testing::ElementsAre("WATCHDOG 750"));
}

TEST(SerialLightController, BadArgumentsAreRefusedBeforeSending) {
  FakeSerialBoard board(kGoodBanner, AnswerLikeFirmware);
  SerialLightController controller(board.path(), FastOptions());
  EXPECT_THROW(controller.LightOnly(10), std::out_of_range);
  EXPECT_THROW(controller.LightOnly(-1), std::out_of_range);
  EXPECT_THROW(controller.SetWatchdog(99), std::out_of_range);
  EXPECT_THROW(controller.SetWatchdog(3600001), std::out_of_range);
  EXPECT_TRUE(board.lines().empty());
}

TEST(SerialLightController, SilenceIsTimeoutAfterEveryAttempt) {
  FakeSerialBoard board(kGoodBanner, [](const std::string& line) {
    return line == "STATUS" ? std::string() : AnswerLikeFirmware(line);
  });
  SerialLightController controller(board.path(), FastOptions());
  const auto start = Clock::now();
  const std::string message =
      ExpectDeviceError(DeviceErrorKind::kTimeout, board.path(), [&] { controller.Status(); });
  EXPECT_THAT(message, HasSubstr("'STATUS'"));
  EXPECT_THAT(message, HasSubstr("2 attempt(s)"));
  EXPECT_GE(Clock::now() - start, std::chrono::milliseconds(2 * 150));
  const auto lines = board.lines();
  EXPECT_EQ(std::count(lines.begin(), lines.end(), "STATUS"), 2);
  // The link still works for the next command.
  EXPECT_NO_THROW(controller.AllOff());
}

TEST(SerialLightController, ErrReplyIsRejectedWithTheBoardsText) {
  FakeSerialBoard board(kGoodBanner, [](const std::string& line) {
    return line == "ON 7" ? std::string("ERR 4 led out of range 0..5\r\n") : AnswerLikeFirmware(line);
  });
  SerialLightController controller(board.path(), FastOptions());
  const std::string message =
      ExpectDeviceError(DeviceErrorKind::kRejected, board.path(), [&] { controller.LightOnly(7); });
  EXPECT_THAT(message, HasSubstr("'ON 7'"));
  EXPECT_THAT(message, HasSubstr("ERR 4 led out of range 0..5"));
}

TEST(SerialLightController, CorruptedLineIsResentOnce) {
  std::atomic<int> ons{0};
  FakeSerialBoard board(kGoodBanner, [&](const std::string& line) {
    if (line == "ON 3" && ons++ == 0) return std::string("ERR 7 non-printable character in line\r\n");
    return AnswerLikeFirmware(line);
  });
  SerialLightController controller(board.path(), FastOptions());
  controller.LightOnly(3);
  EXPECT_EQ(ons.load(), 2);
}

TEST(SerialLightController, PersistentCorruptionIsProtocolError) {
  FakeSerialBoard board(kGoodBanner, [](const std::string& line) {
    return line == "OFF" ? std::string("ERR 1 unknown command\r\n") : AnswerLikeFirmware(line);
  });
  auto options = FastOptions();
  options.all_off_on_close = false;
  SerialLightController controller(board.path(), options);
  const std::string message = ExpectDeviceError(DeviceErrorKind::kProtocol, board.path(), [&] { controller.AllOff(); });
  EXPECT_THAT(message, HasSubstr("line noise"));
}

TEST(SerialLightController, GarbageAndStaleRepliesAreSkipped) {
  FakeSerialBoard board(kGoodBanner, [](const std::string& line) {
    if (line == "STATUS") {
      return std::string("\xFF\xFE\x01zz\r\nOK ON 1\r\nbla\r\n") +
             "OK STATUS led=2 uptime_ms=99 watchdog_ms=500 watchdog_trips=3\r\n";
    }
    return AnswerLikeFirmware(line);
  });
  SerialLightController controller(board.path(), FastOptions());
  const LightStatus status = controller.Status();
  ASSERT_TRUE(status.lit_led.has_value());
  EXPECT_EQ(*status.lit_led, 2);
  EXPECT_EQ(status.uptime_ms, 99u);
  EXPECT_EQ(status.watchdog_ms, 500u);
  EXPECT_EQ(status.watchdog_trips, 3u);
}

TEST(SerialLightController, BannerMidSessionIsDeviceResetThenRecovers) {
  std::atomic<bool> restart_next{false};
  FakeSerialBoard board(kGoodBanner, [&](const std::string& line) {
    if (line == "ON 4" && restart_next.exchange(false)) return std::string(kGoodBanner);
    return AnswerLikeFirmware(line);
  });
  auto options = FastOptions();
  options.watchdog_ms = 900;
  SerialLightController controller(board.path(), options);
  restart_next = true;
  const std::string message =
      ExpectDeviceError(DeviceErrorKind::kDeviceReset, board.path(), [&] { controller.LightOnly(4); });
  EXPECT_THAT(message, HasSubstr("restarted"));
  EXPECT_THAT(message, HasSubstr("'ON 4'"));
  EXPECT_EQ(controller.board_resets_seen(), 1);
  // All off and the watchdog back on before the error was thrown.
  EXPECT_THAT(board.lines(), ::testing::ElementsAre("WATCHDOG 900", "ON 4", "OFF", "WATCHDOG 900"));
  EXPECT_NO_THROW(controller.LightOnly(4));
}

TEST(SerialLightController, UptimeGoingBackIsDeviceReset) {
  std::atomic<int> statuses{0};
  FakeSerialBoard board(kGoodBanner, [&](const std::string& line) {
    if (line == "STATUS") {
      const int uptime = statuses++ == 0 ? 50000 : 20;
      return "OK STATUS led=none uptime_ms=" + std::to_string(uptime) + " watchdog_ms=10000 watchdog_trips=0\r\n";
    }
    return AnswerLikeFirmware(line);
  });
  SerialLightController controller(board.path(), FastOptions());
  controller.Status();
  const std::string message =
      ExpectDeviceError(DeviceErrorKind::kDeviceReset, board.path(), [&] { controller.Status(); });
  EXPECT_THAT(message, HasSubstr("uptime went back from 50000 to 20 ms"));
  EXPECT_EQ(controller.board_resets_seen(), 1);
}

TEST(SerialLightController, UnreadableStatusIsProtocolError) {
  FakeSerialBoard board(kGoodBanner, [](const std::string& line) {
    return line == "STATUS" ? std::string("OK STATUS led=seven uptime_ms=1\r\n") : AnswerLikeFirmware(line);
  });
  SerialLightController controller(board.path(), FastOptions());
  const std::string message = ExpectDeviceError(DeviceErrorKind::kProtocol, board.path(), [&] { controller.Status(); });
  EXPECT_THAT(message, HasSubstr("led=seven"));
}

TEST(SerialLightController, UnpluggedBoardIsDisconnectedUntilReconnect) {
  FakeSerialBoard board(kGoodBanner, AnswerLikeFirmware);
  auto options = FastOptions();
  options.all_off_on_close = false;
  SerialLightController controller(board.path(), options);
  const std::string port = board.path();
  board.Unplug();
  ExpectDeviceError(DeviceErrorKind::kDisconnected, port, [&] { controller.Status(); });
  const std::string message = ExpectDeviceError(DeviceErrorKind::kDisconnected, port, [&] { controller.AllOff(); });
  EXPECT_THAT(message, HasSubstr("Reconnect()"));
  // (No Reconnect() here: the freed pty number may already belong to a test
  // running in parallel.)
}

}  // namespace
}  // namespace scanbench
