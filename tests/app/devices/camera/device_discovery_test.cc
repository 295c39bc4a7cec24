#include "app/devices/camera/device_discovery.h"

#include <atomic>
#include <chrono>
#include <regex>
#include <stdexcept>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/devices/camera/gphoto2_support.h"

namespace scanbench {
namespace {

TEST(DeviceDiscovery, ListsWithoutCrashingWhenThereIsNothing) {
  std::vector<DetectedCamera> cameras;
  EXPECT_NO_THROW(cameras = DetectCameras());
  std::vector<UsbDeviceInfo> usb;
  EXPECT_NO_THROW(usb = ListUsbDevices());
  for (const UsbDeviceInfo& device : usb) {
    EXPECT_TRUE(std::regex_match(device.UsbId(), std::regex("[0-9a-f]{4}:[0-9a-f]{4}"))) << device.UsbId();
    EXPECT_GT(device.bus, 0);
  }
  UsbHotplugAvailable();  // either answer is fine; it must not need a device
}

TEST(DeviceDiscovery, UsbIdsAndPortsAsToolsPrintThem) {
  UsbDeviceInfo device;
  device.bus = 1;
  device.address = 4;
  device.vendor_id = 0x04b0;
  device.product_id = 0x0429;
  EXPECT_EQ(device.UsbId(), "04b0:0429");
  EXPECT_EQ(device.GphotoPort(), "usb:001,004");
  // libgphoto2's own table names the D5100 by its USB ids.
  EXPECT_EQ(gphoto2_support::ModelForUsbId(0x04b0, 0x0429), "Nikon DSC D5100 (PTP mode)");
  EXPECT_EQ(gphoto2_support::ModelForUsbId(0x2341, 0x0043), "");  // an Arduino Uno is no camera
}

TEST(DeviceMonitor, PollsAndStopsPromptly) {
  DeviceMonitorOptions options;
  options.use_hotplug = false;
  options.poll_interval_s = 0.05;
  options.settle_s = 0;
  std::atomic<int> changes{0};
  DeviceMonitor monitor(options, [&changes](const DeviceSnapshot&) { ++changes; });
  EXPECT_FALSE(monitor.using_hotplug());
  EXPECT_GE(monitor.scan_count(), 1);
  const DeviceSnapshot first = monitor.Latest();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // a few polls of an unchanged bus
  monitor.Rescan();
  EXPECT_EQ(monitor.Latest().usb, first.usb);
  EXPECT_EQ(changes.load(), 0);
  const auto start = std::chrono::steady_clock::now();
  monitor.Stop();
  monitor.Stop();
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
}

TEST(DeviceMonitor, UsesHotplugWhereAvailable) {
  DeviceMonitorOptions options;
  options.detect_cameras = false;
  const auto start = std::chrono::steady_clock::now();
  {
    DeviceMonitor monitor(options, nullptr);
    EXPECT_EQ(monitor.using_hotplug(), UsbHotplugAvailable());
    EXPECT_TRUE(monitor.Latest().cameras.empty());
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
}

TEST(DeviceMonitor, OptionsAreChecked) {
  DeviceMonitorOptions options;
  options.poll_interval_s = 0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = {};
  options.settle_s = -1;
  EXPECT_THROW(DeviceMonitor(options, nullptr), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
