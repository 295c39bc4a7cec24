// scanbench-leds: the Arduino Uno sketch that switches the rig's ten LEDs.
// All protocol logic lives in firmware/protocol (shared with the host's
// tests); this file only wires it to the UART, millis() and the pins.
#include <Arduino.h>
#include <avr/interrupt.h>
#include <avr/sleep.h>

#include "firmware/protocol/led_protocol.h"

namespace {

using scanbench::led_protocol::kBaudRate;
using scanbench::led_protocol::kFirstLedPin;
using scanbench::led_protocol::kLedCount;
using scanbench::led_protocol::kReplyCapacity;
using scanbench::led_protocol::LedBoard;

// Active high: a pin at HIGH switches its LED driver on. During reset and
// the bootloader the pins float, so the drivers need pull-downs (README).
void WriteLedPin(uint8_t led, bool on, void* /*context*/) {
  digitalWrite(kFirstLedPin + led, on ? HIGH : LOW);
}

LedBoard board(WriteLedPin, nullptr);
char reply[kReplyCapacity];

}  // namespace

void setup() {
  // LOW before OUTPUT, so that no pin ever drives HIGH on its way out of
  // reset.
  for (uint8_t led = 0; led < kLedCount; ++led) {
    digitalWrite(kFirstLedPin + led, LOW);
    pinMode(kFirstLedPin + led, OUTPUT);
  }
  Serial.begin(kBaudRate);
  board.Start(millis());
  Serial.write(reinterpret_cast<const uint8_t*>(reply), LedBoard::WriteBanner(reply, sizeof(reply)));
}

void loop() {
  while (Serial.available() > 0) {
    const char received = static_cast<char>(Serial.read());
    const uint8_t length = board.ReceiveByte(received, millis(), reply, sizeof(reply));
    if (length > 0) Serial.write(reinterpret_cast<const uint8_t*>(reply), length);
  }
  board.CheckWatchdog(millis());

  // Idle until the next interrupt: a received byte, or timer0's tick every
  // 1.024 ms that keeps millis() and so the watchdog going. Saves power on
  // the bench and lets simavr skip the idle cycles. Interrupts stay off
  // between the check and the sleep (sei takes effect after the next
  // instruction), so a byte arriving in between still wakes us.
  set_sleep_mode(SLEEP_MODE_IDLE);
  cli();
  if (Serial.available() == 0) {
    sleep_enable();
    sei();
    sleep_cpu();
    sleep_disable();
  }
  sei();
}
