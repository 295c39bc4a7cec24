// Serial port listing (libserialport) and recognising Arduino boards by
// their USB ids. The listing is checked against what the machine's sysfs
// holds, and where it holds no port (CI) by what it must leave out.
#include "app/devices/serial_port_list.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "tests/app/devices/fake_serial_board.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

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

// What the listing can see: libserialport lists /dev/<name> for each entry of
// /sys/class/tty whose device link does not lead under "virtual" (terminals,
// consoles, pseudo-terminals), an 8250 UART only where an ioctl finds one
// behind it. The same read of sysfs, written out again: name -> link target.
std::map<std::string, std::string> NonVirtualTtys() {
  std::map<std::string, std::string> ttys;
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator("/sys/class/tty", error)) {
    const fs::path link = fs::is_symlink(entry.path()) ? entry.path() : entry.path() / "device";
    std::error_code unreadable;
    const std::string target = fs::read_symlink(link, unreadable).string();
    if (unreadable || target.find("virtual") != std::string::npos) continue;
    ttys["/dev/" + entry.path().filename().string()] = target;
  }
  return ttys;
}

TEST(ListSerialPorts, ListsTheMachinesSerialPortsSortedWithTheirTransport) {
  const std::vector<SerialPortInfo> ports = ListSerialPorts();
  EXPECT_TRUE(std::is_sorted(ports.begin(), ports.end(),
                             [](const SerialPortInfo& a, const SerialPortInfo& b) { return a.path < b.path; }));
  const std::map<std::string, std::string> ttys = NonVirtualTtys();
  std::set<std::string> listed;
  for (const SerialPortInfo& port : ports) {
    listed.insert(port.path);
    // A tty of sysfs (or a link in /dev to one), its transport where its device sits.
    std::error_code error;
    const std::string device = fs::is_symlink(port.path, error)
                                   ? "/dev/" + fs::canonical(port.path, error).filename().string()
                                   : port.path;
    ASSERT_EQ(ttys.count(device), 1u) << port.path << " is no serial device of /sys/class/tty";
    const std::string& link = ttys.at(device);
    const std::string transport = link.find("bluetooth") != std::string::npos ? "bluetooth"
                                  : link.find("usb") != std::string::npos     ? "usb"
                                                                               : "native";
    EXPECT_EQ(port.transport, transport) << port.path << " (" << link << ")";
    if (port.transport != "usb") {
      EXPECT_FALSE(port.usb_vendor_id.has_value()) << port.path;
      EXPECT_EQ(port.board, "") << port.path;
    } else if (port.usb_vendor_id && port.usb_product_id) {
      EXPECT_EQ(port.board, RecogniseBoard(*port.usb_vendor_id, *port.usb_product_id)) << port.path;
    }
  }
  // Every one it can see but the 8250 UARTs, which it lists only when there is one behind.
  for (const auto& [path, link] : ttys) {
    if (link.find("serial8250") == std::string::npos) {
      EXPECT_EQ(listed.count(path), 1u) << path << " (" << link << ")";
    }
  }
}

TEST(ListSerialPorts, LeavesOutPseudoTerminals) {
  // The simulated LED board's kind of port: a terminal, not a serial port of
  // the machine, so FindArduinoPort can never take one for the board.
  const testing::TestPty pty;
  ASSERT_TRUE(fs::exists(pty.path()));
  for (const SerialPortInfo& port : ListSerialPorts()) {
    EXPECT_NE(port.path, pty.path());
    EXPECT_EQ(port.path.rfind("/dev/pts/", 0), std::string::npos) << port.path;
    EXPECT_NE(port.path, "/dev/ptmx");
    EXPECT_NE(port.path, "/dev/tty");
    EXPECT_NE(port.path, "/dev/console");
  }
}

TEST(FindArduinoPort, TakesTheOneBoardAmongThePortsOrSaysWhatToDo) {
  std::vector<std::string> boards;
  for (const SerialPortInfo& port : ListSerialPorts()) {
    if (!port.board.empty()) boards.push_back(port.path);
  }
  if (boards.size() == 1) {
    EXPECT_EQ(FindArduinoPort(), boards.front());
    return;
  }
  // None (as in CI) or several: the message says what the operator can do.
  try {
    const std::string port = FindArduinoPort();
    ADD_FAILURE() << "took " << port << " among " << boards.size() << " boards";
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    if (boards.empty()) {
      EXPECT_THAT(message, ::testing::HasSubstr("no LED board found"));
      EXPECT_THAT(message, ::testing::HasSubstr("scanbench devices"));
      // The library speaks no front end's options unless asked to (issue #36).
      EXPECT_THAT(message, ::testing::Not(::testing::HasSubstr("--")));
      EXPECT_THAT(message, ::testing::HasSubstr("or choose its serial port, or use the simulated LED board"));
      try {
        FindArduinoPort({"name its port with --port", "use --simulated"});
        ADD_FAILURE() << "found a board";
      } catch (const std::runtime_error& hinted) {
        EXPECT_THAT(hinted.what(), ::testing::HasSubstr("or name its port with --port, or use --simulated"));
      }
    } else {
      EXPECT_THAT(message, ::testing::HasSubstr("several Arduino-like boards found"));
      for (const std::string& board : boards) EXPECT_THAT(message, ::testing::HasSubstr(board));
    }
  }
}

}  // namespace
}  // namespace scanbench
