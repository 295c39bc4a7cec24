#include "app/devices/simulated_led_board.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/inotify.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cerrno>
#include <condition_variable>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <thread>

extern "C" {
#include <avr_extint.h>
#include <avr_ioport.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_io.h>
}

#ifndef SCANBENCH_FIRMWARE_ELF_PATH
#define SCANBENCH_FIRMWARE_ELF_PATH ""
#endif

namespace scanbench {

namespace fs = std::filesystem;
using WallClock = std::chrono::steady_clock;

namespace {

// AVR time between two looks at the pty and the clock: 0.2 ms, short
// against the 5.5 ms that the UART's 64-byte FIFO holds at 115200 baud.
constexpr avr_cycle_count_t kSlicesPerSecond = 5000;
// Simulated time may run this far ahead of the wall clock before the
// thread sleeps, and this far behind before it gives up catching up.
constexpr auto kMaxLead = std::chrono::microseconds(500);
constexpr auto kMaxLag = std::chrono::milliseconds(20);
// Longest sleep: how late a stopped CPU, or a host opening the port,
// is noticed.
constexpr auto kStoppedPollInterval = std::chrono::milliseconds(2);

// simavr's own idle handler sleeps in usleep(); the pacing here does that job.
void SkipIdleCycles(avr_t* /*avr*/, avr_cycle_count_t /*cycles*/) {}

// INT0/INT1 sit on D2/D3, two LED pins. simavr's default for them polls the
// pin every cycle while it is low (level-triggered mode, even with the
// interrupt masked), which makes an idle board cost a full host core. The
// firmware uses no external interrupts: edge semantics are as good. Reset
// turns the polling back on, so this follows every avr_reset().
void DisableLevelInterruptPolling(avr_t* avr) {
  avr_extint_set_strict_lvl_trig(avr, 0, 0);
  avr_extint_set_strict_lvl_trig(avr, 1, 0);
}

// simavr logs through one process-wide function; keep its errors, drop the
// chatter (it would otherwise print every ELF section it loads).
void SimavrLogger(avr_t* /*avr*/, const int level, const char* format, va_list arguments) {
  if (level > LOG_ERROR) return;
  std::fputs("simavr: ", stderr);
  std::vfprintf(stderr, format, arguments);
}

void InstallSimavrLogger() {
  static std::once_flag once;
  std::call_once(once, [] { avr_global_logger_set(&SimavrLogger); });
}

std::string SystemError(const std::string& what) { return what + ": " + std::strerror(errno); }

struct PinLocation {
  char port;    // 'B', 'C' or 'D'
  uint8_t bit;  // 0..7
};

// Arduino Uno ("standard" variant): D0-D7 on PORTD, D8-D13 on PORTB, A0-A5
// (D14-D19) on PORTC.
PinLocation ArduinoPinLocation(int pin) {
  if (pin < 8) return {'D', static_cast<uint8_t>(pin)};
  if (pin < 14) return {'B', static_cast<uint8_t>(pin - 8)};
  return {'C', static_cast<uint8_t>(pin - 14)};
}

void CheckField(bool ok, const std::string& field, const std::string& value, const std::string& rule) {
  if (!ok) throw std::invalid_argument("SimulatedLedBoardOptions." + field + " = " + value + ": " + rule);
}

}  // namespace

fs::path DefaultFirmwareElfPath() {
  if (const char* from_environment = std::getenv("SCANBENCH_FIRMWARE_ELF");
      from_environment != nullptr && *from_environment != '\0') {
    return from_environment;
  }
  return SCANBENCH_FIRMWARE_ELF_PATH;
}

void SimulatedLedBoardOptions::Check() const {
  CheckField(!mcu.empty(), "mcu", "\"\"", "must name a simavr part (atmega328p)");
  CheckField(cpu_frequency_hz >= 1000000 && cpu_frequency_hz <= 32000000, "cpu_frequency_hz",
             std::to_string(cpu_frequency_hz), "must be in [1000000, 32000000]");
  CheckField(speed > 0 && speed <= 100, "speed", std::to_string(speed), "must be in (0, 100]");
  CheckField(first_led_pin >= 2 && first_led_pin <= 19, "first_led_pin", std::to_string(first_led_pin),
             "must be in [2, 19] (D0/D1 carry the serial line)");
  CheckField(led_count >= 1 && led_count <= 18, "led_count", std::to_string(led_count), "must be in [1, 18]");
  CheckField(first_led_pin + led_count - 1 <= 19, "led_count", std::to_string(led_count),
             "first_led_pin + led_count - 1 must be <= 19 (A5, the Uno's last pin)");
}

class SimulatedLedBoard::Impl {
 public:
  explicit Impl(SimulatedLedBoardOptions options);
  ~Impl() { Stop(); }

