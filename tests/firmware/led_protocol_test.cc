// The LED board's protocol, as the sketch runs it, on the host: every
// command, every error, line endings, overlong lines, noise, the watchdog.
#include "firmware/protocol/led_protocol.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <utility>
#include <vector>

namespace scanbench::led_protocol {
namespace {

Command Parse(const std::string& line) { return ParseLine(line.data(), static_cast<uint8_t>(line.size())); }

TEST(ParseLine, AcceptsEveryCommand) {
  EXPECT_EQ(Parse("ON 0").error, kOk);
  EXPECT_EQ(Parse("ON 0").kind, kCommandOn);
  EXPECT_EQ(Parse("ON 9").argument, 9u);
  EXPECT_EQ(Parse("OFF").kind, kCommandOff);
  EXPECT_EQ(Parse("STATUS").kind, kCommandStatus);
  EXPECT_EQ(Parse("VERSION").kind, kCommandVersion);
  const Command watchdog = Parse("WATCHDOG 2500");
  EXPECT_EQ(watchdog.error, kOk);
  EXPECT_EQ(watchdog.kind, kCommandWatchdog);
  EXPECT_EQ(watchdog.argument, 2500u);
  EXPECT_EQ(Parse("WATCHDOG 100").error, kOk);
  EXPECT_EQ(Parse("WATCHDOG 3600000").error, kOk);
}

TEST(ParseLine, IgnoresCaseAndExtraBlanks) {
  EXPECT_EQ(Parse("on 3").argument, 3u);
  EXPECT_EQ(Parse("Status").kind, kCommandStatus);
  EXPECT_EQ(Parse("  ON\t\t7  ").argument, 7u);
  EXPECT_EQ(Parse("ON 007").argument, 7u);
  EXPECT_EQ(Parse("\tOFF\t").error, kOk);
}

TEST(ParseLine, RejectsUnknownCommands) {
  for (const char* line : {"FOO", "ONN 3", "O", "OF", "STATUSX", "", "   ", "3", "WATCH 100", "OFFF"}) {
    EXPECT_EQ(Parse(line).error, kErrUnknownCommand) << line;
  }
}

TEST(ParseLine, RejectsMissingArguments) {
  EXPECT_EQ(Parse("ON").error, kErrMissingArgument);
  EXPECT_EQ(Parse("ON   ").error, kErrMissingArgument);
  EXPECT_EQ(Parse("WATCHDOG").error, kErrMissingArgument);
}

TEST(ParseLine, RejectsArgumentsThatAreNotDecimal) {
  for (const char* line : {"ON x", "ON -1", "ON +3", "ON 3x", "ON 0x3", "WATCHDOG 1e3", "WATCHDOG 1.5"}) {
    EXPECT_EQ(Parse(line).error, kErrNotANumber) << line;
  }
}

TEST(ParseLine, RejectsValuesOutOfRange) {
  EXPECT_EQ(Parse("ON 10").error, kErrOutOfRange);
  EXPECT_EQ(Parse("ON 255").error, kErrOutOfRange);
  EXPECT_EQ(Parse("ON 4294967296").error, kErrOutOfRange);  // saturates, never wraps to 0
  EXPECT_EQ(Parse("ON 99999999999999999999").error, kErrOutOfRange);
  EXPECT_EQ(Parse("WATCHDOG 99").error, kErrOutOfRange);
  EXPECT_EQ(Parse("WATCHDOG 0").error, kErrOutOfRange);
  EXPECT_EQ(Parse("WATCHDOG 3600001").error, kErrOutOfRange);
}

TEST(ParseLine, RejectsExtraWords) {
  for (const char* line : {"OFF 1", "ON 3 4", "STATUS now", "VERSION 2", "WATCHDOG 100 200"}) {
    EXPECT_EQ(Parse(line).error, kErrUnexpectedArgument) << line;
  }
}

// Feeds text to an assembler, collecting (line, too_long, bad_character).
struct AssembledLine {
  std::string text;
  bool too_long;
  bool bad_character;
};

std::vector<AssembledLine> Assemble(const std::string& bytes) {
  LineAssembler assembler;
  std::vector<AssembledLine> lines;
  for (char byte : bytes) {
    if (assembler.Feed(byte)) {
      lines.push_back({std::string(assembler.line(), assembler.length()), assembler.too_long(),
                       assembler.bad_character()});
      assembler.Clear();
    }
  }
  return lines;
}

TEST(LineAssembler, EndsLinesAtLfCrlfAndCr) {
  const auto lines = Assemble("ON 1\nON 2\r\nON 3\rON 4\n\rOFF\n");
  ASSERT_EQ(lines.size(), 5u);
  EXPECT_EQ(lines[0].text, "ON 1");
  EXPECT_EQ(lines[1].text, "ON 2");
  EXPECT_EQ(lines[2].text, "ON 3");
  EXPECT_EQ(lines[3].text, "ON 4");
  EXPECT_EQ(lines[4].text, "OFF");
}

TEST(LineAssembler, IgnoresEmptyLines) { EXPECT_TRUE(Assemble("\n\r\n\r\r\n\n").empty()); }

TEST(LineAssembler, KeepsALineOfExactlyTheMaximumLength) {
  const std::string longest(kMaxLineLength, 'A');
  const auto lines = Assemble(longest + "\n");
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].text, longest);
  EXPECT_FALSE(lines[0].too_long);
}

