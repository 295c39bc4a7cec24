// A real camera over USB through libgphoto2 (a Nikon D5100 on the bench; any
// PTP camera libgphoto2 drives). Frames are captured to the camera's internal
// RAM in RAW, downloaded and deleted there, so nothing piles up on the card.
// libgphoto2 stays private: this header does not include it.
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "app/devices/camera/camera.h"

namespace scanbench {

struct GPhotoCameraOptions {
  // libgphoto2's model name ("Nikon DSC D5100 (PTP mode)"); "" = the one camera autodetect finds.
  std::string model;
  // libgphoto2's port ("usb:001,004"; "disk:/some/folder" with model "Directory Browse"); "" = autodetect's.
  std::string port;
  bool capture_to_ram = true;            // capturetarget "Internal RAM"; false: "Memory card"
  bool force_raw_only = true;            // set image quality to RAW only (e.g. "NEF (Raw)") where offered
  bool disable_auto_iso = true;          // switch Auto ISO off: the ISO must not change between frames
  bool require_manual_exposure = true;   // refuse to capture unless the mode dial is on M
  bool require_manual_focus = true;      // refuse to capture unless the focus is manual (lens switch on M)
  bool delete_after_download = true;     // delete each downloaded file from the camera's RAM or card
  int busy_timeout_ms = 3000;            // keep retrying a capture the camera refuses as busy, [0, 60000]
  int event_timeout_ms = 200;            // wait for each event while draining after a capture, [1, 10000]
  int drain_limit_ms = 5000;             // stop draining after this long even if events keep coming, [0, 60000]

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

class GPhotoCamera : public Camera {
 public:
  // Finds (autodetect, unless both model and port are given) and opens the
  // camera, then sets what it may set itself (capture target, RAW only, Auto
  // ISO off). The mode dial and focus are checked by CheckReady() and at
  // every Capture(), not here, so that `camera info` works in any mode.
  // Throws CameraError: kNotFound (no camera, not the one named, several
  // found without a choice), kClaimed (gvfs or another program holds it),
  // kPermissionDenied, kBusy, ...
  explicit GPhotoCamera(GPhotoCameraOptions options = {});
  ~GPhotoCamera() override;
  GPhotoCamera(const GPhotoCamera&) = delete;
  GPhotoCamera& operator=(const GPhotoCamera&) = delete;

  std::string description() const override;
  CameraDeviceInfo Info() override;
  CameraSettingState GetSetting(CameraSetting setting) override;
  void SetSetting(CameraSetting setting, const std::string& value) override;
  std::vector<std::string> CheckReady() override;
  // Triggers the capture, drains the events (a RAW+JPEG setting adds a
  // second file), downloads every new file and deletes it on the camera,
  // and returns the RAW one.
  CapturedFrame Capture() override;
  PreviewFrame CapturePreview() override;
  void StopPreview() override;
  std::vector<CameraEvent> DrainEvents(std::chrono::milliseconds wait) override;
  void Reconnect() override;

  // The camera's file system, as Capture uses it (absolute camera paths, "/"
  // the root). Download names the file in every error; the frame's
  // capture_time is the download time and its settings are unknown.
  std::vector<std::string> ListFolders(const std::string& folder);
  std::vector<std::string> ListFiles(const std::string& folder);
  CapturedFrame Download(const std::string& folder, const std::string& name);
  void Delete(const std::string& folder, const std::string& name);

  // Every configuration widget as "path = value" lines (choices appended), for
  // `scanbench camera info --all` and bug reports.
  std::vector<std::string> DescribeConfiguration();

  const GPhotoCameraOptions& options() const { return options_; }

 private:
  class Impl;
  GPhotoCameraOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace scanbench