  void Stop();
  void Reset();
  void Inject(std::string_view bytes, bool to_board);
  bool WaitForLit(LedMask mask, std::chrono::milliseconds timeout) const;
  void SetObserver(LedObserver observer) {
    std::lock_guard lock(mutex_);
    observer_ = std::move(observer);
  }
  std::string failure() const {
    std::lock_guard lock(mutex_);
    return failure_;
  }

  SimulatedLedBoardOptions options_;
  std::string port_path_;
  std::atomic<LedMask> lit_{0};
  std::atomic<int> max_lit_{0};
  std::atomic<int> reset_count_{0};
  std::atomic<bool> running_{false};
  std::atomic<bool> host_connected_{false};
  std::atomic<uint64_t> cycles_{0};

 private:
  void CreatePty();
  void LoadFirmware();
  void Run();
  void TakeRequests();
  void ServicePty();
  void HostOpened();
  void HostClosed();
  void FeedUart();
  // How far simulated time is ahead of the wall clock (negative: behind).
  std::chrono::nanoseconds SimulationLead();
  void WaitForWork(std::chrono::nanoseconds wait);
  void DoReset();
  void UpdateLeds();
  void Wake() const;

  static void OnUartOutput(avr_irq_t* /*irq*/, uint32_t value, void* param) {
    static_cast<Impl*>(param)->to_host_.push_back(static_cast<char>(value & 0xFF));
  }
  static void OnUartXoff(avr_irq_t* /*irq*/, uint32_t value, void* param) {
    static_cast<Impl*>(param)->uart_xoff_ = value != 0;
  }
  static void OnPortRegister(avr_irq_t* /*irq*/, uint32_t /*value*/, void* param) {
    // DDR writes are announced before the register changes, so the pins are
    // read back once the instruction has finished.
    static_cast<Impl*>(param)->pins_dirty_ = true;
  }

  std::vector<PinLocation> led_pins_;
  int master_fd_ = -1;
  int wake_fd_ = -1;
  int open_watch_fd_ = -1;  // inotify on the pty's slave side; -1: fall back to polling for hang-ups
  avr_t* avr_ = nullptr;
  avr_irq_t* uart_input_ = nullptr;
  std::thread thread_;

  // Simulation thread only.
  std::deque<char> to_board_;
  std::string to_host_;
  bool uart_xoff_ = false;
  bool pins_dirty_ = true;
  bool connected_ = false;
  int host_opens_ = 0;  // file descriptors the host side has open on the slave
  WallClock::time_point wall_start_;
  avr_cycle_count_t cycle_start_ = 0;