TEST(LineAssembler, FlagsAnOverlongLineAndStartsCleanAfterIt) {
  const auto lines = Assemble(std::string(kMaxLineLength + 1, 'A') + "\nOFF\n" + std::string(1000, 'x') + "\r\n");
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_TRUE(lines[0].too_long);
  EXPECT_EQ(lines[1].text, "OFF");
  EXPECT_FALSE(lines[1].too_long);
  EXPECT_TRUE(lines[2].too_long);
}

TEST(LineAssembler, FlagsNonPrintableBytesButKeepsTabs) {
  const std::string with_nul("ON\0 3", 5);
  const auto lines = Assemble(with_nul + "\n\xFF\xFE\nON\t3\n\x7F\n");
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_TRUE(lines[0].bad_character);
  EXPECT_TRUE(lines[1].bad_character);  // noise only: still one line, so one reply
  EXPECT_FALSE(lines[2].bad_character);
  EXPECT_TRUE(lines[3].bad_character);
}

// A board whose pins are recorded in order.
class BoardTest : public ::testing::Test {
 protected:
  void SetUp() override { board_.Start(now_ms_); }

  static void RecordPin(uint8_t led, bool on, void* context) {
    auto* self = static_cast<BoardTest*>(context);
    self->pins_[led] = on;
    self->writes_.emplace_back(led, on);
  }

  // Every reply the bytes produce, in order.
  std::vector<std::string> Send(const std::string& bytes) {
    std::vector<std::string> replies;
    char reply[kReplyCapacity];
    for (char byte : bytes) {
      const uint8_t length = board_.ReceiveByte(byte, now_ms_, reply, sizeof(reply));
      if (length > 0) replies.emplace_back(reply, length);
    }
    return replies;
  }
  std::string SendOne(const std::string& line) {
    const auto replies = Send(line + "\n");
    EXPECT_EQ(replies.size(), 1u) << line;
    return replies.empty() ? "" : replies.front();
  }
  int LitPins() const {
    int count = 0;
    for (bool on : pins_) count += on ? 1 : 0;
    return count;
  }

  uint32_t now_ms_ = 1000;
  bool pins_[kLedCount] = {};
  std::vector<std::pair<int, bool>> writes_;
  LedBoard board_{&BoardTest::RecordPin, this};
};

TEST_F(BoardTest, StartsWithEveryPinWrittenLow) {
  ASSERT_EQ(writes_.size(), static_cast<size_t>(kLedCount));
  for (const auto& [led, on] : writes_) EXPECT_FALSE(on) << led;
  EXPECT_EQ(board_.lit_led(), -1);
}

TEST_F(BoardTest, BannerNamesFirmwareVersionAndLedCount) {
  char banner[kReplyCapacity];
  const uint8_t length = LedBoard::WriteBanner(banner, sizeof(banner));
  EXPECT_EQ(std::string(banner, length), "READY scanbench-leds " SCANBENCH_LEDS_FIRMWARE_VERSION " leds=10\r\n");
  EXPECT_EQ(banner[length], '\0');
}

