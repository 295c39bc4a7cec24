// The serial ports of this machine, and which of them look like an Arduino
// board (by USB vendor and product id), for `scanbench devices` and for
// picking the LED board's port. Enumeration only: opening goes through
// SerialPort, which also handles pseudo-terminals.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace scanbench {

struct SerialPortInfo {
  std::string path;               // "/dev/ttyACM0"
  std::string description;        // the system's one-line description
  std::string transport;          // "usb", "native" or "bluetooth"
  std::optional<uint16_t> usb_vendor_id;   // USB ports only
  std::optional<uint16_t> usb_product_id;  // USB ports only
  std::string usb_manufacturer;   // "" when unknown
  std::string usb_product;        // "" when unknown
  std::string usb_serial_number;  // "" when unknown
  std::string board;              // recognised board ("Arduino Uno"), "" when not recognised
};

// Every serial port the system knows, sorted by path. Throws
// std::runtime_error with libserialport's message if listing fails.
std::vector<SerialPortInfo> ListSerialPorts();

// What the operator can do when FindArduinoPort finds no board or several, in
// the words of the front end that asks: the command line names its options
// (`led` has --simulated, `capture` --rig sim), the GUI its controls.
struct BoardChoiceHints {
  std::string name_port = "choose its serial port";           // "name its port with --port"
  std::string use_simulated = "use the simulated LED board";  // "use --simulated"
};

// The one serial port that looks like an Arduino board; throws
// std::runtime_error listing the candidates when there is none or more than
// one (the user then names the port, as `hints` say).
std::string FindArduinoPort(const BoardChoiceHints& hints = {});

// "Arduino Uno" for 2341:0043 etc.; clones' USB-serial chips (CH340, FTDI,
// CP210x) are named as such ("USB-serial CH340 (Arduino clone?)"); "" when
// the ids mean nothing to us.
std::string RecogniseBoard(uint16_t usb_vendor_id, uint16_t usb_product_id);

// "2341:0043": lower-case hex, as lsusb prints it.
std::string FormatUsbId(uint16_t vendor_id, uint16_t product_id);

}  // namespace scanbench
