#include "app/devices/camera/device_discovery.h"

#include <libusb.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "app/devices/camera/gphoto2_support.h"

namespace scanbench {

using namespace gphoto2_support;

namespace {

const char kUsbBus[] = "USB bus";

std::string LibusbError(int code) { return std::string(libusb_error_name(code)) + " (" + std::to_string(code) + ")"; }

// The same devices at the same addresses (what changes on plug and unplug).
bool SameDevices(const std::vector<UsbDeviceInfo>& a, const std::vector<UsbDeviceInfo>& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](const UsbDeviceInfo& x, const UsbDeviceInfo& y) {
    return x.bus == y.bus && x.address == y.address && x.vendor_id == y.vendor_id && x.product_id == y.product_id;
  });
}

}  // namespace

std::string UsbDeviceInfo::UsbId() const {
  char text[16];
  std::snprintf(text, sizeof(text), "%04x:%04x", vendor_id, product_id);
  return text;
}

std::string UsbDeviceInfo::GphotoPort() const {
  char text[32];
  std::snprintf(text, sizeof(text), "usb:%03d,%03d", bus, address);
  return text;
}

std::vector<DetectedCamera> DetectCameras() {
  std::lock_guard<std::mutex> lock(LibraryMutex());
  Context context;
  CameraList* raw_list = nullptr;
  if (const int result = gp_list_new(&raw_list); result < GP_OK) {
    throw ErrorFromResult(result, "libgphoto2", "autodetect", context.TakeText(), Phase::kOpen);
  }
  ListPtr list(raw_list);
  if (const int result = gp_camera_autodetect(list.get(), context.get()); result < GP_OK) {
    throw ErrorFromResult(result, "libgphoto2", "autodetect", context.TakeText(), Phase::kOpen);
  }
  std::vector<DetectedCamera> cameras;
  for (int i = 0; i < gp_list_count(list.get()); ++i) {
    const char* model = nullptr;
    const char* port = nullptr;
    gp_list_get_name(list.get(), i, &model);
    gp_list_get_value(list.get(), i, &port);
    cameras.push_back({model ? model : "", port ? port : ""});
  }
  return cameras;
}

std::vector<UsbDeviceInfo> ListUsbDevices(bool identify_cameras) {
  libusb_context* context = nullptr;
  if (const int result = libusb_init(&context); result < 0) {
    throw CameraError(CameraErrorKind::kIo, kUsbBus, "libusb could not start: " + LibusbError(result));
  }
  libusb_device** list = nullptr;
  const ssize_t count = libusb_get_device_list(context, &list);
  if (count < 0) {
    libusb_exit(context);
    throw CameraError(CameraErrorKind::kIo, kUsbBus,
                      "libusb could not list the devices: " + LibusbError(static_cast<int>(count)));
  }
  std::vector<UsbDeviceInfo> devices;
  for (ssize_t i = 0; i < count; ++i) {
    libusb_device_descriptor descriptor{};
    if (libusb_get_device_descriptor(list[i], &descriptor) != LIBUSB_SUCCESS) continue;
    UsbDeviceInfo device;
    device.bus = libusb_get_bus_number(list[i]);
    device.address = libusb_get_device_address(list[i]);
    device.vendor_id = descriptor.idVendor;
    device.product_id = descriptor.idProduct;
    device.device_class = descriptor.bDeviceClass;
    uint8_t ports[8];
    const int depth = libusb_get_port_numbers(list[i], ports, sizeof(ports));
    if (depth > 0) {
      device.port_path = std::to_string(device.bus) + "-";
      for (int k = 0; k < depth; ++k) {
        if (k > 0) device.port_path += '.';
        device.port_path += std::to_string(ports[k]);
      }
    }
    devices.push_back(std::move(device));
  }
  libusb_free_device_list(list, /*unref_devices=*/1);
  libusb_exit(context);
  std::sort(devices.begin(), devices.end(), [](const UsbDeviceInfo& a, const UsbDeviceInfo& b) {
    return a.bus != b.bus ? a.bus < b.bus : a.address < b.address;
  });
  if (identify_cameras) {
    for (UsbDeviceInfo& device : devices) device.camera_model = ModelForUsbId(device.vendor_id, device.product_id);
  }
  return devices;
}

bool UsbHotplugAvailable() { return libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) != 0; }

void DeviceMonitorOptions::Check() const {
  if (!(poll_interval_s >= 0.05 && poll_interval_s <= 3600)) {
    throw std::invalid_argument("DeviceMonitorOptions.poll_interval_s = " + std::to_string(poll_interval_s) +
                                " must be in [0.05, 3600]");
  }
  if (!(settle_s >= 0 && settle_s <= 30)) {
    throw std::invalid_argument("DeviceMonitorOptions.settle_s = " + std::to_string(settle_s) +
                                " must be in [0, 30]");
  }
}

class DeviceMonitor::Impl {
 public:
  Impl(DeviceMonitorOptions options, ChangeCallback on_change)
      : options_(std::move(options)), on_change_(std::move(on_change)) {}

  ~Impl() { Stop(); }

