// Firmware in the loop: the built ELF runs in simavr, SerialLightController
// talks to it over the pty exactly as to a real Uno, and the assertions look
// at the simulated pins, not at the replies.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <memory>
#include <thread>

#include "app/devices/serial_light_controller.h"
#include "app/devices/simulated_led_board.h"
#include "firmware/protocol/led_protocol.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;
using LedMask = SimulatedLedBoard::LedMask;

constexpr LedMask Only(int led) { return LedMask{1} << led; }

class FirmwareLoopTest : public ::testing::Test {
 protected:
  void SetUp() override {
    board_ = std::make_unique<SimulatedLedBoard>();
    controller_ = std::make_unique<SerialLightController>(board_->port_path(), Options());
  }

  static SerialLightControllerOptions Options() {
    SerialLightControllerOptions options;
    options.banner_timeout_ms = 1000;
    options.reply_timeout_ms = 300;
    options.resync_quiet_ms = 20;
    return options;
  }

  DeviceError CatchDeviceError(const std::function<void()>& action) {
    try {
      action();
    } catch (const DeviceError& error) {
      return error;
    }
    ADD_FAILURE() << "no DeviceError";
    return DeviceError(DeviceErrorKind::kIo, "", "");
  }

  std::unique_ptr<SimulatedLedBoard> board_;
  std::unique_ptr<SerialLightController> controller_;
};

TEST_F(FirmwareLoopTest, OpeningThePortRestartsTheBoardAndItsBannerIsRead) {
  EXPECT_EQ(board_->reset_count(), 1);
  EXPECT_EQ(controller_->firmware().name, "scanbench-leds");
  EXPECT_EQ(controller_->firmware().version, SCANBENCH_LEDS_FIRMWARE_VERSION);
  EXPECT_EQ(controller_->led_count(), 10);
  EXPECT_EQ(board_->lit_leds(), 0u);
  const LightFirmwareInfo version = controller_->Version();
  EXPECT_EQ(version.name, "scanbench-leds");
  EXPECT_EQ(version.led_count, 10);
}

TEST_F(FirmwareLoopTest, EachCommandLightsExactlyItsPin) {
  for (int led = 0; led < 10; ++led) {
    controller_->LightOnly(led);
    EXPECT_EQ(board_->lit_leds(), Only(led)) << "LED " << led;
  }
  for (int led : {7, 2, 2, 9, 0}) {
    controller_->LightOnly(led);
    EXPECT_EQ(board_->lit_leds(), Only(led)) << "LED " << led;
  }
  // Never two at once, not even between the two pin writes of a switch.
  EXPECT_EQ(board_->max_lit_at_once(), 1);
}

TEST_F(FirmwareLoopTest, AllOffClearsEveryPin) {
  controller_->LightOnly(6);
  controller_->AllOff();
  EXPECT_EQ(board_->lit_leds(), 0u);
  controller_->AllOff();
  EXPECT_EQ(board_->lit_leds(), 0u);
}

TEST_F(FirmwareLoopTest, StatusMatchesThePins) {
  LightStatus status = controller_->Status();
  EXPECT_FALSE(status.lit_led.has_value());
  EXPECT_EQ(status.watchdog_ms, 10000u);
  controller_->LightOnly(8);
  std::this_thread::sleep_for(milliseconds(60));
  status = controller_->Status();
  ASSERT_TRUE(status.lit_led.has_value());
  EXPECT_EQ(*status.lit_led, 8);
  EXPECT_EQ(board_->lit_leds(), Only(*status.lit_led));
  // The firmware's clock runs with the wall clock (the simulation is paced).
  EXPECT_GE(status.uptime_ms, 60u);
  EXPECT_LT(status.uptime_ms, 5000u);
}

TEST_F(FirmwareLoopTest, WatchdogTurnsTheLedOffAfterSilence) {
  controller_->SetWatchdog(150);
  controller_->LightOnly(4);
  const auto lit_at = Clock::now();
  ASSERT_EQ(board_->lit_leds(), Only(4));
  ASSERT_TRUE(board_->WaitForLitLeds(0, milliseconds(3000)));
  const auto silence = Clock::now() - lit_at;
  EXPECT_GE(silence, milliseconds(130));  // simulated time never runs ahead of the wall clock
  EXPECT_LT(silence, milliseconds(1500));
  const LightStatus status = controller_->Status();
  EXPECT_FALSE(status.lit_led.has_value());
  EXPECT_EQ(status.watchdog_ms, 150u);
  EXPECT_EQ(status.watchdog_trips, 1u);
}

