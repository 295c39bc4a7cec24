#include "app/devices/serial_light_controller.h"

#include <charconv>
#include <chrono>
#include <map>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

#include "app/devices/serial_port.h"
#include "firmware/protocol/led_protocol.h"

namespace scanbench {

namespace protocol = led_protocol;
using Clock = std::chrono::steady_clock;

namespace {

// Longer received lines are noise, not replies (the longest is < 96).
constexpr size_t kMaxReplyLength = 256;

std::vector<std::string> SplitWords(const std::string& text) {
  std::vector<std::string> words;
  std::istringstream stream(text);
  for (std::string word; stream >> word;) words.push_back(word);
  return words;
}

std::optional<uint32_t> ParseUnsigned(const std::string& text) {
  uint32_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || text.empty()) return std::nullopt;
  return value;
}

// "name version leds=N" (banner and VERSION reply share it).
std::optional<LightFirmwareInfo> ParseFirmwareInfo(const std::vector<std::string>& words, size_t first) {
  if (words.size() < first + 3) return std::nullopt;
  LightFirmwareInfo info;
  info.name = words[first];
  info.version = words[first + 1];
  const std::string& leds = words[first + 2];
  if (leds.rfind("leds=", 0) != 0) return std::nullopt;
  const auto count = ParseUnsigned(leds.substr(5));
  if (!count || *count == 0 || *count > 32) return std::nullopt;
  info.led_count = static_cast<int>(*count);
  return info;
}

std::string Quoted(const std::string& text) { return "'" + text + "'"; }

void CheckRange(const char* field, int64_t value, int64_t low, int64_t high) {
  if (value < low || value > high) {
    throw std::invalid_argument("SerialLightControllerOptions." + std::string(field) + " = " +
                                std::to_string(value) + ": must be in [" + std::to_string(low) + ", " +
                                std::to_string(high) + "]");
  }
}

}  // namespace

// One received line, classified.
struct SerialLightController::Reply {
  enum class Type { kBanner, kOk, kError, kNoise } type = Type::kNoise;
  std::string line;      // as received, leading noise removed
  std::string word;      // kOk: the command word it answers
  std::string rest;      // kOk: after the word; kError: the text
  int error_code = 0;    // kError
  std::optional<LightFirmwareInfo> banner;  // kBanner
};

SerialLightController::Reply SerialLightController::ClassifyLine(std::string line) {
  using Type = Reply::Type;
  Reply reply;
  // Bytes from a reset or line noise often precede a good line: skip them.
  size_t start = 0;
  while (start < line.size() && (static_cast<unsigned char>(line[start]) < 0x20 ||
                                 static_cast<unsigned char>(line[start]) > 0x7E)) {
    ++start;
  }
  line.erase(0, start);
  // A restart cuts the line it interrupts: the banner may follow a partial
  // line without a terminator of its own.
  if (const size_t banner = line.rfind("READY "); banner != std::string::npos && banner > 0) line.erase(0, banner);
  reply.line = line;
  for (char c : line) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E) return reply;  // noise
  }
  const std::vector<std::string> words = SplitWords(line);
  if (words.empty()) return reply;
  if (words[0] == "READY") {
    reply.banner = ParseFirmwareInfo(words, 1);
    if (reply.banner) reply.type = Type::kBanner;
    return reply;
  }
  if (words[0] == "OK" && words.size() >= 2) {
    reply.type = Type::kOk;
    reply.word = words[1];
    const size_t word_end = line.find(words[1]) + words[1].size();
    reply.rest = word_end < line.size() ? line.substr(word_end + 1) : "";
    return reply;
  }
  if (words[0] == "ERR" && words.size() >= 2) {
    const auto code = ParseUnsigned(words[1]);
    if (!code) return reply;
    reply.type = Type::kError;
    reply.error_code = static_cast<int>(*code);
    reply.rest = line.substr(line.find(words[1]) + words[1].size());
    if (!reply.rest.empty() && reply.rest[0] == ' ') reply.rest.erase(0, 1);
    return reply;
  }
  return reply;
}

void SerialLightControllerOptions::Check() const {
  if (!SerialPort::IsSupportedBaudRate(baud_rate)) {
    throw std::invalid_argument("SerialLightControllerOptions.baud_rate = " + std::to_string(baud_rate) +
                                ": must be a standard termios rate (the firmware uses 115200)");
  }
  CheckRange("banner_timeout_ms", banner_timeout_ms, 1, 60000);
  CheckRange("reply_timeout_ms", reply_timeout_ms, 1, 60000);
  CheckRange("attempts", attempts, 1, 10);
  CheckRange("resync_quiet_ms", resync_quiet_ms, 1, 1000);
  CheckRange("reconnect_pause_ms", reconnect_pause_ms, 0, 5000);
  if (watchdog_ms != 0) {
    CheckRange("watchdog_ms", watchdog_ms, protocol::kMinWatchdogMs, protocol::kMaxWatchdogMs);
  }
}