TEST_F(BoardTest, OnLightsExactlyOneLedTurningTheOldOneOffFirst) {
  EXPECT_EQ(SendOne("ON 3"), "OK ON 3\r\n");
  EXPECT_TRUE(pins_[3]);
  EXPECT_EQ(LitPins(), 1);
  writes_.clear();
  EXPECT_EQ(SendOne("ON 7"), "OK ON 7\r\n");
  ASSERT_EQ(writes_.size(), 2u);
  EXPECT_EQ(writes_[0], std::make_pair(3, false));
  EXPECT_EQ(writes_[1], std::make_pair(7, true));
  EXPECT_EQ(board_.lit_led(), 7);
  writes_.clear();
  EXPECT_EQ(SendOne("ON 7"), "OK ON 7\r\n");
  EXPECT_TRUE(writes_.empty());  // already lit: no flicker
}

TEST_F(BoardTest, OffTurnsEverythingOff) {
  SendOne("ON 9");
  EXPECT_EQ(SendOne("OFF"), "OK OFF\r\n");
  EXPECT_EQ(LitPins(), 0);
  EXPECT_EQ(board_.lit_led(), -1);
  EXPECT_EQ(SendOne("OFF"), "OK OFF\r\n");
}

TEST_F(BoardTest, StatusReportsLedUptimeAndWatchdog) {
  EXPECT_EQ(SendOne("STATUS"), "OK STATUS led=none uptime_ms=0 watchdog_ms=10000 watchdog_trips=0\r\n");
  SendOne("ON 4");
  now_ms_ += 1234;
  EXPECT_EQ(SendOne("STATUS"), "OK STATUS led=4 uptime_ms=1234 watchdog_ms=10000 watchdog_trips=0\r\n");
}

TEST_F(BoardTest, VersionRepeatsTheBanner) {
  EXPECT_EQ(SendOne("VERSION"), "OK VERSION scanbench-leds " SCANBENCH_LEDS_FIRMWARE_VERSION " leds=10\r\n");
}

TEST_F(BoardTest, EveryErrorHasItsCodeAndText) {
  EXPECT_EQ(SendOne("BLINK 3"), "ERR 1 unknown command (ON n, OFF, STATUS, VERSION, WATCHDOG ms)\r\n");
  EXPECT_EQ(SendOne("ON"), "ERR 2 missing led index\r\n");
  EXPECT_EQ(SendOne("WATCHDOG"), "ERR 2 missing milliseconds\r\n");
  EXPECT_EQ(SendOne("ON three"), "ERR 3 argument is not a decimal number\r\n");
  EXPECT_EQ(SendOne("ON 10"), "ERR 4 led out of range 0..9\r\n");
  EXPECT_EQ(SendOne("WATCHDOG 50"), "ERR 4 watchdog_ms out of range 100..3600000\r\n");
  EXPECT_EQ(SendOne("OFF now"), "ERR 5 unexpected argument\r\n");
  EXPECT_EQ(SendOne(std::string(40, 'A')), "ERR 6 line longer than 32 characters\r\n");
  EXPECT_EQ(SendOne("ON \x01"), "ERR 7 non-printable character in line\r\n");
  EXPECT_EQ(LitPins(), 0);
}

TEST_F(BoardTest, ErrorsLeaveTheLitLedAlone) {
  SendOne("ON 5");
  SendOne("ON 12");
  SendOne("garbage");
  EXPECT_EQ(board_.lit_led(), 5);
  EXPECT_TRUE(pins_[5]);
}

TEST_F(BoardTest, AnswersOncePerLineWhateverTheLineEnding) {
  const auto replies = Send("ON 1\nON 2\r\nON 3\rSTATUS\n\rOFF\r\n\n\n");
  ASSERT_EQ(replies.size(), 5u);
  EXPECT_EQ(replies[0], "OK ON 1\r\n");
  EXPECT_EQ(replies[1], "OK ON 2\r\n");
  EXPECT_EQ(replies[2], "OK ON 3\r\n");
  EXPECT_EQ(replies[3].rfind("OK STATUS led=3 ", 0), 0u);
  EXPECT_EQ(replies[4], "OK OFF\r\n");
}

TEST_F(BoardTest, RegainsSyncAfterGarbageAndOverlongLines) {
  const auto replies = Send(std::string("\xDE\xAD\xBE\xEF", 4) + "\n" + std::string(500, 'Z') + "\nON 8\n");
  ASSERT_EQ(replies.size(), 3u);
  EXPECT_EQ(replies[0].rfind("ERR 7 ", 0), 0u);
  EXPECT_EQ(replies[1].rfind("ERR 6 ", 0), 0u);
  EXPECT_EQ(replies[2], "OK ON 8\r\n");
  EXPECT_TRUE(pins_[8]);
}