TEST_F(FirmwareLoopTest, CommandsKeepTheWatchdogFromFiring) {
  // Fed every ~50 ms for longer than its period: a wide margin, so that a
  // loaded machine descheduling this test does not starve it.
  controller_->SetWatchdog(400);
  controller_->LightOnly(1);
  for (int i = 0; i < 12; ++i) {
    std::this_thread::sleep_for(milliseconds(50));
    controller_->Status();
  }
  EXPECT_EQ(board_->lit_leds(), Only(1));
}

TEST_F(FirmwareLoopTest, GarbageOnTheLineThenAGoodCommandWorks) {
  // A burst of noise with its own line end: the board answers it with ERR,
  // a reply nobody asked for.
  constexpr char kBurst[] = "\xFF\x00\x13garbage\r\n";
  board_->InjectNoiseToBoard(std::string(kBurst, sizeof(kBurst) - 1));
  std::this_thread::sleep_for(milliseconds(20));
  controller_->LightOnly(2);
  EXPECT_EQ(board_->lit_leds(), Only(2));
  // Noise without a line end glues onto the next command, which the board
  // then rejects; the controller resyncs and sends it again.
  board_->InjectNoiseToBoard("\x7Fzz");
  std::this_thread::sleep_for(milliseconds(5));
  controller_->LightOnly(5);
  EXPECT_EQ(board_->lit_leds(), Only(5));
  // Noise towards the host is skipped.
  board_->InjectNoiseToHost("\xFE\xFF line noise\r\n");
  EXPECT_EQ(*controller_->Status().lit_led, 5);
  EXPECT_EQ(board_->max_lit_at_once(), 1);
}

TEST_F(FirmwareLoopTest, ResetMidSessionIsReportedThenTheLinkWorks) {
  controller_->SetWatchdog(5000);
  controller_->LightOnly(3);
  board_->Reset();  // brown-out, or someone pressed the button
  EXPECT_EQ(board_->lit_leds(), 0u);
  const DeviceError error = CatchDeviceError([&] { controller_->LightOnly(6); });
  EXPECT_EQ(error.kind(), DeviceErrorKind::kDeviceReset);
  EXPECT_THAT(error.what(), HasSubstr(board_->port_path()));
  EXPECT_THAT(error.what(), HasSubstr("restarted"));
  EXPECT_EQ(controller_->board_resets_seen(), 1);
  // The restart lost the watchdog setting; the controller put it back.
  EXPECT_EQ(controller_->Status().watchdog_ms, 5000u);
  controller_->LightOnly(6);
  EXPECT_EQ(board_->lit_leds(), Only(6));
}

TEST_F(FirmwareLoopTest, ResetWhileIdleIsNoticedAtTheNextCommand) {
  board_->Reset();
  std::this_thread::sleep_for(milliseconds(50));  // the banner arrives unasked
  const DeviceError error = CatchDeviceError([&] { controller_->Status(); });
  EXPECT_EQ(error.kind(), DeviceErrorKind::kDeviceReset);
  EXPECT_NO_THROW(controller_->Status());
}

TEST_F(FirmwareLoopTest, ReconnectRestartsTheBoard) {
  controller_->LightOnly(9);
  controller_->Reconnect();
  EXPECT_EQ(board_->reset_count(), 2);
  EXPECT_EQ(board_->lit_leds(), 0u);
  controller_->LightOnly(0);
  EXPECT_EQ(board_->lit_leds(), Only(0));
}

TEST_F(FirmwareLoopTest, ClosingTheControllerTurnsEverythingOff) {
  controller_->LightOnly(7);
  controller_.reset();
  EXPECT_EQ(board_->lit_leds(), 0u);
}

TEST_F(FirmwareLoopTest, SecondControllerIsBusy) {
  const DeviceError error = CatchDeviceError([&] { SerialLightController second(board_->port_path(), Options()); });
  EXPECT_EQ(error.kind(), DeviceErrorKind::kBusy);
}

TEST_F(FirmwareLoopTest, SimulationStoppingIsADisconnect) {
  board_->Stop();
  const DeviceError error = CatchDeviceError([&] { controller_->Status(); });
  EXPECT_EQ(error.kind(), DeviceErrorKind::kDisconnected);
}

TEST(FirmwareLoop, BoardWithoutAutoResetIsFoundByAskingItsVersion) {
  SimulatedLedBoardOptions board_options;
  board_options.reset_on_open = false;
  SimulatedLedBoard board(board_options);
  std::this_thread::sleep_for(milliseconds(30));  // booted, banner gone unheard
  SerialLightControllerOptions options;
  options.banner_timeout_ms = 100;
  SerialLightController controller(board.port_path(), options);
  EXPECT_EQ(board.reset_count(), 0);
  controller.LightOnly(3);
  EXPECT_EQ(board.lit_leds(), Only(3));
}

}  // namespace
}  // namespace scanbench
