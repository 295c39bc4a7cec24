// The LED board's line protocol and behaviour, as plain C++ with no Arduino
// or standard-library headers: the same code runs in the sketch (avr-gcc,
// C++11, no heap) and in the host's unit and fuzz tests. The sketch only
// moves bytes between the UART and LedBoard and drives the pins.
//
// Protocol (115200 baud, 8N1; see firmware/README.md for the full table):
//   boot      ->  READY scanbench-leds <version> leds=10
//   ON <n>    ->  OK ON <n>            LED n (0..9) lit, every other LED off
//   OFF       ->  OK OFF               all LEDs off
//   STATUS    ->  OK STATUS led=<n|none> uptime_ms=<ms> watchdog_ms=<ms> watchdog_trips=<count>
//   VERSION   ->  OK VERSION scanbench-leds <version> leds=10
//   WATCHDOG <ms> -> OK WATCHDOG <ms>  silence after which all LEDs go off
//   anything else -> ERR <code> <text>
// A line ends at CR or LF (so LF, CRLF and CR all work); empty lines get no
// reply, every other line exactly one.
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace scanbench {
namespace led_protocol {

// Bumped when the protocol or the board's behaviour changes.
#define SCANBENCH_LEDS_FIRMWARE_NAME "scanbench-leds"
#define SCANBENCH_LEDS_FIRMWARE_VERSION "1.0.0"

const uint8_t kLedCount = 10;
// LED n is driven by Arduino digital pin kFirstLedPin + n (D2..D11): D0/D1
// are the USB serial line, D13 carries the on-board LED.
const uint8_t kFirstLedPin = 2;
const uint32_t kBaudRate = 115200;

// Characters in one command line, terminator excluded. Longer lines are
// answered with ERR 6 once their terminator arrives.
const uint8_t kMaxLineLength = 32;
// Room for the longest reply (STATUS with every number at its maximum) plus
// "\r\n" and a NUL.
const uint8_t kReplyCapacity = 96;

// Silence (no valid command) after which the board turns every LED off, so
// that a crashed or unplugged host never leaves an LED burning. Not kept
// across a reset: the host sets it after connecting.
const uint32_t kDefaultWatchdogMs = 10000;
const uint32_t kMinWatchdogMs = 100;
const uint32_t kMaxWatchdogMs = 3600000;

// The number after ERR. The host treats 1, 6 and 7 as signs of a corrupted
// line (it never sends such lines itself) and retries.
enum ErrorCode {
  kOk = 0,
  kErrUnknownCommand = 1,   // first word is not a command
  kErrMissingArgument = 2,  // ON / WATCHDOG without a number
  kErrNotANumber = 3,       // argument has a character other than 0-9
  kErrOutOfRange = 4,       // LED index or watchdog time outside its range
  kErrUnexpectedArgument = 5,  // a word too many
  kErrLineTooLong = 6,      // more than kMaxLineLength characters
  kErrBadCharacter = 7,     // a byte outside printable ASCII (line noise)
};

enum CommandKind { kCommandOn, kCommandOff, kCommandStatus, kCommandVersion, kCommandWatchdog };

struct Command {
  ErrorCode error;   // kOk when the line is a valid command
  CommandKind kind;  // valid when error == kOk
  uint32_t argument; // LED index for ON, milliseconds for WATCHDOG
};

// Parses one complete line (terminator removed). Command words are matched
// case-insensitively; words are separated by spaces or tabs.
Command ParseLine(const char* line, uint8_t length);

// Collects received bytes into lines of at most kMaxLineLength characters.
// An overlong or noisy line is remembered as such and reported when its
// terminator arrives, so that the next line starts clean (sync regained).
class LineAssembler {
 public:
  LineAssembler();
  // True when `byte` ended a non-empty line; read it with line()/length()
  // and the flags, then call Clear().
  bool Feed(char byte);
  void Clear();

  const char* line() const { return buffer_; }
  uint8_t length() const { return length_; }
  bool too_long() const { return too_long_; }
  bool bad_character() const { return bad_character_; }

 private:
  char buffer_[kMaxLineLength + 1];
  uint8_t length_;
  bool too_long_;
  bool bad_character_;
};

// Writes a reply into a caller's buffer; never overflows, always NUL-terminates.
class ReplyWriter {
 public:
  ReplyWriter(char* buffer, uint8_t capacity);
  void Append(const char* text);
  void AppendUnsigned(uint32_t value);
  // Adds "\r\n" and returns the reply's length (NUL excluded).
  uint8_t Finish();

 private:
  char* buffer_;
  uint8_t capacity_;
  uint8_t length_;
};

// "ERR <code> <text>" for `error`; `kind` picks the range named by kErrOutOfRange.
void AppendError(ErrorCode error, CommandKind kind, ReplyWriter& reply);

// The board: lines in, replies out, LED pins through a callback, watchdog.
// At most one LED is ever lit: switching to another LED turns the old one
// off first.
class LedBoard {
 public:
  // Drives LED `led` (0..kLedCount-1) on or off.
  typedef void (*LedWriter)(uint8_t led, bool on, void* context);

  LedBoard(LedWriter write_led, void* context);

  // Power-on state: every LED off (each written once), default watchdog.
  void Start(uint32_t now_ms);

  // Handles one received byte. When it completes a line, the reply
  // (ending in "\r\n", NUL-terminated) is written to `reply` and its length
  // returned; otherwise 0. `capacity` should be kReplyCapacity.
  uint8_t ReceiveByte(char byte, uint32_t now_ms, char* reply, uint8_t capacity);

  // Call every loop iteration: after watchdog_ms() without a valid command
  // every LED goes off. Returns true when it just did so.
  bool CheckWatchdog(uint32_t now_ms);

  // The boot banner, "READY ..." with "\r\n"; returns its length.
  static uint8_t WriteBanner(char* reply, uint8_t capacity);

  int8_t lit_led() const { return lit_led_; }  // -1 when all are off
  uint32_t watchdog_ms() const { return watchdog_ms_; }
  uint16_t watchdog_trips() const { return watchdog_trips_; }

 private:
  // `command` is valid (error == kOk).
  void Execute(const Command& command, uint32_t now_ms, ReplyWriter& reply);
  void LightOnly(int8_t led);

  LedWriter write_led_;
  void* context_;
  LineAssembler assembler_;
  int8_t lit_led_;
  uint32_t start_ms_;
  uint32_t last_command_ms_;
  uint32_t watchdog_ms_;
  uint16_t watchdog_trips_;
};

}  // namespace led_protocol
}  // namespace scanbench
