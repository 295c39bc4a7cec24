#include "app/devices/camera/gphoto2_camera.h"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <thread>

#include "app/devices/camera/device_discovery.h"
#include "app/devices/camera/gphoto2_support.h"

namespace scanbench {

using namespace gphoto2_support;

namespace {

void CheckRange(const char* field, int value, int low, int high) {
  if (value < low || value > high) {
    throw std::invalid_argument("GPhotoCameraOptions." + std::string(field) + " = " + std::to_string(value) +
                                " must be in [" + std::to_string(low) + ", " + std::to_string(high) + "]");
  }
}

std::string JoinPath(const std::string& folder, const std::string& name) {
  if (folder.empty() || folder.back() == '/') return folder + name;
  return folder + "/" + name;
}

std::string ListDetected(const std::vector<DetectedCamera>& cameras) {
  if (cameras.empty()) return "none";
  std::string list;
  for (size_t i = 0; i < cameras.size(); ++i) {
    list += (i ? ", " : "") + cameras[i].model + " on " + cameras[i].port;
  }
  return list;
}

std::string ExtensionForMime(const std::string& mime) {
  if (mime == GP_MIME_JPEG) return ".jpg";
  if (mime == GP_MIME_PNG) return ".png";
  if (mime == GP_MIME_PPM) return ".ppm";
  if (mime == GP_MIME_TIFF) return ".tif";
  return ".bin";
}

}  // namespace

void GPhotoCameraOptions::Check() const {
  CheckRange("busy_timeout_ms", busy_timeout_ms, 0, 60000);
  CheckRange("event_timeout_ms", event_timeout_ms, 1, 10000);
  CheckRange("drain_limit_ms", drain_limit_ms, 0, 60000);
}

class GPhotoCamera::Impl {
 public:
  explicit Impl(const GPhotoCameraOptions& options) : options_(options) {}
  ~Impl() { Close(); }

  std::string description() const { return description_; }
  const std::string& model() const { return model_; }
  const std::string& port() const { return port_; }

  void Open() {
    {
      std::lock_guard<std::mutex> lock(LibraryMutex());
      ResolveModelAndPort();
      InitCamera();
    }
    description_ = "camera " + model_ + " on " + port_;
    if (WidgetPtr tree = GetTree()) {
      if (!PrepareForCapture(tree.get(), options_, description_).empty()) PushTree(tree.get(), "configure for capture");
    }
  }

  void Close() noexcept {
    if (!camera_) return;
    try {
      StopPreview();
    } catch (const std::exception&) {
      // Closing anyway; live view ends when the camera is released.
    }
    gp_camera_exit(camera_.get(), context_.get());
    context_.TakeText();
    camera_.reset();
  }

  [[noreturn]] void Fail(int result, const std::string& action, Phase phase = Phase::kSession) {
    throw ErrorFromResult(result, description_, action, context_.TakeText(), phase);
  }
  void Check(int result, const std::string& action, Phase phase = Phase::kSession) {
    if (result < GP_OK) Fail(result, action, phase);
    context_.TakeText();
  }

  ::Camera* camera() {
    if (!camera_) {
      throw CameraError(CameraErrorKind::kDisconnected, description_, "not connected (a reconnect failed)");
    }
    return camera_.get();
  }

  // nullptr when the driver offers no configuration (Directory Browse).
  WidgetPtr GetTree() {
    CameraWidget* root = nullptr;
    const int result = gp_camera_get_config(camera(), &root, context_.get());
    if (result == GP_ERROR_NOT_SUPPORTED) {
      context_.TakeText();
      return nullptr;
    }
    Check(result, "read the configuration");
    return WidgetPtr(root);
  }

  WidgetPtr RequireTree(const std::string& what) {
    WidgetPtr tree = GetTree();
    if (!tree) {
      throw CameraError(CameraErrorKind::kNotSupported, description_,
                        "has no configuration at all (its libgphoto2 driver offers none), so no " + what);
    }
    return tree;
  }

  // The driver writes only the widgets marked changed.
  void PushTree(CameraWidget* root, const std::string& action) {
    Check(gp_camera_set_config(camera(), root, context_.get()), action);
  }

  bool Can(CameraOperation operation) const { return (abilities_.operations & operation) != 0; }

  std::vector<std::string> CheckReady() {
    std::vector<std::string> problems;
    if (!Can(GP_OPERATION_CAPTURE_IMAGE)) {
      problems.push_back("its libgphoto2 driver cannot capture remotely");
      return problems;
    }
    if (WidgetPtr tree = GetTree()) problems = ReadinessProblems(tree.get(), options_);
    return problems;
  }