  // Requests from other threads.
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> reset_requested_{false};
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;  // lit LEDs, resets, running
  std::string noise_to_board_;
  std::string noise_to_host_;
  LedObserver observer_;
  std::string failure_;
};

SimulatedLedBoard::Impl::Impl(SimulatedLedBoardOptions options) : options_(std::move(options)) {
  options_.Check();
  if (options_.firmware_elf.empty()) options_.firmware_elf = DefaultFirmwareElfPath();
  for (int led = 0; led < options_.led_count; ++led) {
    led_pins_.push_back(ArduinoPinLocation(options_.first_led_pin + led));
  }
  InstallSimavrLogger();
  try {
    LoadFirmware();
    CreatePty();
    wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (wake_fd_ < 0) throw std::runtime_error(SystemError("simulated LED board: eventfd"));
    // Every open and close of the port, in order, however quickly they
    // follow each other (a close and reopen between two polls would be
    // missed by watching for hang-ups alone). Without inotify (instance
    // limit reached) the hang-up polling below still works, just coarser.
    open_watch_fd_ = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (open_watch_fd_ >= 0 && ::inotify_add_watch(open_watch_fd_, port_path_.c_str(), IN_OPEN | IN_CLOSE) < 0) {
      ::close(open_watch_fd_);
      open_watch_fd_ = -1;
    }
  } catch (...) {
    if (avr_) {
      avr_terminate(avr_);
      std::free(avr_);
      avr_ = nullptr;
    }
    if (master_fd_ >= 0) ::close(master_fd_);
    throw;
  }
  running_ = true;
  thread_ = std::thread([this] { Run(); });
}

void SimulatedLedBoard::Impl::LoadFirmware() {
  const fs::path& elf = options_.firmware_elf;
  if (elf.empty()) {
    throw std::runtime_error(
        "simulated LED board: no firmware ELF known: build the scanbench_leds target or set SCANBENCH_FIRMWARE_ELF");
  }
  std::error_code error;
  if (!fs::is_regular_file(elf, error)) {
    throw std::runtime_error("simulated LED board: firmware ELF " + elf.string() +
                             " does not exist: build it (cmake --build <build> --target scanbench_leds) "
                             "or point SCANBENCH_FIRMWARE_ELF at one");
  }
  auto firmware = std::make_unique<elf_firmware_t>();
  if (elf_read_firmware(elf.c_str(), firmware.get()) != 0) {
    throw std::runtime_error("simulated LED board: simavr cannot load " + elf.string() + " as an AVR ELF");
  }
  avr_ = avr_make_mcu_by_name(options_.mcu.c_str());
  if (!avr_) {
    std::free(firmware->flash);
    throw std::runtime_error("simulated LED board: simavr has no part named '" + options_.mcu + "'");
  }
  avr_init(avr_);
  avr_->sleep = &SkipIdleCycles;
  DisableLevelInterruptPolling(avr_);
  // Our ELF has no .mmcu section telling simavr the clock: set it here.
  firmware->frequency = options_.cpu_frequency_hz;
  avr_->frequency = options_.cpu_frequency_hz;
  avr_load_firmware(avr_, firmware.get());
  // simavr copies flash and EEPROM contents and leaves the buffers to us.
  std::free(firmware->flash);
  std::free(firmware->eeprom);
  // Symbols are kept only by a tracing build of simavr (trace_data).
  if (avr_->trace_data == nullptr && firmware->symbol != nullptr) {
    for (uint32_t i = 0; i < firmware->symbolcount; ++i) std::free(firmware->symbol[i]);
    std::free(firmware->symbol);
  }

  // No console echo of the UART, no sleeping when the firmware polls it.
  uint32_t uart_flags = 0;
  avr_ioctl(avr_, AVR_IOCTL_UART_SET_FLAGS('0'), &uart_flags);
  uart_input_ = avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), &Impl::OnUartOutput,
                          this);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), &Impl::OnUartXoff,
                          this);
  for (char port : {'B', 'C', 'D'}) {
    avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(port), IOPORT_IRQ_REG_PORT),
                            &Impl::OnPortRegister, this);
    avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(port), IOPORT_IRQ_DIRECTION_ALL),
                            &Impl::OnPortRegister, this);
  }
}

void SimulatedLedBoard::Impl::CreatePty() {
  // Our own pty rather than simavr's uart_pty part, which signals the whole
  // process on stop and links a fixed /tmp name that parallel tests share.
  master_fd_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (master_fd_ < 0) throw std::runtime_error(SystemError("simulated LED board: posix_openpt"));
  char name[128];
  if (::grantpt(master_fd_) != 0 || ::unlockpt(master_fd_) != 0 || ::ptsname_r(master_fd_, name, sizeof(name)) != 0) {
    throw std::runtime_error(SystemError("simulated LED board: cannot set up the pty"));
  }
  port_path_ = name;
  // Raw from the start, so that nothing the board sends before the host
  // configures the line is echoed back to it. The pty keeps the settings
  // while its master is open.
  const int slave = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (slave < 0) throw std::runtime_error(SystemError("simulated LED board: cannot open " + port_path_));
  termios settings{};
  ::tcgetattr(slave, &settings);
  ::cfmakeraw(&settings);
  ::cfsetispeed(&settings, B115200);
  ::cfsetospeed(&settings, B115200);
  ::tcsetattr(slave, TCSANOW, &settings);
  ::close(slave);  // from now on the master sees a hang-up until the host opens it
  if (::fcntl(master_fd_, F_SETFL, ::fcntl(master_fd_, F_GETFL) | O_NONBLOCK) != 0) {
    throw std::runtime_error(SystemError("simulated LED board: fcntl on the pty"));
  }
}