SerialLightController::SerialLightController(std::string port, SerialLightControllerOptions options)
    : port_path_(std::move(port)), options_(options) {
  options_.Check();
  Connect();
}

SerialLightController::~SerialLightController() {
  if (!options_.all_off_on_close || !port_) return;
  try {
    AllOff();
  } catch (const std::exception&) {
    // Nothing to do on the way out; the firmware watchdog turns them off.
  }
}

std::string SerialLightController::description() const { return "LED board on " + port_path_; }

void SerialLightController::RequirePort() const {
  if (!port_) {
    throw DeviceError(DeviceErrorKind::kDisconnected, port_path_,
                      "LED board on " + port_path_ + " is disconnected: call Reconnect() once it is back");
  }
}

void SerialLightController::Connect() {
  port_.reset();
  received_.clear();
  resync_needed_ = false;
  last_uptime_ms_.reset();
  port_ = std::make_unique<SerialPort>(port_path_, options_.baud_rate);

  std::optional<LightFirmwareInfo> info;
  std::string last_noise;
  const auto banner_deadline = Clock::now() + std::chrono::milliseconds(options_.banner_timeout_ms);
  while (!info) {
    const auto line = NextLine(banner_deadline);
    if (!line) break;
    Reply reply = ClassifyLine(*line);
    if (reply.type == Reply::Type::kBanner) {
      info = reply.banner;
    } else {
      last_noise = reply.line;
    }
  }

  if (!info && options_.probe_without_banner) {
    // A board that did not reset on open (auto-reset disabled) is already
    // running: the leading newline ends any half line it holds.
    port_->Write("\nVERSION\n", Clock::now() + std::chrono::milliseconds(options_.reply_timeout_ms));
    const auto probe_deadline = Clock::now() + std::chrono::milliseconds(options_.reply_timeout_ms);
    while (!info) {
      const auto line = NextLine(probe_deadline);
      if (!line) break;
      Reply reply = ClassifyLine(*line);
      if (reply.type == Reply::Type::kBanner) {
        info = reply.banner;
      } else if (reply.type == Reply::Type::kOk && reply.word == "VERSION") {
        info = ParseFirmwareInfo(SplitWords(reply.rest), 0);
        if (!info) last_noise = reply.line;
      } else if (reply.type != Reply::Type::kError) {
        last_noise = reply.line;
      }
    }
  }

  if (!info) {
    port_.reset();
    std::string message = "no READY banner from " + port_path_ + " within " +
                          std::to_string(options_.banner_timeout_ms) + " ms";
    if (options_.probe_without_banner) message += " and no answer to VERSION";
    message += ": is this the LED board, with the " SCANBENCH_LEDS_FIRMWARE_NAME
               " firmware flashed (firmware/README.md), and nothing else using the port?";
    if (!last_noise.empty()) message += " Last line received: " + Quoted(last_noise.substr(0, 60));
    throw DeviceError(DeviceErrorKind::kNoResponse, port_path_, message);
  }
  if (info->name != SCANBENCH_LEDS_FIRMWARE_NAME || info->version.rfind("1.", 0) != 0) {
    port_.reset();
    throw DeviceError(DeviceErrorKind::kWrongDevice, port_path_,
                      "the board on " + port_path_ + " runs " + info->name + " " + info->version +
                          ", not " SCANBENCH_LEDS_FIRMWARE_NAME " 1.x: flash firmware/ (see firmware/README.md)");
  }
  firmware_ = *info;
  ApplyWatchdog();
}

void SerialLightController::ApplyWatchdog() {
  if (options_.watchdog_ms == 0) return;
  Transact("WATCHDOG " + std::to_string(options_.watchdog_ms));
}

void SerialLightController::Reconnect() {
  port_.reset();
  std::this_thread::sleep_for(std::chrono::milliseconds(options_.reconnect_pause_ms));
  Connect();
}

