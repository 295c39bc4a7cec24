#include "app/devices/serial_port_list.h"

#include <libserialport.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <stdexcept>

namespace scanbench {

namespace {

struct KnownBoard {
  uint16_t vendor_id;
  uint16_t product_id;
  const char* name;
};

// From the Arduino AVR core's boards.txt (Uno, Mega, Leonardo) and the
// USB-serial chips that clone boards carry instead of the 16U2.
constexpr KnownBoard kKnownBoards[] = {
    {0x2341, 0x0043, "Arduino Uno"},
    {0x2341, 0x0001, "Arduino Uno"},
    {0x2A03, 0x0043, "Arduino Uno"},
    {0x2341, 0x0243, "Arduino Uno"},
    {0x2341, 0x006A, "Arduino Uno"},
    {0x2341, 0x0010, "Arduino Mega 2560"},
    {0x2341, 0x0042, "Arduino Mega 2560"},
    {0x2A03, 0x0010, "Arduino Mega 2560"},
    {0x2A03, 0x0042, "Arduino Mega 2560"},
    {0x2341, 0x0036, "Arduino Leonardo (bootloader)"},
    {0x2341, 0x8036, "Arduino Leonardo"},
    {0x1A86, 0x7523, "USB-serial CH340 (Arduino clone?)"},
    {0x0403, 0x6001, "USB-serial FTDI FT232R (Arduino Nano/Duemilanove or clone?)"},
    {0x10C4, 0xEA60, "USB-serial CP210x (Arduino clone?)"},
};

std::string OrEmpty(const char* text) { return text ? text : ""; }

std::string TransportName(sp_transport transport) {
  switch (transport) {
    case SP_TRANSPORT_USB:
      return "usb";
    case SP_TRANSPORT_BLUETOOTH:
      return "bluetooth";
    case SP_TRANSPORT_NATIVE:
      break;
  }
  return "native";
}

}  // namespace

std::string FormatUsbId(uint16_t vendor_id, uint16_t product_id) {
  char text[10];
  std::snprintf(text, sizeof(text), "%04x:%04x", vendor_id, product_id);
  return text;
}

std::string RecogniseBoard(uint16_t usb_vendor_id, uint16_t usb_product_id) {
  for (const KnownBoard& board : kKnownBoards) {
    if (board.vendor_id == usb_vendor_id && board.product_id == usb_product_id) return board.name;
  }
  // Arduino's two vendor ids: some board we do not list by product.
  if (usb_vendor_id == 0x2341 || usb_vendor_id == 0x2A03) return "Arduino (unknown model)";
  return "";
}

std::vector<SerialPortInfo> ListSerialPorts() {
  sp_port** raw_list = nullptr;
  if (sp_list_ports(&raw_list) != SP_OK) {
    char* message = sp_last_error_message();
    const std::string text = OrEmpty(message);
    sp_free_error_message(message);
    throw std::runtime_error("cannot list serial ports (libserialport): " + text);
  }
  const std::unique_ptr<sp_port*, decltype(&sp_free_port_list)> list(raw_list, &sp_free_port_list);

  std::vector<SerialPortInfo> ports;
  for (sp_port** entry = list.get(); *entry != nullptr; ++entry) {
    const sp_port* port = *entry;
    SerialPortInfo info;
    info.path = OrEmpty(sp_get_port_name(port));
    info.description = OrEmpty(sp_get_port_description(port));
    const sp_transport transport = sp_get_port_transport(port);
    info.transport = TransportName(transport);
    if (transport == SP_TRANSPORT_USB) {
      int vendor_id = 0;
      int product_id = 0;
      if (sp_get_port_usb_vid_pid(port, &vendor_id, &product_id) == SP_OK) {
        info.usb_vendor_id = static_cast<uint16_t>(vendor_id);
        info.usb_product_id = static_cast<uint16_t>(product_id);
        info.board = RecogniseBoard(*info.usb_vendor_id, *info.usb_product_id);
      }
      info.usb_manufacturer = OrEmpty(sp_get_port_usb_manufacturer(port));
      info.usb_product = OrEmpty(sp_get_port_usb_product(port));
      info.usb_serial_number = OrEmpty(sp_get_port_usb_serial(port));
    }
    ports.push_back(std::move(info));
  }
  std::sort(ports.begin(), ports.end(),
            [](const SerialPortInfo& a, const SerialPortInfo& b) { return a.path < b.path; });
  return ports;
}

std::string FindArduinoPort(const BoardChoiceHints& hints) {
  std::vector<SerialPortInfo> boards;
  for (const SerialPortInfo& port : ListSerialPorts()) {
    if (!port.board.empty()) boards.push_back(port);
  }
  if (boards.size() == 1) return boards.front().path;
  if (boards.empty()) {
    throw std::runtime_error(
        "no LED board found: no Arduino among the serial ports (`scanbench devices` lists them). Connect the LED "
        "board, an Arduino Uno flashed with firmware/ (docs/bench.md), to this computer by USB, with its LED "
        "drivers on pins D2..D11 and their supply on; or " +
        hints.name_port + ", or " + hints.use_simulated);
  }
  std::string list;
  for (const SerialPortInfo& port : boards) list += " " + port.path + " (" + port.board + ")";
  throw std::runtime_error("several Arduino-like boards found:" + list + "; " + hints.name_port);
}

}  // namespace scanbench