void SimulatedLedBoard::Impl::Wake() const {
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t written = ::write(wake_fd_, &one, sizeof(one));
}

void SimulatedLedBoard::Impl::Stop() {
  if (thread_.joinable()) {
    stop_requested_ = true;
    Wake();
    thread_.join();
  }
  running_ = false;
  changed_.notify_all();
  if (avr_) {
    avr_terminate(avr_);
    std::free(avr_);
    avr_ = nullptr;
  }
  if (master_fd_ >= 0) ::close(master_fd_);  // the pty disappears; the host reads a hang-up
  if (wake_fd_ >= 0) ::close(wake_fd_);
  if (open_watch_fd_ >= 0) ::close(open_watch_fd_);
  master_fd_ = wake_fd_ = open_watch_fd_ = -1;
  host_connected_ = false;
}

void SimulatedLedBoard::Impl::Reset() {
  std::unique_lock lock(mutex_);
  if (!running_) throw std::runtime_error("simulated LED board on " + port_path_ + ": Reset() while not running");
  const int before = reset_count_;
  reset_requested_ = true;
  Wake();
  if (!changed_.wait_for(lock, std::chrono::seconds(5), [&] { return reset_count_ > before || !running_; }) ||
      !running_) {
    throw std::runtime_error("simulated LED board on " + port_path_ + ": the simulation did not restart the CPU");
  }
}

void SimulatedLedBoard::Impl::Inject(std::string_view bytes, bool to_board) {
  {
    std::lock_guard lock(mutex_);
    (to_board ? noise_to_board_ : noise_to_host_).append(bytes);
  }
  Wake();
}

bool SimulatedLedBoard::Impl::WaitForLit(LedMask mask, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] { return lit_.load() == mask; });
}

void SimulatedLedBoard::Impl::Run() {
  wall_start_ = WallClock::now();
  cycle_start_ = avr_->cycle;
  const avr_cycle_count_t cycles_per_slice = options_.cpu_frequency_hz / kSlicesPerSecond;
  while (!stop_requested_) {
    TakeRequests();
    ServicePty();
    FeedUart();
    const bool cpu_running = avr_->state == cpu_Running || avr_->state == cpu_Sleeping;
    const auto lead = cpu_running ? SimulationLead() : std::chrono::nanoseconds(kStoppedPollInterval);
    if (lead >= kMaxLead) {
      WaitForWork(lead);
      continue;
    }
    // One slice of AVR time. A sleeping CPU jumps to its next timer event,
    // so the slice is bounded by cycles, not instructions.
    const avr_cycle_count_t slice_end = avr_->cycle + cycles_per_slice;
    while (avr_->cycle < slice_end) {
      const int state = avr_run(avr_);
      if (pins_dirty_) UpdateLeds();
      if (state == cpu_Done || state == cpu_Crashed) {
        char message[160];
        std::snprintf(message, sizeof(message), "firmware %s at pc 0x%05x (simavr stopped the CPU)",
                      state == cpu_Crashed ? "crashed" : "stopped (sleep with interrupts off)",
                      static_cast<unsigned>(avr_->pc));
        std::lock_guard lock(mutex_);
        failure_ = message;
        break;
      }
    }
    cycles_ = avr_->cycle;
  }
}

void SimulatedLedBoard::Impl::TakeRequests() {
  if (reset_requested_.exchange(false)) DoReset();
  std::lock_guard lock(mutex_);
  to_board_.insert(to_board_.end(), noise_to_board_.begin(), noise_to_board_.end());
  to_host_ += noise_to_host_;
  noise_to_board_.clear();
  noise_to_host_.clear();
}