std::optional<std::string> SerialLightController::NextLine(Clock::time_point deadline) {
  while (true) {
    const size_t end = received_.find_first_of("\r\n");
    if (end != std::string::npos) {
      std::string line = received_.substr(0, end);
      received_.erase(0, end + 1);
      if (line.empty()) continue;  // the LF of a CR LF
      return line;
    }
    if (received_.size() > kMaxReplyLength) {
      // No terminator in sight: noise. Keep the tail, where a line may start.
      received_.erase(0, received_.size() - kMaxReplyLength / 2);
    }
    try {
      if (port_->Read(received_, deadline) == 0) return std::nullopt;
    } catch (const DeviceError& error) {
      if (error.kind() == DeviceErrorKind::kDisconnected) port_.reset();
      throw;
    }
  }
}

void SerialLightController::HandleBoardReset(const Reply& banner, const std::string& context) {
  if (banner.banner) firmware_ = *banner.banner;
  received_.clear();
  ThrowBoardReset("LED board on " + port_path_ + " restarted (" + context + ")");
}

void SerialLightController::ThrowBoardReset(const std::string& what_happened) {
  ++board_resets_seen_;
  resync_needed_ = false;
  last_uptime_ms_.reset();
  // A command sent just as the board came back may still have been carried
  // out: switch everything off so that "all off" below is true, and put the
  // watchdog setting back.
  try {
    Transact("OFF");
    ApplyWatchdog();
  } catch (const DeviceError& error) {
    throw DeviceError(DeviceErrorKind::kDeviceReset, port_path_,
                      what_happened + "; restoring its state (all off, watchdog) then failed: " + error.what());
  }
  throw DeviceError(DeviceErrorKind::kDeviceReset, port_path_,
                    what_happened +
                        ": all LEDs are off and its settings restored; the link is resynchronised, repeat the step");
}

void SerialLightController::CheckForUnsolicitedLines(const std::string& context) {
  const auto now = Clock::now();
  while (const auto line = NextLine(now)) {
    Reply reply = ClassifyLine(*line);
    // Late replies to an earlier, timed-out command are dropped here.
    if (reply.type == Reply::Type::kBanner) HandleBoardReset(reply, "READY banner before " + context);
  }
}

void SerialLightController::Resync(const std::string& context) {
  // The newline ends any half line the board holds (it may answer ERR to it);
  // then everything until the line goes quiet is stale.
  port_->Write("\n", Clock::now() + std::chrono::milliseconds(options_.reply_timeout_ms));
  const auto give_up = Clock::now() + std::chrono::milliseconds(options_.reply_timeout_ms);
  while (Clock::now() < give_up) {
    const auto line = NextLine(std::min(give_up, Clock::now() + std::chrono::milliseconds(options_.resync_quiet_ms)));
    if (!line) break;
    Reply reply = ClassifyLine(*line);
    if (reply.type == Reply::Type::kBanner) HandleBoardReset(reply, "READY banner while resynchronising for " + context);
  }
  received_.clear();
  resync_needed_ = false;
}

std::string SerialLightController::Transact(const std::string& command) {
  RequirePort();
  const std::string word = command.substr(0, command.find(' '));
  const std::string context = "command " + Quoted(command);
  std::string last_problem;
  for (int attempt = 1; attempt <= options_.attempts; ++attempt) {
    if (resync_needed_) {
      Resync(context);
    } else {
      CheckForUnsolicitedLines(context);
    }
    port_->Write(command + "\n", Clock::now() + std::chrono::milliseconds(options_.reply_timeout_ms));
    const auto deadline = Clock::now() + std::chrono::milliseconds(options_.reply_timeout_ms);
    bool retry = false;
    while (!retry) {
      const auto line = NextLine(deadline);
      if (!line) {
        last_problem = "no reply within " + std::to_string(options_.reply_timeout_ms) + " ms";
        break;
      }
      Reply reply = ClassifyLine(*line);
      switch (reply.type) {
        case Reply::Type::kBanner:
          HandleBoardReset(reply, "READY banner instead of the reply to " + context);
        case Reply::Type::kOk:
          if (reply.word == word) return reply.rest;
          last_problem = "stale reply " + Quoted(reply.line);  // to an earlier command
          break;
        case Reply::Type::kError:
          if (reply.error_code == protocol::kErrUnknownCommand || reply.error_code == protocol::kErrLineTooLong ||
              reply.error_code == protocol::kErrBadCharacter) {
            // We never send such lines: the line was corrupted on its way.
            last_problem = "reply " + Quoted(reply.line) + " (line noise?)";
            retry = true;
            break;
          }
          throw DeviceError(DeviceErrorKind::kRejected, port_path_,
                            "LED board on " + port_path_ + " rejected " + Quoted(command) + ": " + reply.line);
        case Reply::Type::kNoise:
          last_problem = "unreadable line " + Quoted(reply.line.substr(0, 60));
          break;
      }
    }
    resync_needed_ = true;
  }
  const bool silent = last_problem.rfind("no reply", 0) == 0;
  throw DeviceError(silent ? DeviceErrorKind::kTimeout : DeviceErrorKind::kProtocol, port_path_,
                    "LED board on " + port_path_ + " gave no valid reply to " + Quoted(command) + " in " +
                        std::to_string(options_.attempts) + " attempt(s); last: " + last_problem +
                        (silent ? " (board hung, or a different device on this port?)" : ""));
}

