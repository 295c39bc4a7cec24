// Serial port listing (libserialport) and recognising Arduino boards by
// their USB ids.
#include "app/devices/serial_port_list.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace scanbench {
namespace {

TEST(RecogniseBoard, KnowsTheUnoInAllItsUsbIds) {
  for (const auto& [vendor, product] : std::vector<std::pair<uint16_t, uint16_t>>{
           {0x2341, 0x0043}, {0x2341, 0x0001}, {0x2A03, 0x0043}, {0x2341, 0x0243}, {0x2341, 0x006A}}) {
    EXPECT_EQ(RecogniseBoard(vendor, product), "Arduino Uno") << FormatUsbId(vendor, product);
  }
}

TEST(RecogniseBoard, NamesClonesAndOtherArduinos) {
  EXPECT_EQ(RecogniseBoard(0x2341, 0x0042), "Arduino Mega 2560");
  EXPECT_EQ(RecogniseBoard(0x2341, 0x1234), "Arduino (unknown model)");
  EXPECT_NE(RecogniseBoard(0x1A86, 0x7523).find("CH340"), std::string::npos);
  EXPECT_NE(RecogniseBoard(0x0403, 0x6001).find("FTDI"), std::string::npos);
}

TEST(RecogniseBoard, IgnoresEverythingElse) {
  EXPECT_EQ(RecogniseBoard(0x046D, 0xC52B), "");  // a Logitech receiver
  EXPECT_EQ(RecogniseBoard(0x04B0, 0x0429), "");  // a Nikon D5100
}

TEST(FormatUsbId, PrintsLikeLsusb) {
  EXPECT_EQ(FormatUsbId(0x2341, 0x0043), "2341:0043");
  EXPECT_EQ(FormatUsbId(0x2A03, 0xABCD), "2a03:abcd");
}

TEST(ListSerialPorts, ListsSortedPortsWithTheirTransport) {
  // The machine decides what is there (CI has no board): only the shape is checked.
  const std::vector<SerialPortInfo> ports = ListSerialPorts();
  EXPECT_TRUE(std::is_sorted(ports.begin(), ports.end(),
                             [](const SerialPortInfo& a, const SerialPortInfo& b) { return a.path < b.path; }));
  for (const SerialPortInfo& port : ports) {
    EXPECT_FALSE(port.path.empty());
    EXPECT_TRUE(port.transport == "usb" || port.transport == "native" || port.transport == "bluetooth");
    if (port.transport != "usb") {
      EXPECT_FALSE(port.usb_vendor_id.has_value());
    }
  }
}

}  // namespace
}  // namespace scanbench