  CapturedFrame Capture() {
    if (!Can(GP_OPERATION_CAPTURE_IMAGE)) {
      throw CameraError(CameraErrorKind::kNotSupported, description_,
                        "cannot capture: its libgphoto2 driver offers no remote capture");
    }
    StopPreview();
    ExposureSettings settings;
    if (WidgetPtr tree = GetTree()) {
      const std::vector<std::string> problems = ReadinessProblems(tree.get(), options_);
      if (!problems.empty()) {
        std::string text;
        for (size_t i = 0; i < problems.size(); ++i) text += (i ? "; " : "") + problems[i];
        throw CameraError(CameraErrorKind::kWrongMode, description_, "not ready to capture: " + text);
      }
      settings = ReadExposure(tree.get());
    }
    // Whatever was pending belongs to earlier work, not to this frame.
    Drain(1, std::min(options_.drain_limit_ms, 1000), nullptr);

    const auto capture_time = std::chrono::system_clock::now();
    CameraFilePath path{};
    const int result = WhileBusy([&] { return gp_camera_capture(camera(), GP_CAPTURE_IMAGE, &path, context_.get()); });
    Check(result, "capture");
    std::vector<CameraFilePath> files = {path};
    std::vector<CameraFilePath> added;
    Drain(options_.event_timeout_ms, options_.drain_limit_ms, &added);
    for (const CameraFilePath& file : added) {
      const bool known = std::any_of(files.begin(), files.end(), [&](const CameraFilePath& other) {
        return std::string(other.folder) == file.folder && std::string(other.name) == file.name;
      });
      if (!known) files.push_back(file);
    }

    // The RAW file is downloaded; a JPEG twin (RAW+JPEG quality) only deleted.
    std::optional<CapturedFrame> raw;
    std::vector<std::string> names;
    for (const CameraFilePath& file : files) {
      names.push_back(JoinPath(file.folder, file.name));
      if (!raw && IsRawFileName(file.name)) raw = Download(file.folder, file.name);
      if (options_.delete_after_download) DeleteQuietly(file.folder, file.name);
    }
    if (!raw) {
      std::string list;
      for (size_t i = 0; i < names.size(); ++i) list += (i ? ", " : "") + names[i];
      throw CameraError(CameraErrorKind::kBadFile, description_,
                        "the capture gave " + list + " but no RAW file: set the image quality to RAW (NEF)");
    }
    raw->capture_time = capture_time;
    raw->settings = settings;
    return *std::move(raw);
  }

  PreviewFrame CapturePreview() {
    if (!Can(GP_OPERATION_CAPTURE_PREVIEW)) {
      throw CameraError(CameraErrorKind::kNotSupported, description_,
                        "has no live view: its libgphoto2 driver cannot capture previews");
    }
    CameraFile* raw_file = nullptr;
    Check(gp_file_new(&raw_file), "allocate a preview file");
    FilePtr file(raw_file);
    const int result = WhileBusy([&] { return gp_camera_capture_preview(camera(), file.get(), context_.get()); });
    preview_active_ = true;
    Check(result, "live-view preview");
    const char* data = nullptr;
    unsigned long size = 0;
    Check(gp_file_get_data_and_size(file.get(), &data, &size), "read the preview");
    const char* mime = nullptr;
    gp_file_get_mime_type(file.get(), &mime);
    PreviewFrame frame;
    frame.bytes.assign(reinterpret_cast<const uint8_t*>(data), reinterpret_cast<const uint8_t*>(data) + size);
    frame.mime_type = mime && *mime ? mime : GP_MIME_JPEG;
    frame.extension = ExtensionForMime(frame.mime_type);
    frame.time = std::chrono::system_clock::now();
    if (frame.bytes.empty()) {
      throw CameraError(CameraErrorKind::kIo, description_, "live-view preview came back empty");
    }
    return frame;
  }

  // Live view ends by switching the "viewfinder" toggle off (mirror down).
  void StopPreview() {
    if (!preview_active_) return;
    preview_active_ = false;
    WidgetPtr tree = GetTree();
    CameraWidget* viewfinder = FindWidget(tree.get(), {"viewfinder"});
    if (!viewfinder || ReadWidget(viewfinder).value == "0") return;
    SetWidgetText(viewfinder, "0", description_);
    PushTree(tree.get(), "end live view");
  }