void SimulatedLedBoard::Impl::DoReset() {
  avr_reset(avr_);
  DisableLevelInterruptPolling(avr_);
  // Bytes in flight are lost in a reset, on the real board too.
  to_board_.clear();
  to_host_.clear();
  uart_xoff_ = false;
  pins_dirty_ = true;
  UpdateLeds();
  {
    std::lock_guard lock(mutex_);
    failure_.clear();
    max_lit_ = 0;
    ++reset_count_;
  }
  changed_.notify_all();
}

void SimulatedLedBoard::Impl::UpdateLeds() {
  pins_dirty_ = false;
  uint8_t port_value[3] = {0, 0, 0};  // B, C, D: bits driven high as outputs
  for (int i = 0; i < 3; ++i) {
    avr_ioport_state_t state{};
    if (avr_ioctl(avr_, AVR_IOCTL_IOPORT_GETSTATE('B' + i), &state) == 0) {
      port_value[i] = static_cast<uint8_t>(state.port & state.ddr);
    }
  }
  LedMask lit = 0;
  for (size_t led = 0; led < led_pins_.size(); ++led) {
    const PinLocation& pin = led_pins_[led];
    if ((port_value[pin.port - 'B'] >> pin.bit) & 1u) lit |= LedMask{1} << led;
  }
  if (lit == lit_.load()) return;
  LedObserver observer;
  {
    std::lock_guard lock(mutex_);
    lit_ = lit;
    max_lit_ = std::max(max_lit_.load(), std::popcount(lit));
    observer = observer_;
  }
  changed_.notify_all();
  if (observer) observer(lit, static_cast<double>(avr_->cycle) / options_.cpu_frequency_hz);
}

void SimulatedLedBoard::Impl::HostOpened() {
  // Only the first open raises DTR; a second program opening the port
  // (and failing on the lock) leaves the board alone, as on an Uno.
  if (!connected_) {
    connected_ = true;
    host_connected_ = true;
    // DTR's capacitor pulses RESET on an Uno.
    if (options_.reset_on_open) DoReset();
    changed_.notify_all();
  }
}

void SimulatedLedBoard::Impl::HostClosed() {
  if (connected_) {
    connected_ = false;
    host_connected_ = false;
    changed_.notify_all();
  }
}

void SimulatedLedBoard::Impl::ServicePty() {
  if (open_watch_fd_ >= 0) {
    alignas(inotify_event) char events[1024];
    ssize_t count;
    while ((count = ::read(open_watch_fd_, events, sizeof(events))) > 0) {
      for (char* at = events; at < events + count;) {
        const auto* event = reinterpret_cast<const inotify_event*>(at);
        if (event->mask & IN_OPEN) {
          if (host_opens_++ == 0) HostOpened();
        } else if (event->mask & IN_CLOSE) {
          if (host_opens_ > 0 && --host_opens_ == 0) HostClosed();
        }
        at += sizeof(inotify_event) + event->len;
      }
    }
  }
  pollfd poll_master{master_fd_, static_cast<short>(POLLIN | (to_host_.empty() ? 0 : POLLOUT)), 0};
  if (::poll(&poll_master, 1, 0) < 0) return;
  const bool hung_up = (poll_master.revents & POLLHUP) != 0;
  if (open_watch_fd_ < 0) {
    if (!hung_up) HostOpened();
    if (hung_up) HostClosed();
  }
  if (!connected_ || hung_up) {
    // Nobody listens: what the board sends is lost, as on a real line.
    to_host_.clear();
    return;
  }
  if (poll_master.revents & POLLIN) {
    char buffer[1024];
    const ssize_t count = ::read(master_fd_, buffer, sizeof(buffer));
    if (count > 0) to_board_.insert(to_board_.end(), buffer, buffer + count);
  }
  if (!to_host_.empty()) {
    const ssize_t written = ::write(master_fd_, to_host_.data(), to_host_.size());
    if (written > 0) to_host_.erase(0, static_cast<size_t>(written));
  }
}

