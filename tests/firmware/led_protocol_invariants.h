// What must hold for any byte stream the LED board receives: shared by the
// deterministic random test (GoogleTest, runs in ctest) and the libFuzzer
// target (clang), so both check the same rules.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "firmware/protocol/led_protocol.h"

namespace scanbench::led_protocol_test {

namespace protocol = scanbench::led_protocol;

struct PinTracker {
  bool on[protocol::kLedCount] = {};
  int most_on_at_once = 0;
};

inline void TrackPin(uint8_t led, bool on, void* context) {
  auto* pins = static_cast<PinTracker*>(context);
  pins->on[led] = on;
  int count = 0;
  for (bool lit : pins->on) count += lit ? 1 : 0;
  if (count > pins->most_on_at_once) pins->most_on_at_once = count;
}

// Lines the board must answer: segments between CR/LF with at least one byte.
inline size_t CountNonEmptyLines(const uint8_t* data, size_t size) {
  size_t lines = 0;
  bool in_line = false;
  for (size_t i = 0; i < size; ++i) {
    if (data[i] == '\r' || data[i] == '\n') {
      if (in_line) ++lines;
      in_line = false;
    } else {
      in_line = true;
    }
  }
  return lines;
}

inline std::string CheckReply(const std::string& reply) {
  if (reply.size() < 2 || reply.compare(reply.size() - 2, 2, "\r\n") != 0) return "reply without CR LF: " + reply;
  if (reply.size() >= protocol::kReplyCapacity) return "reply too long: " + reply;
  if (reply.rfind("OK ", 0) != 0 && reply.rfind("ERR ", 0) != 0) return "reply neither OK nor ERR: " + reply;
  for (size_t i = 0; i + 2 < reply.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(reply[i]);
    if (c < 0x20 || c > 0x7E) return "non-printable byte in reply: " + reply;
  }
  return "";
}

// Feeds `data` to a fresh board, one byte per millisecond with the watchdog
// checked after each, then "\nSTATUS\n". Returns the first rule broken, or
// "" when all hold:
//  - exactly one reply per non-empty line, each well formed;
//  - never two LEDs on at once, and the board's idea of the lit LED matches
//    the pins; "OK ON n" leaves LED n lit, "OK OFF" none;
//  - whatever came before, "STATUS" after a newline is answered OK (sync).
inline std::string CheckProtocolInvariants(const uint8_t* data, size_t size) {
  PinTracker pins;
  protocol::LedBoard board(&TrackPin, &pins);
  uint32_t now_ms = 4000000000u;  // near the millis() wrap, so that it is crossed too
  board.Start(now_ms);
  std::vector<std::string> replies;
  char reply[protocol::kReplyCapacity];

  const auto feed = [&](uint8_t byte) -> std::string {
    ++now_ms;
    const uint8_t length = board.ReceiveByte(static_cast<char>(byte), now_ms, reply, sizeof(reply));
    if (length > 0) {
      if (reply[length] != '\0') return "reply not NUL-terminated";
      const std::string text(reply, length);
      if (std::string problem = CheckReply(text); !problem.empty()) return problem;
      replies.push_back(text);
      if (text.rfind("OK ON ", 0) == 0) {
        const int led = std::stoi(text.substr(6));
        if (led < 0 || led >= protocol::kLedCount || !pins.on[led]) return "OK ON without its LED lit: " + text;
      }
      if (text == "OK OFF\r\n") {
        for (bool lit : pins.on) {
          if (lit) return "OK OFF with an LED still lit";
        }
      }
    }
    board.CheckWatchdog(now_ms);
    if (pins.most_on_at_once > 1) return "two LEDs lit at once";
    const int8_t lit = board.lit_led();
    for (int led = 0; led < protocol::kLedCount; ++led) {
      if (pins.on[led] != (led == lit)) return "lit_led() disagrees with the pins";
    }
    return "";
  };

  for (size_t i = 0; i < size; ++i) {
    if (std::string problem = feed(data[i]); !problem.empty()) return problem;
  }
  const size_t expected = CountNonEmptyLines(data, size);
  if (replies.size() != expected) {
    return "expected " + std::to_string(expected) + " replies, got " + std::to_string(replies.size());
  }

  const size_t before_sync = replies.size();
  for (char byte : std::string("\nSTATUS\n")) {
    if (std::string problem = feed(static_cast<uint8_t>(byte)); !problem.empty()) return problem;
  }
  if (replies.size() < before_sync + 1 || replies.size() > before_sync + 2) return "sync: wrong reply count";
  if (replies.back().rfind("OK STATUS ", 0) != 0) return "sync not regained: " + replies.back();
  return "";
}

}  // namespace scanbench::led_protocol_test