TEST_F(BoardTest, NoReplyUntilTheTerminatorArrives) {
  EXPECT_TRUE(Send("ON 2").empty());
  EXPECT_FALSE(pins_[2]);
  EXPECT_EQ(Send("\r").size(), 1u);
  EXPECT_TRUE(pins_[2]);
}

TEST_F(BoardTest, WatchdogTurnsTheLedOffAfterSilence) {
  SendOne("ON 6");
  now_ms_ += kDefaultWatchdogMs - 1;
  EXPECT_FALSE(board_.CheckWatchdog(now_ms_));
  EXPECT_TRUE(pins_[6]);
  now_ms_ += 1;
  EXPECT_TRUE(board_.CheckWatchdog(now_ms_));
  EXPECT_EQ(LitPins(), 0);
  EXPECT_EQ(board_.watchdog_trips(), 1);
  EXPECT_EQ(SendOne("STATUS").rfind("OK STATUS led=none ", 0), 0u);
  EXPECT_NE(SendOne("STATUS").find("watchdog_trips=1"), std::string::npos);
}

TEST_F(BoardTest, ValidCommandsFeedTheWatchdogInvalidOnesDoNot) {
  EXPECT_EQ(SendOne("WATCHDOG 200"), "OK WATCHDOG 200\r\n");
  SendOne("ON 1");
  for (int i = 0; i < 10; ++i) {
    now_ms_ += 150;
    EXPECT_FALSE(board_.CheckWatchdog(now_ms_));
    SendOne("STATUS");
  }
  EXPECT_TRUE(pins_[1]);
  now_ms_ += 150;
  SendOne("NOISE");
  now_ms_ += 60;
  EXPECT_TRUE(board_.CheckWatchdog(now_ms_));
  EXPECT_FALSE(pins_[1]);
}

TEST_F(BoardTest, WatchdogWithNothingLitCountsNoTrip) {
  now_ms_ += kDefaultWatchdogMs * 3;
  EXPECT_FALSE(board_.CheckWatchdog(now_ms_));
  EXPECT_EQ(board_.watchdog_trips(), 0);
}

TEST_F(BoardTest, WatchdogWorksAcrossTheMillisWrap) {
  now_ms_ = 0xFFFFFF00u;
  board_.Start(now_ms_);
  SendOne("WATCHDOG 1000");
  SendOne("ON 0");
  now_ms_ += 999;  // wraps past zero
  EXPECT_FALSE(board_.CheckWatchdog(now_ms_));
  now_ms_ += 1;
  EXPECT_TRUE(board_.CheckWatchdog(now_ms_));
}

TEST_F(BoardTest, StartRestoresTheDefaults) {
  SendOne("WATCHDOG 500");
  SendOne("ON 2");
  board_.Start(now_ms_);
  EXPECT_EQ(board_.watchdog_ms(), kDefaultWatchdogMs);
  EXPECT_EQ(LitPins(), 0);
  EXPECT_TRUE(Send("ON 4").empty());  // a half line from before does not survive either
  EXPECT_EQ(Send("\n").front(), "OK ON 4\r\n");
}

TEST(ReplyWriter, NeverOverflowsASmallBuffer) {
  char buffer[8];
  std::memset(buffer, '#', sizeof(buffer));
  ReplyWriter writer(buffer, sizeof(buffer));
  writer.Append("OK STATUS led=none");
  writer.AppendUnsigned(4294967295u);
  const uint8_t length = writer.Finish();
  EXPECT_EQ(length, 7u);
  EXPECT_EQ(std::string(buffer, length), "OK ST\r\n");
  EXPECT_EQ(buffer[7], '\0');
}

TEST(ReplyWriter, WritesTheLargestNumbers) {
  char buffer[kReplyCapacity];
  ReplyWriter writer(buffer, sizeof(buffer));
  writer.AppendUnsigned(0);
  writer.Append(" ");
  writer.AppendUnsigned(4294967295u);
  writer.Finish();
  EXPECT_STREQ(buffer, "0 4294967295\r\n");
}

}  // namespace
}  // namespace scanbench::led_protocol
