// camera: the camera by hand (bench set-up, checking the tether): list what is
// plugged in, show a camera's identity, settings and readiness, take one RAW
// frame or one live-view frame.
#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "app/cli/command_util.h"
#include "app/cli/commands.h"
#include "app/cli/run_controller.h"
#include "app/devices/camera/camera.h"
#include "app/devices/camera/device_discovery.h"
#include "app/devices/camera/gphoto2_camera.h"
#include "app/devices/camera/replay_camera.h"
#include "app/devices/camera/simulated_camera.h"
#include "app/io/file_util.h"

namespace scanbench {

namespace {

struct CameraCommandState {
  std::string model;          // --model (libgphoto2's name)
  std::string port;           // --port
  std::string replay_folder;  // --replay DIR
  bool simulated = false;     // --simulated
  int led = -1;               // --led with --simulated; -1 = none lit (dark frame)
  bool skip_ready_check = false;  // --skip-ready-check: no mode dial / focus requirement
  bool to_card = false;       // --to-card: capture target memory card instead of RAM
  bool all = false;           // info --all
  std::string out;            // capture / preview --out
  std::string iso, shutter, aperture;  // capture settings
  double watch_seconds = 0;   // list --watch
};

std::atomic<bool> interrupted{false};
extern "C" void OnCameraInterrupt(int) { interrupted = true; }

std::unique_ptr<Camera> OpenCamera(const CameraCommandState& state) {
  if (state.simulated) {
    std::cout << "Building the simulated rig...\n";
    SimulatedRigOptions rig_options;
    auto rig = std::make_shared<const SimulatedRig>(rig_options, TextileScene(),
                                                    MakeDefaultSimulatedRig(rig_options.width, rig_options.height));
    const std::optional<int> led = state.led >= 0 ? std::optional<int>(state.led) : std::nullopt;
    return std::make_unique<SimulatedCamera>(rig, [led] { return led; });
  }
  if (!state.replay_folder.empty()) {
    ReplayCameraOptions options;
    options.folder = state.replay_folder;
    return std::make_unique<ReplayCamera>(options);
  }
  GPhotoCameraOptions options;
  options.model = state.model;
  options.port = state.port;
  options.capture_to_ram = !state.to_card;
  options.require_manual_exposure = !state.skip_ready_check;
  options.require_manual_focus = !state.skip_ready_check;
  return std::make_unique<GPhotoCamera>(options);
}

std::string FormatSeconds(double seconds) {
  std::ostringstream text;
  if (seconds > 0 && seconds < 1) {
    text << "1/" << std::lround(1 / seconds) << " s";
  } else {
    text << seconds << " s";
  }
  return text.str();
}

std::string ExposureText(const ExposureSettings& settings) {
  std::ostringstream text;
  text << "ISO " << (settings.iso > 0 ? std::to_string(std::lround(settings.iso)) : "?") << ", "
       << (settings.exposure_time_s > 0 ? FormatSeconds(settings.exposure_time_s) : "? s") << ", f/";
  if (settings.f_number > 0) {
    text << settings.f_number;
  } else {
    text << "?";
  }
  return text.str();
}

void PrintEvents(Camera& camera) {
  for (const CameraEvent& event : camera.DrainEvents(std::chrono::milliseconds(0))) {
    std::cout << "  event: " << CameraEventTypeName(event.type) << (event.detail.empty() ? "" : ": " + event.detail)
              << "\n";
  }
}

void PrintSnapshot(const DeviceSnapshot& snapshot) {
  std::cout << "Cameras (libgphoto2 autodetect):\n";
  if (snapshot.cameras.empty()) std::cout << "  (none)\n";
  for (const DetectedCamera& camera : snapshot.cameras) {
    std::cout << "  " << std::left << std::setw(14) << camera.port << " " << camera.model << "\n";
  }
  std::cout << "USB devices:\n";
  if (snapshot.usb.empty()) std::cout << "  (none visible)\n";
  for (const UsbDeviceInfo& device : snapshot.usb) {
    std::cout << "  " << std::left << std::setw(14) << device.GphotoPort() << " " << device.UsbId() << "  "
              << std::setw(10) << (device.port_path.empty() ? "-" : device.port_path) << " "
              << (device.camera_model.empty() ? "" : "camera: " + device.camera_model) << "\n";
  }
  if (!snapshot.error.empty()) std::cout << "  (problem: " << snapshot.error << ")\n";
}

int ListCameras(const CameraCommandState& state) {
  if (state.watch_seconds <= 0) {
    DeviceSnapshot snapshot;
    snapshot.usb = ListUsbDevices();
    snapshot.cameras = DetectCameras();
    PrintSnapshot(snapshot);
    return kExitSuccess;
  }
  interrupted = false;
  struct sigaction action{};
  struct sigaction previous{};
  action.sa_handler = &OnCameraInterrupt;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, &previous);
  DeviceMonitor monitor(DeviceMonitorOptions{}, [](const DeviceSnapshot& snapshot) {
    std::cout << "-- changed --\n";
    PrintSnapshot(snapshot);
    std::cout.flush();
  });
  PrintSnapshot(monitor.Latest());
  std::cout << "Watching for " << state.watch_seconds << " s ("
            << (monitor.using_hotplug() ? "libusb hotplug" : "polling") << "; Ctrl-C ends)...\n";
  std::cout.flush();
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(state.watch_seconds);
  while (!interrupted && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  monitor.Stop();
  sigaction(SIGINT, &previous, nullptr);
  return interrupted ? kExitCancelled : kExitSuccess;
}

int ShowInfo(const CameraCommandState& state) {
  std::unique_ptr<Camera> camera = OpenCamera(state);
  const CameraDeviceInfo info = camera->Info();
  std::cout << camera->description() << "\n";
  const auto line = [](const char* name, const std::string& value) {
    if (!value.empty()) std::cout << "  " << std::left << std::setw(14) << name << value << "\n";
  };
  line("backend", info.backend);
  line("make", info.make);
  line("model", info.model);
  line("serial", info.serial);
  line("lens", info.lens);
  line("firmware", info.firmware);
  line("port", info.port);
  for (const CameraSetting setting : {CameraSetting::kIso, CameraSetting::kShutter, CameraSetting::kAperture}) {
    // The GUI's Capture page offers the same (ExposureChoicesOf).
    const ExposureChoices choices = ExposureChoicesOf(*camera, setting);
    std::string text = "(not available: " + choices.unavailable + ")";
    if (choices.state) {
      const CameraSettingState& value = *choices.state;
      text = value.current.empty() ? "?" : value.current;
      if (value.read_only) text += " (read-only)";
      if (!value.choices.empty()) {
        text += "  [";
        for (size_t i = 0; i < value.choices.size(); ++i) text += (i ? ", " : "") + value.choices[i];
        text += "]";
      }
    }
    line(CameraSettingName(setting), text);
  }
  const std::vector<std::string> problems = camera->CheckReady();
  if (problems.empty()) {
    std::cout << "Ready to capture.\n";
  } else {
    std::cout << "Not ready to capture:\n";
    for (const std::string& problem : problems) std::cout << "  - " << problem << "\n";
  }
  if (state.all) {
    if (auto* gphoto = dynamic_cast<GPhotoCamera*>(camera.get())) {
      std::cout << "Configuration:\n";
      for (const std::string& entry : gphoto->DescribeConfiguration()) std::cout << "  " << entry << "\n";
    }
  }
  return kExitSuccess;
}

// --out FILE, or --out FOLDER (then the camera's file name).
std::filesystem::path OutputPath(const std::string& out, const std::string& name) {
  const std::filesystem::path path(out);
  return std::filesystem::is_directory(path) ? path / name : path;
}

int CaptureFrame(const CameraCommandState& state) {
  // Refuse before the shutter fires rather than after.
  if (!std::filesystem::is_directory(state.out) && std::filesystem::exists(state.out)) {
    throw std::runtime_error(state.out + ": already exists and is never overwritten");
  }
  std::unique_ptr<Camera> camera = OpenCamera(state);
  if (!state.iso.empty()) camera->SetSetting(CameraSetting::kIso, state.iso);
  if (!state.shutter.empty()) camera->SetSetting(CameraSetting::kShutter, state.shutter);
  if (!state.aperture.empty()) camera->SetSetting(CameraSetting::kAperture, state.aperture);
  const CapturedFrame frame = camera->Capture();
  const std::filesystem::path path = OutputPath(state.out, frame.source_name);
  WriteFileAtomic(path, frame.bytes, OverwritePolicy::kRefuse);
  std::cout << camera->description() << ": wrote " << path.string() << " (" << frame.bytes.size() << " bytes, "
            << ExposureText(frame.settings) << ", from " << frame.source_name << ")\n";
  if (!state.out.empty() && LowerCaseExtension(path.filename().string()) != frame.extension) {
    std::cout << "Note: the file is a " << frame.extension << " but is named " << path.filename().string() << "\n";
  }
  PrintEvents(*camera);
  return kExitSuccess;
}

int CapturePreview(const CameraCommandState& state) {
  if (!std::filesystem::is_directory(state.out) && std::filesystem::exists(state.out)) {
    throw std::runtime_error(state.out + ": already exists and is never overwritten");
  }
  std::unique_ptr<Camera> camera = OpenCamera(state);
  const PreviewFrame preview = camera->CapturePreview();
  camera->StopPreview();
  const std::filesystem::path path = OutputPath(state.out, "preview" + preview.extension);
  WriteFileAtomic(path, preview.bytes, OverwritePolicy::kRefuse);
  std::cout << camera->description() << ": wrote " << path.string() << " (" << preview.mime_type << ", "
            << preview.bytes.size() << " bytes)\n";
  return kExitSuccess;
}

void AddSourceOptions(CLI::App& command, CameraCommandState& state) {
  auto* model = command.add_option("--model", state.model,
                                   "libgphoto2 model name, e.g. \"Nikon DSC D5100 (PTP mode)\" (default: the one "
                                   "camera autodetect finds)");
  auto* port = command.add_option("--port", state.port,
                                  "libgphoto2 port, e.g. usb:001,004 (`scanbench camera list`), or disk:/folder "
                                  "with --model \"Directory Browse\"");
  auto* replay = command.add_option("--replay", state.replay_folder,
                                    "Serve the RAW files of this folder in name order instead of a camera");
  auto* simulated = command.add_flag("--simulated", state.simulated, "Use the simulated rig's camera");
  command.add_option("--led", state.led, "With --simulated: the LED lit during the capture (default: none, dark)")
      ->check(CLI::Range(0, 31))
      ->needs(simulated);
  auto* skip = command.add_flag("--skip-ready-check", state.skip_ready_check,
                                "Capture even if the mode dial is not on M or the focus is automatic");
  auto* card = command.add_flag("--to-card", state.to_card,
                                "Capture to the memory card instead of the camera's RAM (still downloaded and "
                                "deleted)");
  for (CLI::Option* gphoto_only : {model, port, skip, card}) {
    gphoto_only->excludes(replay)->excludes(simulated);
  }
  replay->excludes(simulated);
}

}  // namespace

void RegisterCameraCommands(CLI::App& app, int* exit_code) {
  auto state = std::make_shared<CameraCommandState>();
  CLI::App* camera = app.add_subcommand(
      "camera", "The camera by hand: list, info, capture (one RAW frame), preview (one live-view frame)");
  camera->require_subcommand(1);

  CLI::App* list = camera->add_subcommand("list", "Cameras libgphoto2 finds and the USB devices (VID:PID)");
  list->add_option("--watch", state->watch_seconds,
                   "Keep watching this many seconds, printing every change (libusb hotplug, else polling)")
      ->check(CLI::Range(0.0, 86400.0));
  list->callback([state, exit_code] { Guarded(exit_code, [&] { return ListCameras(*state); }); });

  CLI::App* info = camera->add_subcommand("info", "Identity, ISO / shutter / aperture with their allowed values, "
                                                  "and whether it is ready to capture");
  AddSourceOptions(*info, *state);
  info->add_flag("--all", state->all, "Also every libgphoto2 configuration widget");
  info->callback([state, exit_code] { Guarded(exit_code, [&] { return ShowInfo(*state); }); });

  CLI::App* capture = camera->add_subcommand("capture", "Take one RAW frame and write it (never overwrites)");
  AddSourceOptions(*capture, *state);
  capture->add_option("--out", state->out, "File to write, or a folder (then the camera's file name)")->required();
  capture->add_option("--iso", state->iso, "ISO first, e.g. 100");
  capture->add_option("--shutter", state->shutter, "Shutter speed first, e.g. 1/125 or 0.5");
  capture->add_option("--aperture", state->aperture, "Aperture first, e.g. f/8 or 8");
  capture->callback([state, exit_code] { Guarded(exit_code, [&] { return CaptureFrame(*state); }); });

  CLI::App* preview = camera->add_subcommand("preview", "Take one live-view frame and write it (JPEG from a "
                                                        "camera, PPM from --simulated / --replay)");
  AddSourceOptions(*preview, *state);
  preview->add_option("--out", state->out, "File to write, or a folder (then preview.<ext>)")->required();
  preview->callback([state, exit_code] { Guarded(exit_code, [&] { return CapturePreview(*state); }); });
}

}  // namespace scanbench
