#include "app/devices/camera/gphoto2_support.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>

namespace scanbench::gphoto2_support {

namespace {

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

bool Contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::string Join(const std::vector<std::string>& items, const std::string& separator) {
  std::string joined;
  for (size_t i = 0; i < items.size(); ++i) joined += (i ? separator : "") + items[i];
  return joined;
}

std::string FormatFloat(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

std::string WidgetName(CameraWidget* widget) {
  const char* name = nullptr;
  gp_widget_get_name(widget, &name);
  return name ? name : "";
}

bool IsOn(const std::string& value) {
  const std::string lower = Lower(value);
  return lower == "on" || lower == "1" || lower == "true" || lower == "yes";
}

// The mode dial's M (PTP "M"; some drivers say "Manual").
bool IsManualExposure(const std::string& value) {
  const std::string lower = Lower(value);
  return lower == "m" || lower == "manual";
}

// "Manual" (PTP focus mode: the lens or body switch on M), Nikon's
// "MF (fixed)" / "MF (selection)" (AF-mode menu), Canon's "Manual Focus".
bool IsManualFocus(const std::string& value) {
  const std::string lower = Lower(value);
  return lower.rfind("mf", 0) == 0 || Contains(lower, "manual");
}

// Image quality values that carry a RAW file: "NEF (Raw)", "NEF+Fine", "RAW", "RAW+JPEG (Fine)".
bool IncludesRaw(const std::string& value) {
  const std::string lower = Lower(value);
  return Contains(lower, "raw") || Contains(lower, "nef");
}

bool IsRawOnly(const std::string& value) {
  const std::string lower = Lower(value);
  if (!IncludesRaw(value) || Contains(lower, "+")) return false;
  for (const char* other : {"jpeg", "jpg", "heif", "tiff", "basic", "normal", "fine"}) {
    if (Contains(lower, other)) return false;
  }
  return true;
}

const std::vector<std::string> kCaptureTargetNames = {"capturetarget"};
const std::vector<std::string> kAutoIsoNames = {"autoiso"};
const std::vector<std::string> kImageQualityNames = {"imagequality", "imageformat"};
const std::vector<std::string> kExposureProgramNames = {"expprogram", "autoexposuremode", "autoexposuremodedial"};
const std::vector<std::string> kFocusNames = {"focusmode", "focusmode2"};

void Walk(CameraWidget* widget, const std::string& parent,
          const std::function<void(CameraWidget*, const std::string& path)>& visit) {
  const std::string path = parent + "/" + WidgetName(widget);
  visit(widget, path);
  const int count = gp_widget_count_children(widget);
  for (int i = 0; i < count; ++i) {
    CameraWidget* child = nullptr;
    if (gp_widget_get_child(widget, i, &child) == GP_OK && child) Walk(child, path, visit);
  }
}

bool IsValueWidget(CameraWidgetType type) {
  return type != GP_WIDGET_WINDOW && type != GP_WIDGET_SECTION && type != GP_WIDGET_BUTTON;
}

}  // namespace

std::mutex& LibraryMutex() {
  static std::mutex mutex;
  return mutex;
}

Context::Context() : context_(gp_context_new()) {
  gp_context_set_error_func(context_, &Context::OnText, this);
  gp_context_set_message_func(context_, &Context::OnText, this);
}

Context::~Context() { gp_context_unref(context_); }

void Context::OnText(GPContext*, const char* text, void* data) {
  if (!text || !*text) return;
  auto* self = static_cast<Context*>(data);
  std::string line(text);
  while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
  // The same complaint often comes twice (driver, then core).
  if (Contains(self->text_, line)) return;
  if (!self->text_.empty()) self->text_ += "; ";
  self->text_ += line;
}

std::string Context::TakeText() {
  std::string text;
  text.swap(text_);
  return text;
}

CameraError ErrorFromResult(int result, const std::string& camera, const std::string& action,
                            const std::string& library_text, Phase phase) {
  const std::string quoted = " (libgphoto2: " + (library_text.empty() ? "" : library_text + "; ") + "error " +
                             std::to_string(result) + ", " + gp_result_as_string(result) + ")";
  const std::string lower_text = Lower(library_text);
  const bool opening = phase == Phase::kOpen;
  const auto error = [&](CameraErrorKind kind, const std::string& problem) {
    return CameraError(kind, camera, action + " failed: " + problem + quoted);
  };
  const std::string reconnect_hint =
      "check the USB cable, that the camera is switched on and has not gone to sleep (set a long auto-off "
      "timer), then reconnect";

  if (Contains(lower_text, "access denied") || Contains(lower_text, "permission")) {
    return error(CameraErrorKind::kPermissionDenied,
                 "no permission to use the camera's USB device: add your user to the plugdev group "
                 "(sudo adduser $USER plugdev, then log in again) so that libgphoto2's udev rules "
                 "(/lib/udev/rules.d/60-libgphoto2-6.rules) give you access, and replug the camera");
  }
  switch (result) {
    case GP_ERROR_MODEL_NOT_FOUND:
      return error(CameraErrorKind::kNotFound,
                   "no camera found: connect it by USB and switch it on (`scanbench camera list` shows what is "
                   "on the USB bus)");
    case GP_ERROR_UNKNOWN_PORT:
      return error(CameraErrorKind::kNotFound,
                   "no such port: the camera was unplugged or got a new USB address (`scanbench camera list` "
                   "shows the current one)");
    case GP_ERROR_IO_USB_FIND:
      return opening ? error(CameraErrorKind::kNotFound, "the camera is not on the USB bus")
                     : error(CameraErrorKind::kDisconnected, "the camera left the USB bus: " + reconnect_hint);
    case GP_ERROR_IO_USB_CLAIM:
    case GP_ERROR_IO_LOCK:
      return error(CameraErrorKind::kClaimed,
                   "another program holds the camera's USB interface. On a desktop this is usually gvfs, "
                   "which mounts cameras by itself: unmount the camera in the file manager or run "
                   "`gio mount -s gphoto2`, and keep it from coming back with `systemctl --user mask --now "
                   "gvfs-gphoto2-volume-monitor.service`; also close gphoto2, Entangle, darktable or digiKam "
                   "if one is running");
    case GP_ERROR_CAMERA_BUSY:
      return error(CameraErrorKind::kBusy,
                   "the camera is busy (still writing the last frame, showing a menu or playback, or the "
                   "shutter button half-pressed): close its menu and try again");
    case GP_ERROR_NOT_SUPPORTED:
      return error(CameraErrorKind::kNotSupported, "this camera or its libgphoto2 driver does not support it");
    case GP_ERROR_BAD_PARAMETERS:
      return opening ? error(CameraErrorKind::kNotFound,
                             "no such camera on the port (unplugged, or not switched on?)")
                     : error(CameraErrorKind::kNotSupported, "the camera's driver rejected the request");
    case GP_ERROR_TIMEOUT:
      return error(CameraErrorKind::kTimeout, "the camera did not answer in time: " + reconnect_hint);
    case GP_ERROR_IO:
    case GP_ERROR_IO_INIT:
    case GP_ERROR_IO_READ:
    case GP_ERROR_IO_WRITE:
    case GP_ERROR_IO_UPDATE:
    case GP_ERROR_IO_USB_CLEAR_HALT:
    case GP_ERROR_IO_SERIAL_SPEED:
      return opening ? error(CameraErrorKind::kIo, "USB communication failed: " + reconnect_hint)
                     : error(CameraErrorKind::kDisconnected, "USB communication failed: " + reconnect_hint);
    case GP_ERROR_FILE_NOT_FOUND:
    case GP_ERROR_DIRECTORY_NOT_FOUND:
      return error(CameraErrorKind::kNotFound, "no such file or folder on the camera");
    case GP_ERROR_NO_SPACE:
      return error(CameraErrorKind::kIo, "the camera's storage is full: delete frames or capture to RAM");
    case GP_ERROR_CAMERA_ERROR:
      if (Contains(lower_text, "focus")) {
        return error(CameraErrorKind::kWrongMode,
                     "the camera could not focus: set the lens's focus switch to M after focusing on the sample");
      }
      return error(CameraErrorKind::kIo, "the camera reported an error");
    default:
      return error(CameraErrorKind::kIo, "unexpected libgphoto2 error");
  }
}

WidgetState ReadWidget(CameraWidget* widget) {
  WidgetState state;
  const char* text = nullptr;
  if (gp_widget_get_name(widget, &text) == GP_OK && text) state.name = text;
  text = nullptr;
  if (gp_widget_get_label(widget, &text) == GP_OK && text) state.label = text;
  gp_widget_get_type(widget, &state.type);
  int read_only = 0;
  gp_widget_get_readonly(widget, &read_only);
  state.read_only = read_only != 0;
  switch (state.type) {
    case GP_WIDGET_TEXT:
    case GP_WIDGET_RADIO:
    case GP_WIDGET_MENU: {
      char* value = nullptr;
      if (gp_widget_get_value(widget, &value) == GP_OK && value) state.value = value;
      if (state.type != GP_WIDGET_TEXT) {
        const int count = gp_widget_count_choices(widget);
        for (int i = 0; i < count; ++i) {
          const char* choice = nullptr;
          if (gp_widget_get_choice(widget, i, &choice) == GP_OK && choice) state.choices.emplace_back(choice);
        }
      }
      break;
    }
    case GP_WIDGET_TOGGLE:
    case GP_WIDGET_DATE: {
      int value = 0;
      if (gp_widget_get_value(widget, &value) == GP_OK) state.value = std::to_string(value);
      break;
    }
    case GP_WIDGET_RANGE: {
      float value = 0, low = 0, high = 0, step = 0;
      if (gp_widget_get_value(widget, &value) == GP_OK) state.value = FormatFloat(value);
      if (gp_widget_get_range(widget, &low, &high, &step) == GP_OK) {
        state.range_min = low;
        state.range_max = high;
        state.range_step = step;
      }
      break;
    }
    default:
      break;
  }
  return state;
}

CameraWidget* FindWidget(CameraWidget* root, const std::vector<std::string>& names) {
  if (!root) return nullptr;
  for (const std::string& name : names) {
    CameraWidget* child = nullptr;
    if (gp_widget_get_child_by_name(root, name.c_str(), &child) == GP_OK && child) return child;
  }
  return nullptr;
}

void SetWidgetText(CameraWidget* widget, const std::string& value, const std::string& camera) {
  const WidgetState state = ReadWidget(widget);
  const std::string what = "setting '" + state.name + "' (" + state.label + ") to '" + value + "'";
  const auto fail = [&](const std::string& rule) {
    throw CameraError(CameraErrorKind::kNotSupported, camera, what + ": " + rule);
  };
  if (state.read_only) fail("it is read-only (the camera sets it, or it is set by hand on the camera)");
  int result = GP_OK;
  switch (state.type) {
    case GP_WIDGET_RADIO:
    case GP_WIDGET_MENU:
      if (!state.choices.empty() && std::find(state.choices.begin(), state.choices.end(), value) ==
                                        state.choices.end()) {
        fail("not one of its values: " + Join(state.choices, ", "));
      }
      result = gp_widget_set_value(widget, value.c_str());
      break;
    case GP_WIDGET_TEXT:
      result = gp_widget_set_value(widget, value.c_str());
      break;
    case GP_WIDGET_TOGGLE: {
      const std::string lower = Lower(value);
      int on = 0;
      if (lower == "1" || lower == "on" || lower == "true" || lower == "yes") {
        on = 1;
      } else if (!(lower == "0" || lower == "off" || lower == "false" || lower == "no")) {
        fail("a toggle takes 0/1, on/off, true/false or yes/no");
      }
      result = gp_widget_set_value(widget, &on);
      break;
    }
    case GP_WIDGET_RANGE:
    case GP_WIDGET_DATE: {
      char* end = nullptr;
      const double number = std::strtod(value.c_str(), &end);
      if (value.empty() || *end != '\0' || !std::isfinite(number)) fail("not a number");
      if (state.type == GP_WIDGET_DATE) {
        const int seconds = static_cast<int>(number);
        result = gp_widget_set_value(widget, &seconds);
        break;
      }
      if (state.range_min && state.range_max &&
          (number < *state.range_min - 1e-6 || number > *state.range_max + 1e-6)) {
        fail("outside its range [" + FormatFloat(*state.range_min) + ", " + FormatFloat(*state.range_max) + "]");
      }
      const float as_float = static_cast<float>(number);
      result = gp_widget_set_value(widget, &as_float);
      break;
    }
    default:
      fail("it is a section or button, not a value");
  }
  if (result < GP_OK) {
    throw CameraError(CameraErrorKind::kIo, camera,
                      what + " failed in libgphoto2: " + gp_result_as_string(result));
  }
}

const std::vector<std::string>& SettingWidgetNames(CameraSetting setting) {
  static const std::vector<std::string> iso = {"iso", "isospeed"};
  static const std::vector<std::string> shutter = {"shutterspeed2", "shutterspeed", "eos-shutterspeed"};
  static const std::vector<std::string> aperture = {"f-number", "aperture"};
  return ForSetting(setting, iso, shutter, aperture);
}

std::optional<CameraSettingState> ReadSetting(CameraWidget* root, CameraSetting setting) {
  CameraWidget* widget = FindWidget(root, SettingWidgetNames(setting));
  if (!widget) return std::nullopt;
  const WidgetState widget_state = ReadWidget(widget);
  CameraSettingState state;
  state.setting = setting;
  state.current = widget_state.value;
  state.choices = widget_state.choices;
  if (widget_state.range_min) state.range_min = *widget_state.range_min;
  if (widget_state.range_max) state.range_max = *widget_state.range_max;
  state.read_only = widget_state.read_only;
  state.source = "widget " + widget_state.name;
  return state;
}

CameraWidget* ApplySetting(CameraWidget* root, CameraSetting setting, const std::string& requested,
                           const std::string& camera) {
  CameraWidget* widget = FindWidget(root, SettingWidgetNames(setting));
  const std::optional<CameraSettingState> state = ReadSetting(root, setting);
  if (!widget || !state) {
    throw CameraError(CameraErrorKind::kNotSupported, camera,
                      std::string("has no ") + CameraSettingName(setting) + " setting (no widget named " +
                          Join(SettingWidgetNames(setting), " or ") + "; `scanbench camera info --all` lists "
                          "what it has)");
  }
  SetWidgetText(widget, MatchSettingValue(*state, requested, camera), camera);
  return widget;
}

ExposureSettings ReadExposure(CameraWidget* root) {
  ExposureSettings settings;
  const auto value = [root](CameraSetting setting) {
    const std::optional<CameraSettingState> state = ReadSetting(root, setting);
    return state ? ParseSettingValue(setting, state->current).value_or(0.0) : 0.0;
  };
  settings.iso = value(CameraSetting::kIso);
  settings.exposure_time_s = value(CameraSetting::kShutter);
  settings.f_number = value(CameraSetting::kAperture);
  return settings;
}

std::vector<std::string> PrepareForCapture(CameraWidget* root, const GPhotoCameraOptions& options,
                                           const std::string& camera) {
  std::vector<std::string> changed;
  const auto set = [&](CameraWidget* widget, const WidgetState& state, const std::string& value) {
    if (state.read_only || state.value == value) return;
    SetWidgetText(widget, value, camera);
    changed.push_back(state.name);
  };

  // "Internal RAM" / "Memory card" (ptp2); a libgphoto2 setting for Nikon,
  // so it always takes.
  if (CameraWidget* widget = FindWidget(root, kCaptureTargetNames)) {
    const WidgetState state = ReadWidget(widget);
    for (const std::string& choice : state.choices) {
      const std::string lower = Lower(choice);
      const bool is_ram = Contains(lower, "ram");
      const bool is_card = Contains(lower, "card");
      if ((options.capture_to_ram && is_ram) || (!options.capture_to_ram && is_card)) {
        set(widget, state, choice);
        break;
      }
    }
  }
  if (options.disable_auto_iso) {
    if (CameraWidget* widget = FindWidget(root, kAutoIsoNames)) {
      const WidgetState state = ReadWidget(widget);
      if (IsOn(state.value)) {
        if (state.type == GP_WIDGET_TOGGLE) {
          set(widget, state, "0");
        } else {
          for (const std::string& choice : state.choices) {
            if (Lower(choice) == "off") set(widget, state, choice);
          }
        }
      }
    }
  }
  if (options.force_raw_only) {
    if (CameraWidget* widget = FindWidget(root, kImageQualityNames)) {
      const WidgetState state = ReadWidget(widget);
      if (!IsRawOnly(state.value)) {
        for (const std::string& choice : state.choices) {
          if (IsRawOnly(choice)) {
            set(widget, state, choice);
            break;
          }
        }
      }
    }
  }
  return changed;
}

std::vector<std::string> ReadinessProblems(CameraWidget* root, const GPhotoCameraOptions& options) {
  std::vector<std::string> problems;
  if (!root) return problems;
  if (options.require_manual_exposure) {
    if (CameraWidget* widget = FindWidget(root, kExposureProgramNames)) {
      const WidgetState state = ReadWidget(widget);
      if (!IsManualExposure(state.value)) {
        problems.push_back("the mode dial is on '" + state.value + "' (widget " + state.name +
                           "): turn it to M. In any other mode the camera picks its own exposure for each "
                           "frame, and every LED must be captured with the same exposure");
      }
    }
  }
  if (options.require_manual_focus) {
    std::vector<std::string> readings;
    bool manual = false;
    for (const std::string& name : kFocusNames) {
      if (CameraWidget* widget = FindWidget(root, {name})) {
        const WidgetState state = ReadWidget(widget);
        readings.push_back(state.name + " '" + state.value + "'");
        manual = manual || IsManualFocus(state.value);
      }
    }
    if (!readings.empty() && !manual) {
      problems.push_back("the focus is automatic (" + Join(readings, ", ") +
                         "): focus on the sample, then set the lens's A/M switch to M (or the focus mode to "
                         "MF). Autofocus hunts in the light of a single LED, may refuse to release the "
                         "shutter, and can move the focus between frames");
    }
  }
  if (CameraWidget* widget = FindWidget(root, kImageQualityNames)) {
    const WidgetState state = ReadWidget(widget);
    if (!IncludesRaw(state.value)) {
      problems.push_back("the image quality is '" + state.value + "' (widget " + state.name +
                         "): set it to RAW (NEF) in the camera's shooting menu; a JPEG is neither linear nor "
                         "complete");
    }
  }
  if (options.disable_auto_iso) {
    if (CameraWidget* widget = FindWidget(root, kAutoIsoNames)) {
      const WidgetState state = ReadWidget(widget);
      if (IsOn(state.value)) {
        problems.push_back("Auto ISO is on (widget " + state.name +
                           "): turn it off (shooting menu, ISO sensitivity settings, Auto ISO sensitivity "
                           "control), or the ISO changes from frame to frame");
      }
    }
  }
  return problems;
}

void FillInfo(CameraWidget* root, CameraDeviceInfo* info) {
  const auto read = [root](const std::vector<std::string>& names, std::string* out) {
    if (CameraWidget* widget = FindWidget(root, names)) {
      const std::string value = ReadWidget(widget).value;
      if (!value.empty()) *out = value;
    }
  };
  read({"manufacturer"}, &info->make);
  read({"cameramodel", "model"}, &info->model);
  read({"serialnumber", "eos-serialnumber"}, &info->serial);
  read({"lensname"}, &info->lens);
  read({"deviceversion"}, &info->firmware);
}

std::vector<std::string> DescribeTree(CameraWidget* root) {
  std::vector<std::string> lines;
  if (!root) return lines;
  Walk(root, "", [&lines](CameraWidget* widget, const std::string& path) {
    const WidgetState state = ReadWidget(widget);
    if (!IsValueWidget(state.type)) return;
    std::string line = path + " = " + state.value;
    if (!state.choices.empty()) line += " [" + Join(state.choices, ", ") + "]";
    if (state.range_min && state.range_max) {
      line += " [" + FormatFloat(*state.range_min) + " .. " + FormatFloat(*state.range_max) + "]";
    }
    if (state.read_only) line += " (read-only)";
    lines.push_back(line);
  });
  return lines;
}

std::string ModelForUsbId(int vendor_id, int product_id) {
  std::lock_guard<std::mutex> lock(LibraryMutex());
  // The driver list does not change while we run: load it once.
  static AbilitiesListPtr abilities = [] {
    CameraAbilitiesList* list = nullptr;
    if (gp_abilities_list_new(&list) < GP_OK) return AbilitiesListPtr();
    AbilitiesListPtr owned(list);
    Context context;
    if (gp_abilities_list_load(list, context.get()) < GP_OK) return AbilitiesListPtr();
    return owned;
  }();
  if (!abilities || vendor_id == 0) return "";
  const int count = gp_abilities_list_count(abilities.get());
  for (int i = 0; i < count; ++i) {
    CameraAbilities entry;
    if (gp_abilities_list_get_abilities(abilities.get(), i, &entry) != GP_OK) continue;
    if (entry.usb_vendor == vendor_id && entry.usb_product == product_id) return entry.model;
  }
  return "";
}

}  // namespace scanbench::gphoto2_support
