// Internal to the libgphoto2 backend, device discovery and their tests: this
// header includes libgphoto2. Ownership wrappers, the mapping of libgphoto2
// results to CameraError, and the mapping of settings onto widget trees,
// kept apart from the camera so it is testable on trees built in memory.
#pragma once

#include <gphoto2/gphoto2.h>

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "app/devices/camera/camera.h"
#include "app/devices/camera/gphoto2_camera.h"

namespace scanbench::gphoto2_support {

struct WidgetUnref {
  void operator()(CameraWidget* widget) const { gp_widget_unref(widget); }
};
struct CameraUnref {
  void operator()(::Camera* camera) const { gp_camera_unref(camera); }
};
struct FileUnref {
  void operator()(CameraFile* file) const { gp_file_unref(file); }
};
struct ListUnref {
  void operator()(CameraList* list) const { gp_list_unref(list); }
};
struct AbilitiesListFree {
  void operator()(CameraAbilitiesList* list) const { gp_abilities_list_free(list); }
};
struct PortInfoListFree {
  void operator()(GPPortInfoList* list) const { gp_port_info_list_free(list); }
};
using WidgetPtr = std::unique_ptr<CameraWidget, WidgetUnref>;
using CameraPtr = std::unique_ptr<::Camera, CameraUnref>;
using FilePtr = std::unique_ptr<CameraFile, FileUnref>;
using ListPtr = std::unique_ptr<CameraList, ListUnref>;
using AbilitiesListPtr = std::unique_ptr<CameraAbilitiesList, AbilitiesListFree>;
using PortInfoListPtr = std::unique_ptr<GPPortInfoList, PortInfoListFree>;

// libgphoto2 loads its camera and port drivers with libltdl, which is not
// thread-safe: autodetect, driver lists and camera init take this lock (the
// device monitor's thread autodetects while the camera is in use).
std::mutex& LibraryMutex();

// A GPContext that keeps the text the drivers report (gp_context_error and
// gp_context_message), to be quoted in error messages.
class Context {
 public:
  Context();
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  GPContext* get() const { return context_; }
  // The text collected since the last call, "; "-separated.
  std::string TakeText();

 private:
  static void OnText(GPContext* context, const char* text, void* data);
  GPContext* context_ = nullptr;
  std::string text_;
};

// Whether the failure happened while opening (no device on the port is "not
// found" then) or later (a vanished device is "disconnected").
enum class Phase { kOpen, kSession };

// The CameraError for a libgphoto2 result < 0 of `action` ("capture",
// "download /DCIM/DSC_0001.NEF"), quoting the driver's text.
CameraError ErrorFromResult(int result, const std::string& camera, const std::string& action,
                            const std::string& library_text, Phase phase);

// One widget's state, whatever its type; value as text (toggle "0"/"1",
// range and date as numbers).
struct WidgetState {
  std::string name;
  std::string label;
  CameraWidgetType type = GP_WIDGET_TEXT;
  std::string value;
  std::vector<std::string> choices;  // radio and menu widgets
  bool read_only = false;
  std::optional<float> range_min, range_max, range_step;  // range widgets
};

WidgetState ReadWidget(CameraWidget* widget);
// The first widget under `root` (anywhere in the tree) named one of `names`
// in that order of preference; nullptr when none.
CameraWidget* FindWidget(CameraWidget* root, const std::vector<std::string>& names);
// Sets a widget from text: radio/menu only to one of its choices (exact),
// toggle from 0/1/on/off/true/false/yes/no, range from a number within its
// bounds, text as given. Throws CameraError (kNotSupported) naming `camera`,
// the widget, the value and what it accepts.
void SetWidgetText(CameraWidget* widget, const std::string& value, const std::string& camera);

// Widget names per setting, preferred first: Nikon's "shutterspeed2" gives
// exact fractions where the generic "shutterspeed" prints rounded seconds.
const std::vector<std::string>& SettingWidgetNames(CameraSetting setting);
// nullopt when the tree has no widget for the setting.
std::optional<CameraSettingState> ReadSetting(CameraWidget* root, CameraSetting setting);
// Matches `requested` (MatchSettingValue) and sets the widget; returns it.
// Throws CameraError (kNotSupported) naming the widget names looked for when
// there is no such widget, or when the value is not allowed.
CameraWidget* ApplySetting(CameraWidget* root, CameraSetting setting, const std::string& requested,
                           const std::string& camera);
ExposureSettings ReadExposure(CameraWidget* root);

// Sets what the backend may set itself under `options`: capture target
// (RAM or card), image quality RAW only, Auto ISO off. Returns the names of
// the widgets it changed (to push to the camera).
std::vector<std::string> PrepareForCapture(CameraWidget* root, const GPhotoCameraOptions& options,
                                           const std::string& camera);
// What the operator must change by hand before capturing (mode dial on M,
// manual focus, RAW image quality, Auto ISO), each naming the widget, its
// value and what to do; empty when ready.
std::vector<std::string> ReadinessProblems(CameraWidget* root, const GPhotoCameraOptions& options);
// make, model, serial, lens and firmware from the status widgets, where present.
void FillInfo(CameraWidget* root, CameraDeviceInfo* info);
// "/main/capturesettings/shutterspeed2 = 1/125 [30, 25, ...]" for every value widget.
std::vector<std::string> DescribeTree(CameraWidget* root);

// libgphoto2's model for a USB VID:PID ("" when none); loads the driver list
// once per process.
std::string ModelForUsbId(int vendor_id, int product_id);

}  // namespace scanbench::gphoto2_support
