// What is plugged in: cameras as libgphoto2 autodetects them, and the USB
// bus (libusb), whose changes trigger a new autodetect. DeviceMonitor
// watches for changes with libusb hotplug where the system has it and polls
// otherwise. libgphoto2 and libusb stay private.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace scanbench {

struct DetectedCamera {
  std::string model;  // libgphoto2's model name ("Nikon DSC D5100 (PTP mode)")
  std::string port;   // "usb:001,004": what GPhotoCameraOptions::port takes
  bool operator==(const DetectedCamera& other) const = default;
};

// Cameras libgphoto2 finds now, in its order; empty when none. Throws
// CameraError (kIo) when libgphoto2 itself fails (no camera drivers installed).
std::vector<DetectedCamera> DetectCameras();

struct UsbDeviceInfo {
  int bus = 0;                // 1..
  int address = 0;            // device number on the bus, changes when replugged
  std::string port_path;      // physical port chain "1-2.3" ("" when unknown); stable across replugs
  uint16_t vendor_id = 0;
  uint16_t product_id = 0;
  int device_class = 0;       // bDeviceClass (0: per interface; 6: still image)
  std::string camera_model;   // libgphoto2's model for this VID:PID, "" when it knows none

  // "04b0:0429", lower-case hex as lsusb prints it.
  std::string UsbId() const;
  // "usb:001,004", libgphoto2's port for the device.
  std::string GphotoPort() const;
  bool operator==(const UsbDeviceInfo& other) const = default;
};

// Every USB device, sorted by bus and address; without access to USB (a
// container) an empty list. With identify_cameras, fills camera_model from
// libgphoto2's list of supported cameras. Throws CameraError (kIo) only if
// libusb cannot start.
std::vector<UsbDeviceInfo> ListUsbDevices(bool identify_cameras = true);

// Whether libusb can report devices arriving and leaving on this system.
bool UsbHotplugAvailable();

struct DeviceSnapshot {
  std::vector<UsbDeviceInfo> usb;
  std::vector<DetectedCamera> cameras;
  std::string error;  // why listing or autodetect failed this time; "" when it worked
  std::chrono::system_clock::time_point time;
};

struct DeviceMonitorOptions {
  bool use_hotplug = true;        // libusb hotplug events where available; false: always poll
  double poll_interval_s = 2.0;   // without hotplug: how often the USB bus is listed, [0.05, 3600]
  double settle_s = 0.5;          // wait after a USB change before autodetect (PTP cameras enumerate late), [0, 30]
  bool detect_cameras = true;     // run libgphoto2 autodetect when the bus changes

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

// Watches the USB bus on a thread of its own and calls back when the devices
// or cameras change: the trigger for re-running camera autodetect and
// re-listing serial ports (a board plugged in or out).
class DeviceMonitor {
 public:
  // Called on the monitor's thread after every change; keep it short.
  using ChangeCallback = std::function<void(const DeviceSnapshot& snapshot)>;

  // Takes the first snapshot (synchronously) and starts watching.
  // Throws std::invalid_argument for bad options.
  DeviceMonitor(DeviceMonitorOptions options, ChangeCallback on_change);
  ~DeviceMonitor();  // Stop()
  DeviceMonitor(const DeviceMonitor&) = delete;
  DeviceMonitor& operator=(const DeviceMonitor&) = delete;

  DeviceSnapshot Latest() const;
  // True when changes come from libusb hotplug events, false when polled.
  bool using_hotplug() const;
  // Snapshots taken so far (the first included).
  int scan_count() const;
  // Scans again now, on the caller's thread (calls back if something changed).
  void Rescan();
  // Stops the thread; idempotent.
  void Stop();

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace scanbench