  void Start() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      latest_ = TakeSnapshot();
      scans_ = 1;
    }
    if (options_.use_hotplug && UsbHotplugAvailable() && libusb_init(&usb_) == LIBUSB_SUCCESS) {
      const int result = libusb_hotplug_register_callback(
          usb_, static_cast<libusb_hotplug_event>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
          LIBUSB_HOTPLUG_NO_FLAGS, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY,
          &Impl::OnHotplug, this, &hotplug_handle_);
      hotplug_ = result == LIBUSB_SUCCESS;
      if (!hotplug_) {
        libusb_exit(usb_);
        usb_ = nullptr;
      }
    }
    thread_ = std::thread([this] { Run(); });
  }

  void Stop() {
    if (stop_.exchange(true)) return;
    if (hotplug_) libusb_interrupt_event_handler(usb_);
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
    if (usb_) {
      if (hotplug_) libusb_hotplug_deregister_callback(usb_, hotplug_handle_);
      libusb_exit(usb_);
      usb_ = nullptr;
    }
  }

  DeviceSnapshot Latest() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return latest_;
  }
  bool using_hotplug() const { return hotplug_; }
  int scan_count() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return scans_;
  }

  // Takes a snapshot and calls back if it differs from the last one.
  void Scan() {
    std::lock_guard<std::mutex> scan_lock(scan_mutex_);
    DeviceSnapshot snapshot = TakeSnapshot();
    bool changed = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      changed = snapshot.usb != latest_.usb || snapshot.cameras != latest_.cameras || snapshot.error != latest_.error;
      latest_ = snapshot;
      ++scans_;
    }
    if (changed && on_change_) on_change_(snapshot);
  }

 private:
  static int LIBUSB_CALL OnHotplug(libusb_context*, libusb_device*, libusb_hotplug_event, void* data) {
    // Called inside libusb_handle_events on our thread: only note it; the
    // scan runs once the bus has been quiet for settle_s.
    auto* self = static_cast<Impl*>(data);
    self->last_event_ticks_ = std::chrono::steady_clock::now().time_since_epoch().count();
    self->dirty_ = true;
    return 0;  // keep the callback registered
  }

  DeviceSnapshot TakeSnapshot() const {
    DeviceSnapshot snapshot;
    snapshot.time = std::chrono::system_clock::now();
    try {
      snapshot.usb = ListUsbDevices(/*identify_cameras=*/true);
    } catch (const std::exception& error) {
      snapshot.error = error.what();
    }
    if (options_.detect_cameras) {
      try {
        snapshot.cameras = DetectCameras();
      } catch (const std::exception& error) {
        snapshot.error += (snapshot.error.empty() ? "" : "; ") + std::string(error.what());
      }
    }
    return snapshot;
  }

  // Sleeps up to `duration`, returning early (true) when stopped.
  bool SleepFor(std::chrono::duration<double> duration) {
    std::unique_lock<std::mutex> lock(wake_mutex_);
    return wake_.wait_for(lock, duration, [this] { return stop_.load(); });
  }

  void Run() {
    const auto poll = std::chrono::duration<double>(options_.poll_interval_s);
    const auto settle = std::chrono::duration<double>(options_.settle_s);
    while (!stop_) {
      if (hotplug_) {
        timeval timeout{0, 200000};
        libusb_handle_events_timeout_completed(usb_, &timeout, nullptr);
        if (stop_ || !dirty_) continue;
        const auto last = std::chrono::steady_clock::time_point(
            std::chrono::steady_clock::duration(last_event_ticks_.load()));
        if (std::chrono::steady_clock::now() - last < settle) continue;
        dirty_ = false;
        Scan();
        continue;
      }
      if (SleepFor(poll)) break;
      std::vector<UsbDeviceInfo> usb;
      try {
        usb = ListUsbDevices(/*identify_cameras=*/false);
      } catch (const std::exception&) {
        continue;  // the next full scan reports it
      }
      bool changed = false;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        changed = !SameDevices(usb, latest_.usb);
      }
      if (!changed) continue;
      if (SleepFor(settle)) break;
      Scan();
    }
  }

  DeviceMonitorOptions options_;
  ChangeCallback on_change_;
  libusb_context* usb_ = nullptr;
  libusb_hotplug_callback_handle hotplug_handle_{};
  bool hotplug_ = false;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> dirty_{false};
  std::atomic<int64_t> last_event_ticks_{0};
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  mutable std::mutex mutex_;  // latest_, scans_
  std::mutex scan_mutex_;     // one scan at a time (thread and Rescan)
  DeviceSnapshot latest_;
  int scans_ = 0;
};

DeviceMonitor::DeviceMonitor(DeviceMonitorOptions options, ChangeCallback on_change) {
  options.Check();
  impl_ = std::make_unique<Impl>(std::move(options), std::move(on_change));
  impl_->Start();
}

DeviceMonitor::~DeviceMonitor() { Stop(); }

DeviceSnapshot DeviceMonitor::Latest() const { return impl_->Latest(); }
bool DeviceMonitor::using_hotplug() const { return impl_->using_hotplug(); }
int DeviceMonitor::scan_count() const { return impl_->scan_count(); }
void DeviceMonitor::Rescan() { impl_->Scan(); }
void DeviceMonitor::Stop() { impl_->Stop(); }

}  // namespace scanbench