void SerialLightController::LightOnly(int led) {
  if (led < 0 || led >= firmware_.led_count) {
    throw std::out_of_range("LED index " + std::to_string(led) + " is outside [0, " +
                            std::to_string(firmware_.led_count - 1) + "] of the LED board on " + port_path_);
  }
  Transact("ON " + std::to_string(led));
}

void SerialLightController::AllOff() { Transact("OFF"); }

LightStatus SerialLightController::Status() {
  const std::string text = Transact("STATUS");
  std::map<std::string, std::string> fields;
  for (const std::string& word : SplitWords(text)) {
    const size_t equals = word.find('=');
    if (equals != std::string::npos) fields[word.substr(0, equals)] = word.substr(equals + 1);
  }
  const auto field = [&](const char* key) -> std::optional<uint32_t> {
    const auto found = fields.find(key);
    if (found == fields.end()) return std::nullopt;
    return ParseUnsigned(found->second);
  };
  LightStatus status;
  const auto uptime = field("uptime_ms");
  const auto watchdog = field("watchdog_ms");
  const auto trips = field("watchdog_trips");
  const auto led = fields.find("led");
  std::optional<uint32_t> led_index;
  if (led != fields.end() && led->second != "none") led_index = ParseUnsigned(led->second);
  if (!uptime || !watchdog || !trips || led == fields.end() || (led->second != "none" && !led_index) ||
      (led_index && static_cast<int>(*led_index) >= firmware_.led_count)) {
    throw DeviceError(DeviceErrorKind::kProtocol, port_path_,
                      "LED board on " + port_path_ + " sent a STATUS reply scanbench cannot read: " + Quoted(text));
  }
  if (led_index) status.lit_led = static_cast<int>(*led_index);
  status.uptime_ms = *uptime;
  status.watchdog_ms = *watchdog;
  status.watchdog_trips = *trips;

  // A board whose banner got lost still gives itself away by its clock
  // running backwards (unless millis() wrapped, after 49.7 days).
  const auto now = Clock::now();
  if (last_uptime_ms_ && status.uptime_ms < *last_uptime_ms_) {
    const auto elapsed_ms = std::chrono::duration_cast<std::chrono::milliseconds>(now - last_uptime_at_).count();
    const bool could_wrap = static_cast<uint64_t>(*last_uptime_ms_) + static_cast<uint64_t>(elapsed_ms) + 1000 >
                            uint64_t{0xFFFFFFFF};
    if (!could_wrap) {
      ThrowBoardReset("LED board on " + port_path_ + " restarted (its uptime went back from " +
                      std::to_string(*last_uptime_ms_) + " to " + std::to_string(status.uptime_ms) + " ms)");
    }
  }
  last_uptime_ms_ = status.uptime_ms;
  last_uptime_at_ = now;
  return status;
}

LightFirmwareInfo SerialLightController::Version() {
  const std::string text = Transact("VERSION");
  const auto info = ParseFirmwareInfo(SplitWords(text), 0);
  if (!info) {
    throw DeviceError(DeviceErrorKind::kProtocol, port_path_,
                      "LED board on " + port_path_ + " sent a VERSION reply scanbench cannot read: " + Quoted(text));
  }
  return *info;
}

void SerialLightController::SetWatchdog(uint32_t silence_ms) {
  if (silence_ms < protocol::kMinWatchdogMs || silence_ms > protocol::kMaxWatchdogMs) {
    throw std::out_of_range("watchdog " + std::to_string(silence_ms) + " ms for the LED board on " + port_path_ +
                            " is outside [" + std::to_string(protocol::kMinWatchdogMs) + ", " +
                            std::to_string(protocol::kMaxWatchdogMs) + "] ms");
  }
  Transact("WATCHDOG " + std::to_string(silence_ms));
  // Remembered so that a board restart gets it back.
  options_.watchdog_ms = silence_ms;
}

}  // namespace scanbench