void SimulatedLedBoard::Impl::FeedUart() {
  // The UART's FIFO paces reception at the baud rate and raises XOFF when
  // full; bytes wait here until it has room again.
  while (!to_board_.empty() && !uart_xoff_) {
    avr_raise_irq(uart_input_, static_cast<uint8_t>(to_board_.front()));
    to_board_.pop_front();
  }
}

std::chrono::nanoseconds SimulatedLedBoard::Impl::SimulationLead() {
  const double simulated_ns =
      static_cast<double>(avr_->cycle - cycle_start_) * 1e9 / options_.cpu_frequency_hz / options_.speed;
  const auto due = wall_start_ + std::chrono::nanoseconds(static_cast<int64_t>(simulated_ns));
  const auto now = WallClock::now();
  if (due < now - kMaxLag) {
    // Fell behind (host busy): carry on from here rather than racing to catch up.
    wall_start_ += (now - kMaxLag) - due;
  }
  return due - now;
}

void SimulatedLedBoard::Impl::WaitForWork(std::chrono::nanoseconds wait) {
  wait = std::min<std::chrono::nanoseconds>(wait, kStoppedPollInterval);
  pollfd fds[3] = {{wake_fd_, POLLIN, 0}, {open_watch_fd_, POLLIN, 0}, {master_fd_, POLLIN, 0}};
  // A hung-up master would report POLLHUP at once: leave it out then (the
  // open watch, or the next poll interval, notices the host coming).
  const nfds_t count = connected_ ? 3 : 2;
  const timespec timeout{static_cast<time_t>(wait.count() / 1000000000), static_cast<long>(wait.count() % 1000000000)};
  if (::ppoll(fds, count, &timeout, nullptr) > 0 && (fds[0].revents & POLLIN)) {
    uint64_t drained = 0;
    [[maybe_unused]] const ssize_t read_count = ::read(wake_fd_, &drained, sizeof(drained));
  }
}

SimulatedLedBoard::SimulatedLedBoard(SimulatedLedBoardOptions options)
    : impl_(std::make_unique<Impl>(std::move(options))) {}

SimulatedLedBoard::~SimulatedLedBoard() = default;

const std::string& SimulatedLedBoard::port_path() const { return impl_->port_path_; }
int SimulatedLedBoard::led_count() const { return impl_->options_.led_count; }
SimulatedLedBoard::LedMask SimulatedLedBoard::lit_leds() const { return impl_->lit_; }

std::vector<int> SimulatedLedBoard::LitLedIndices() const {
  std::vector<int> indices;
  const LedMask lit = impl_->lit_;
  for (int led = 0; led < led_count(); ++led) {
    if ((lit >> led) & 1u) indices.push_back(led);
  }
  return indices;
}

std::optional<int> SimulatedLedBoard::SingleLitLed() const {
  const std::vector<int> lit = LitLedIndices();
  return lit.size() == 1 ? std::optional<int>(lit.front()) : std::nullopt;
}

bool SimulatedLedBoard::WaitForLitLeds(LedMask mask, std::chrono::milliseconds timeout) const {
  return impl_->WaitForLit(mask, timeout);
}

int SimulatedLedBoard::max_lit_at_once() const { return impl_->max_lit_; }
void SimulatedLedBoard::SetLedObserver(LedObserver observer) { impl_->SetObserver(std::move(observer)); }
void SimulatedLedBoard::Reset() { impl_->Reset(); }
int SimulatedLedBoard::reset_count() const { return impl_->reset_count_; }
bool SimulatedLedBoard::host_connected() const { return impl_->host_connected_; }

double SimulatedLedBoard::simulated_seconds() const {
  return static_cast<double>(impl_->cycles_.load()) / impl_->options_.cpu_frequency_hz;
}

void SimulatedLedBoard::InjectNoiseToBoard(std::string_view bytes) { impl_->Inject(bytes, true); }
void SimulatedLedBoard::InjectNoiseToHost(std::string_view bytes) { impl_->Inject(bytes, false); }
void SimulatedLedBoard::Stop() { impl_->Stop(); }
bool SimulatedLedBoard::running() const { return impl_->running_; }
std::string SimulatedLedBoard::failure() const { return impl_->failure(); }

}  // namespace scanbench
