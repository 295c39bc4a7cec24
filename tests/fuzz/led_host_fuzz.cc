// libFuzzer harness: the host side of the LED board's serial protocol
// (app/devices/serial_light_controller.h). The input is everything the
// "board" sends, written into a pseudo-terminal before the controller opens
// its end: the banner, then the replies to the commands below, in order --
// or noise, restarts, wrong replies. The controller must answer with a reply
// or a DeviceError, never crash or hang. The firmware's own side of the
// protocol is fuzzed by tests/firmware/led_protocol_fuzz.
#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "app/devices/serial_light_controller.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

// A pty whose slave end is raw (so the line discipline passes the bytes as
// they are) and held open, so the controller's open and close do not hang it up.
struct Pty {
  int master = -1;
  int slave = -1;
  std::string slave_path;

  Pty() {
    master = ::posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (master < 0 || ::grantpt(master) != 0 || ::unlockpt(master) != 0) Fail("posix_openpt");
    slave_path = ::ptsname(master);
    slave = ::open(slave_path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (slave < 0) Fail("open the pty's slave");
    termios raw{};
    if (::tcgetattr(slave, &raw) != 0) Fail("tcgetattr");
    ::cfmakeraw(&raw);
    if (::tcsetattr(slave, TCSANOW, &raw) != 0) Fail("tcsetattr");
  }
  ~Pty() {
    ::close(slave);
    ::close(master);
  }
  [[noreturn]] static void Fail(const char* what) {
    std::perror(what);
    std::abort();
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace scanbench;
  // A pty's input queue holds 4 KiB: anything longer would block the write.
  if (size > 2048) return -1;
  Pty pty;
  if (size > 0 && ::write(pty.master, data, size) != static_cast<ssize_t>(size)) Pty::Fail("write to the pty");

  SerialLightControllerOptions options;
  options.banner_timeout_ms = 5;
  options.reply_timeout_ms = 2;
  options.resync_quiet_ms = 1;
  options.reconnect_pause_ms = 0;
  std::unique_ptr<SerialLightController> board;
  fuzz::ExpectOnlyDocumentedErrors([&] { board = std::make_unique<SerialLightController>(pty.slave_path, options); });
  if (!board) return 0;
  if (board->led_count() > 0) fuzz::ExpectOnlyDocumentedErrors([&] { board->LightOnly(0); });
  fuzz::ExpectOnlyDocumentedErrors([&] { board->Status(); });
  fuzz::ExpectOnlyDocumentedErrors([&] { board->Version(); });
  fuzz::ExpectOnlyDocumentedErrors([&] { board->SetWatchdog(1000); });
  fuzz::ExpectOnlyDocumentedErrors([&] { board->AllOff(); });
  fuzz::ExpectOnlyDocumentedErrors([&] { board->Status(); });
  board.reset();  // its destructor switches the LEDs off: one more exchange
  return 0;
}