  std::vector<CameraEvent> DrainEvents(std::chrono::milliseconds wait) {
    Drain(static_cast<int>(std::clamp<int64_t>(wait.count(), 1, 60000)), options_.drain_limit_ms, nullptr);
    std::vector<CameraEvent> events;
    events.swap(events_);
    return events;
  }

  std::vector<std::string> List(const std::string& folder, bool folders) {
    CameraList* raw_list = nullptr;
    Check(gp_list_new(&raw_list), "allocate a list");
    ListPtr list(raw_list);
    const int result = folders ? gp_camera_folder_list_folders(camera(), folder.c_str(), list.get(), context_.get())
                               : gp_camera_folder_list_files(camera(), folder.c_str(), list.get(), context_.get());
    Check(result, std::string("list the ") + (folders ? "folders" : "files") + " in " + folder);
    std::vector<std::string> names;
    for (int i = 0; i < gp_list_count(list.get()); ++i) {
      const char* name = nullptr;
      if (gp_list_get_name(list.get(), i, &name) == GP_OK && name) names.emplace_back(name);
    }
    std::sort(names.begin(), names.end());
    return names;
  }

  CapturedFrame Download(const std::string& folder, const std::string& name) {
    const std::string path = JoinPath(folder, name);
    CameraFile* raw_file = nullptr;
    Check(gp_file_new(&raw_file), "allocate a file");
    FilePtr file(raw_file);
    Check(gp_camera_file_get(camera(), folder.c_str(), name.c_str(), GP_FILE_TYPE_NORMAL, file.get(), context_.get()),
          "download " + path);
    const char* data = nullptr;
    unsigned long size = 0;
    Check(gp_file_get_data_and_size(file.get(), &data, &size), "read the download of " + path);
    if (size == 0 || !data) {
      throw CameraError(CameraErrorKind::kBadFile, description_, "download " + path + " came back empty");
    }
    CapturedFrame frame;
    frame.bytes.assign(reinterpret_cast<const uint8_t*>(data), reinterpret_cast<const uint8_t*>(data) + size);
    frame.extension = LowerCaseExtension(name);
    frame.source_name = name;
    frame.capture_time = std::chrono::system_clock::now();
    return frame;
  }

  void Delete(const std::string& folder, const std::string& name) {
    Check(gp_camera_file_delete(camera(), folder.c_str(), name.c_str(), context_.get()),
          "delete " + JoinPath(folder, name));
  }

  std::vector<std::string> DescribeConfiguration() {
    WidgetPtr tree = GetTree();
    if (!tree) return {"(no configuration: the libgphoto2 driver offers none)"};
    return DescribeTree(tree.get());
  }

  CameraDeviceInfo Info() {
    CameraDeviceInfo info;
    info.backend = "gphoto2";
    info.model = model_;
    info.port = port_;
    if (WidgetPtr tree = GetTree()) FillInfo(tree.get(), &info);
    if (info.make.empty()) info.make = model_.substr(0, model_.find(' '));
    return info;
  }

 private:
  // Runs `call` again while the camera answers busy, up to busy_timeout_ms.
  template <typename Call>
  int WhileBusy(Call&& call) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.busy_timeout_ms);
    while (true) {
      const int result = call();
      if (result != GP_ERROR_CAMERA_BUSY || std::chrono::steady_clock::now() >= deadline) return result;
      context_.TakeText();
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }

  // Waits up to timeout_ms per event until the camera has nothing more to
  // say (or limit_ms passed), logging every event; files the camera added
  // go to `added` when given.
  void Drain(int timeout_ms, int limit_ms, std::vector<CameraFilePath>* added) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(limit_ms);
    while (true) {
      CameraEventType type = GP_EVENT_UNKNOWN;
      void* data = nullptr;
      const int result = gp_camera_wait_for_event(camera(), timeout_ms, &type, &data, context_.get());
      if (result == GP_ERROR_NOT_SUPPORTED) {  // the driver has no events
        context_.TakeText();
        return;
      }
      if (result < GP_OK) {
        free(data);
        Fail(result, "wait for camera events");
      }
      CameraEvent event;
      event.time = std::chrono::system_clock::now();
      switch (type) {
        case GP_EVENT_TIMEOUT:
          break;
        case GP_EVENT_FILE_ADDED:
        case GP_EVENT_FOLDER_ADDED:
        case GP_EVENT_FILE_CHANGED: {
          const auto* path = static_cast<const CameraFilePath*>(data);
          event.type = type == GP_EVENT_FILE_ADDED     ? CameraEvent::Type::kFileAdded
                       : type == GP_EVENT_FOLDER_ADDED ? CameraEvent::Type::kFolderAdded
                                                       : CameraEvent::Type::kFileChanged;
          if (path) {
            event.detail = JoinPath(path->folder, path->name);
            if (type == GP_EVENT_FILE_ADDED && added) added->push_back(*path);
          }
          break;
        }
        case GP_EVENT_CAPTURE_COMPLETE:
          event.type = CameraEvent::Type::kCaptureComplete;
          break;
        default:
          event.type = CameraEvent::Type::kUnknown;
          if (data) event.detail = static_cast<const char*>(data);
          break;
      }
      free(data);  // the caller owns event data
      context_.TakeText();
      if (type == GP_EVENT_TIMEOUT) return;
      events_.push_back(std::move(event));
      if (std::chrono::steady_clock::now() >= deadline) return;
    }
  }

  // A file left behind costs the camera's RAM, not the frame: note it.
  void DeleteQuietly(const std::string& folder, const std::string& name) {
    try {
      Delete(folder, name);
    } catch (const CameraError& error) {
      events_.push_back({CameraEvent::Type::kNote, error.what(), std::chrono::system_clock::now()});
    }
  }

  void ResolveModelAndPort() {
    model_ = options_.model;
    port_ = options_.port;
    description_ = "camera" + (model_.empty() ? std::string() : " " + model_) +
                   (port_.empty() ? " (autodetect)" : " on " + port_);
    if (!model_.empty() && !port_.empty()) return;

    std::vector<DetectedCamera> detected;
    {
      CameraList* raw_list = nullptr;
      Check(gp_list_new(&raw_list), "allocate a list", Phase::kOpen);
      ListPtr list(raw_list);
      Check(gp_camera_autodetect(list.get(), context_.get()), "autodetect", Phase::kOpen);
      for (int i = 0; i < gp_list_count(list.get()); ++i) {
        const char* name = nullptr;
        const char* value = nullptr;
        gp_list_get_name(list.get(), i, &name);
        gp_list_get_value(list.get(), i, &value);
        detected.push_back({name ? name : "", value ? value : ""});
      }
    }
    std::vector<DetectedCamera> matches;
    for (const DetectedCamera& camera : detected) {
      if ((model_.empty() || camera.model == model_) && (port_.empty() || camera.port == port_)) {
        matches.push_back(camera);
      }
    }
    if (matches.size() == 1) {
      model_ = matches.front().model;
      port_ = matches.front().port;
      return;
    }
    if (matches.empty() && model_.empty() && port_.empty()) {
      throw CameraError(CameraErrorKind::kNotFound, description_,
                        "no camera found by libgphoto2's autodetect: connect the camera by USB and switch it on "
                        "(`scanbench camera list` shows what is on the USB bus)");
    }
    if (matches.empty()) {
      throw CameraError(CameraErrorKind::kNotFound, description_,
                        "not found by libgphoto2's autodetect (it found: " + ListDetected(detected) +
                            "); connect and switch on the camera, or name the port (e.g. disk:/folder for "
                            "model \"Directory Browse\")");
    }
    throw CameraError(CameraErrorKind::kNotFound, description_,
                      "several cameras found (" + ListDetected(matches) + "): choose one by model and port");
  }

  void InitCamera() {
    CameraAbilitiesList* raw_abilities = nullptr;
    Check(gp_abilities_list_new(&raw_abilities), "allocate the driver list", Phase::kOpen);
    AbilitiesListPtr abilities(raw_abilities);
    Check(gp_abilities_list_load(abilities.get(), context_.get()), "load the camera drivers", Phase::kOpen);
    const int model_index = gp_abilities_list_lookup_model(abilities.get(), model_.c_str());
    if (model_index < GP_OK) {
      throw CameraError(CameraErrorKind::kNotSupported, description_,
                        "libgphoto2 knows no camera model '" + model_ +
                            "' (`scanbench camera list` shows the names it uses)");
    }
    Check(gp_abilities_list_get_abilities(abilities.get(), model_index, &abilities_), "read the driver",
          Phase::kOpen);

    GPPortInfoList* raw_ports = nullptr;
    Check(gp_port_info_list_new(&raw_ports), "allocate the port list", Phase::kOpen);
    PortInfoListPtr ports(raw_ports);
    Check(gp_port_info_list_load(ports.get()), "load the port drivers", Phase::kOpen);
    const int port_index = gp_port_info_list_lookup_path(ports.get(), port_.c_str());
    if (port_index < GP_OK) Fail(port_index, "find port " + port_, Phase::kOpen);
    GPPortInfo port_info;
    Check(gp_port_info_list_get_info(ports.get(), port_index, &port_info), "read port " + port_, Phase::kOpen);

    ::Camera* raw_camera = nullptr;
    Check(gp_camera_new(&raw_camera), "allocate the camera", Phase::kOpen);
    CameraPtr camera(raw_camera);
    Check(gp_camera_set_abilities(camera.get(), abilities_), "select the driver", Phase::kOpen);
    Check(gp_camera_set_port_info(camera.get(), port_info), "select port " + port_, Phase::kOpen);
    Check(gp_camera_init(camera.get(), context_.get()), "open", Phase::kOpen);
    camera_ = std::move(camera);
  }

  GPhotoCameraOptions options_;
  Context context_;
  CameraPtr camera_;
  CameraAbilities abilities_{};
  std::string model_, port_;
  std::string description_ = "camera";
  bool preview_active_ = false;
  std::vector<CameraEvent> events_;
};

