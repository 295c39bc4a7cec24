// See led_protocol.h. Written for both avr-gcc 5.4 (C++11, no standard
// library, 2 KB of RAM) and the host compilers: no heap, no exceptions, no
// printf (it would cost the Uno ~1.5 KB of flash).
#include "firmware/protocol/led_protocol.h"

namespace scanbench {
namespace led_protocol {

namespace {

bool IsSeparator(char c) { return c == ' ' || c == '\t'; }

char ToUpper(char c) { return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 'a' + 'A') : c; }

// True when the `length` characters at `word` spell `name` (upper case),
// ignoring case.
bool WordIs(const char* word, uint8_t length, const char* name) {
  uint8_t i = 0;
  for (; i < length; ++i) {
    if (name[i] == '\0' || ToUpper(word[i]) != name[i]) return false;
  }
  return name[i] == '\0';
}

// Splits off the next word starting at *position; returns its length (0 at
// the end of the line) and leaves *position just after it.
uint8_t NextWord(const char* line, uint8_t length, uint8_t* position, const char** word) {
  uint8_t i = *position;
  while (i < length && IsSeparator(line[i])) ++i;
  *word = line + i;
  uint8_t start = i;
  while (i < length && !IsSeparator(line[i])) ++i;
  *position = i;
  return static_cast<uint8_t>(i - start);
}

// Decimal digits only. Values past 2^32 - 1 saturate there, which every
// range check then rejects as out of range.
bool ParseUnsigned(const char* word, uint8_t length, uint32_t* value) {
  const uint32_t kMax = 0xFFFFFFFFu;
  uint32_t result = 0;
  for (uint8_t i = 0; i < length; ++i) {
    if (word[i] < '0' || word[i] > '9') return false;
    uint32_t digit = static_cast<uint32_t>(word[i] - '0');
    result = (result > (kMax - digit) / 10u) ? kMax : result * 10u + digit;
  }
  *value = result;
  return true;
}

Command MakeCommand(ErrorCode error, CommandKind kind, uint32_t argument) {
  Command command;
  command.error = error;
  command.kind = kind;
  command.argument = argument;
  return command;
}

}  // namespace

Command ParseLine(const char* line, uint8_t length) {
  uint8_t position = 0;
  const char* word = line;
  uint8_t word_length = NextWord(line, length, &position, &word);

  CommandKind kind;
  bool takes_argument = false;
  if (WordIs(word, word_length, "ON")) {
    kind = kCommandOn;
    takes_argument = true;
  } else if (WordIs(word, word_length, "OFF")) {
    kind = kCommandOff;
  } else if (WordIs(word, word_length, "STATUS")) {
    kind = kCommandStatus;
  } else if (WordIs(word, word_length, "VERSION")) {
    kind = kCommandVersion;
  } else if (WordIs(word, word_length, "WATCHDOG")) {
    kind = kCommandWatchdog;
    takes_argument = true;
  } else {
    return MakeCommand(kErrUnknownCommand, kCommandOff, 0);
  }

  uint32_t argument = 0;
  if (takes_argument) {
    word_length = NextWord(line, length, &position, &word);
    if (word_length == 0) return MakeCommand(kErrMissingArgument, kind, 0);
    if (!ParseUnsigned(word, word_length, &argument)) return MakeCommand(kErrNotANumber, kind, 0);
  }
  if (NextWord(line, length, &position, &word) != 0) return MakeCommand(kErrUnexpectedArgument, kind, 0);

  if (kind == kCommandOn && argument >= kLedCount) return MakeCommand(kErrOutOfRange, kind, argument);
  if (kind == kCommandWatchdog && (argument < kMinWatchdogMs || argument > kMaxWatchdogMs)) {
    return MakeCommand(kErrOutOfRange, kind, argument);
  }
  return MakeCommand(kOk, kind, argument);
}

LineAssembler::LineAssembler() { Clear(); }

void LineAssembler::Clear() {
  length_ = 0;
  too_long_ = false;
  bad_character_ = false;
  buffer_[0] = '\0';
}

bool LineAssembler::Feed(char byte) {
  if (byte == '\r' || byte == '\n') {
    // CR LF arrives as a line and an empty line; the empty one is ignored.
    return length_ > 0 || too_long_ || bad_character_;
  }
  const unsigned char value = static_cast<unsigned char>(byte);
  if ((value < 0x20 && byte != '\t') || value > 0x7E) {
    bad_character_ = true;
    return false;
  }
  if (length_ >= kMaxLineLength) {
    too_long_ = true;
    return false;
  }
  buffer_[length_++] = byte;
  buffer_[length_] = '\0';
  return false;
}

ReplyWriter::ReplyWriter(char* buffer, uint8_t capacity) : buffer_(buffer), capacity_(capacity), length_(0) {
  if (capacity_ > 0) buffer_[0] = '\0';
}

void ReplyWriter::Append(const char* text) {
  // Keep room for "\r\n" and the NUL so that Finish() always fits.
  while (*text != '\0' && length_ + 3 < capacity_) buffer_[length_++] = *text++;
  if (capacity_ > 0) buffer_[length_] = '\0';
}

void ReplyWriter::AppendUnsigned(uint32_t value) {
  char digits[11];
  uint8_t count = 0;
  do {
    digits[count++] = static_cast<char>('0' + value % 10u);
    value /= 10u;
  } while (value != 0);
  char text[11];
  for (uint8_t i = 0; i < count; ++i) text[i] = digits[count - 1 - i];
  text[count] = '\0';
  Append(text);
}

uint8_t ReplyWriter::Finish() {
  if (capacity_ < 3) return 0;
  buffer_[length_++] = '\r';
  buffer_[length_++] = '\n';
  buffer_[length_] = '\0';
  return length_;
}

LedBoard::LedBoard(LedWriter write_led, void* context)
    : write_led_(write_led),
      context_(context),
      lit_led_(-1),
      start_ms_(0),
      last_command_ms_(0),
      watchdog_ms_(kDefaultWatchdogMs),
      watchdog_trips_(0) {}

void LedBoard::Start(uint32_t now_ms) {
  for (uint8_t led = 0; led < kLedCount; ++led) write_led_(led, false, context_);
  lit_led_ = -1;
  start_ms_ = now_ms;
  last_command_ms_ = now_ms;
  watchdog_ms_ = kDefaultWatchdogMs;
  watchdog_trips_ = 0;
  assembler_.Clear();
}

void LedBoard::LightOnly(int8_t led) {
  if (led == lit_led_) return;
  // Off before on: two LEDs must never light the sample together, not even
  // for the microseconds between two pin writes.
  if (lit_led_ >= 0) write_led_(static_cast<uint8_t>(lit_led_), false, context_);
  lit_led_ = -1;
  if (led >= 0) {
    write_led_(static_cast<uint8_t>(led), true, context_);
    lit_led_ = led;
  }
}

uint8_t LedBoard::WriteBanner(char* reply, uint8_t capacity) {
  ReplyWriter writer(reply, capacity);
  writer.Append("READY " SCANBENCH_LEDS_FIRMWARE_NAME " " SCANBENCH_LEDS_FIRMWARE_VERSION " leds=");
  writer.AppendUnsigned(kLedCount);
  return writer.Finish();
}

uint8_t LedBoard::ReceiveByte(char byte, uint32_t now_ms, char* reply, uint8_t capacity) {
  if (!assembler_.Feed(byte)) return 0;
  ReplyWriter writer(reply, capacity);
  // Noise outranks length: a burst of garbage is usually both.
  if (assembler_.bad_character()) {
    AppendError(kErrBadCharacter, kCommandOff, writer);
  } else if (assembler_.too_long()) {
    AppendError(kErrLineTooLong, kCommandOff, writer);
  } else {
    Command command = ParseLine(assembler_.line(), assembler_.length());
    if (command.error == kOk) {
      Execute(command, now_ms, writer);
    } else {
      AppendError(command.error, command.kind, writer);
    }
  }
  assembler_.Clear();
  return writer.Finish();
}

void AppendError(ErrorCode error, CommandKind kind, ReplyWriter& reply) {
  reply.Append("ERR ");
  reply.AppendUnsigned(static_cast<uint32_t>(error));
  switch (error) {
    case kOk:
      reply.Append(" no error");
      return;
    case kErrUnknownCommand:
      reply.Append(" unknown command (ON n, OFF, STATUS, VERSION, WATCHDOG ms)");
      return;
    case kErrMissingArgument:
      reply.Append(kind == kCommandOn ? " missing led index" : " missing milliseconds");
      return;
    case kErrNotANumber:
      reply.Append(" argument is not a decimal number");
      return;
    case kErrOutOfRange:
      if (kind == kCommandOn) {
        reply.Append(" led out of range 0..");
        reply.AppendUnsigned(kLedCount - 1);
      } else {
        reply.Append(" watchdog_ms out of range ");
        reply.AppendUnsigned(kMinWatchdogMs);
        reply.Append("..");
        reply.AppendUnsigned(kMaxWatchdogMs);
      }
      return;
    case kErrUnexpectedArgument:
      reply.Append(" unexpected argument");
      return;
    case kErrLineTooLong:
      reply.Append(" line longer than ");
      reply.AppendUnsigned(kMaxLineLength);
      reply.Append(" characters");
      return;
    case kErrBadCharacter:
      reply.Append(" non-printable character in line");
      return;
  }
}

void LedBoard::Execute(const Command& command, uint32_t now_ms, ReplyWriter& reply) {
  last_command_ms_ = now_ms;
  switch (command.kind) {
    case kCommandOn:
      LightOnly(static_cast<int8_t>(command.argument));
      reply.Append("OK ON ");
      reply.AppendUnsigned(command.argument);
      return;
    case kCommandOff:
      LightOnly(-1);
      reply.Append("OK OFF");
      return;
    case kCommandStatus:
      reply.Append("OK STATUS led=");
      if (lit_led_ >= 0) {
        reply.AppendUnsigned(static_cast<uint32_t>(lit_led_));
      } else {
        reply.Append("none");
      }
      reply.Append(" uptime_ms=");
      reply.AppendUnsigned(now_ms - start_ms_);
      reply.Append(" watchdog_ms=");
      reply.AppendUnsigned(watchdog_ms_);
      reply.Append(" watchdog_trips=");
      reply.AppendUnsigned(watchdog_trips_);
      return;
    case kCommandVersion:
      reply.Append("OK VERSION " SCANBENCH_LEDS_FIRMWARE_NAME " " SCANBENCH_LEDS_FIRMWARE_VERSION " leds=");
      reply.AppendUnsigned(kLedCount);
      return;
    case kCommandWatchdog:
      watchdog_ms_ = command.argument;
      reply.Append("OK WATCHDOG ");
      reply.AppendUnsigned(watchdog_ms_);
      return;
  }
}

bool LedBoard::CheckWatchdog(uint32_t now_ms) {
  // Unsigned difference: correct across the millis() wrap after 49 days.
  if (now_ms - last_command_ms_ < watchdog_ms_) return false;
  last_command_ms_ = now_ms;
  if (lit_led_ < 0) return false;
  LightOnly(-1);
  if (watchdog_trips_ != 0xFFFF) ++watchdog_trips_;
  return true;
}

}  // namespace led_protocol
}  // namespace scanbench