GPhotoCamera::GPhotoCamera(GPhotoCameraOptions options) : options_(std::move(options)) {
  options_.Check();
  impl_ = std::make_unique<Impl>(options_);
  impl_->Open();
}

GPhotoCamera::~GPhotoCamera() = default;

std::string GPhotoCamera::description() const { return impl_->description(); }
CameraDeviceInfo GPhotoCamera::Info() { return impl_->Info(); }

CameraSettingState GPhotoCamera::GetSetting(CameraSetting setting) {
  WidgetPtr tree = impl_->RequireTree(std::string(CameraSettingName(setting)) + " setting");
  std::optional<CameraSettingState> state = ReadSetting(tree.get(), setting);
  if (!state) {
    std::string names;
    for (const std::string& name : SettingWidgetNames(setting)) names += (names.empty() ? "" : " or ") + name;
    throw CameraError(CameraErrorKind::kNotSupported, description(),
                      std::string("has no ") + CameraSettingName(setting) + " setting (no widget named " + names +
                          "; `scanbench camera info --all` lists what it has)");
  }
  return *state;
}

void GPhotoCamera::SetSetting(CameraSetting setting, const std::string& value) {
  const std::string name = CameraSettingName(setting);
  WidgetPtr tree = impl_->RequireTree(name + " setting");
  CameraWidget* widget = ApplySetting(tree.get(), setting, value, description());
  const std::string wanted = ReadWidget(widget).value;
  impl_->PushTree(tree.get(), "set the " + name + " to " + wanted);
  // Some refusals are silent (a dial that overrides the host): read it back,
  // giving the camera a moment to report the new value.
  CameraSettingState now = GetSetting(setting);
  for (int attempt = 0; attempt < 5 && now.current != wanted; ++attempt) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    now = GetSetting(setting);
  }
  if (now.current != wanted) {
    throw CameraError(CameraErrorKind::kWrongMode, description(),
                      "the " + name + " stayed at '" + now.current + "' after setting it to '" + wanted +
                          "': is the mode dial on M?");
  }
}

std::vector<std::string> GPhotoCamera::CheckReady() { return impl_->CheckReady(); }
CapturedFrame GPhotoCamera::Capture() { return impl_->Capture(); }
PreviewFrame GPhotoCamera::CapturePreview() { return impl_->CapturePreview(); }
void GPhotoCamera::StopPreview() { impl_->StopPreview(); }

std::vector<CameraEvent> GPhotoCamera::DrainEvents(std::chrono::milliseconds wait) {
  return impl_->DrainEvents(wait);
}

void GPhotoCamera::Reconnect() {
  // The same model, but a replugged camera gets a new USB address: find it
  // again unless the caller pinned the port.
  GPhotoCameraOptions reopen = options_;
  if (reopen.model.empty()) reopen.model = impl_->model();
  impl_->Close();
  impl_ = std::make_unique<Impl>(reopen);
  impl_->Open();
}

std::vector<std::string> GPhotoCamera::ListFolders(const std::string& folder) { return impl_->List(folder, true); }
std::vector<std::string> GPhotoCamera::ListFiles(const std::string& folder) { return impl_->List(folder, false); }

CapturedFrame GPhotoCamera::Download(const std::string& folder, const std::string& name) {
  return impl_->Download(folder, name);
}

void GPhotoCamera::Delete(const std::string& folder, const std::string& name) { impl_->Delete(folder, name); }

std::vector<std::string> GPhotoCamera::DescribeConfiguration() { return impl_->DescribeConfiguration(); }

}  // namespace scanbench
