// A camera that serves the RAW files of a folder, one per Capture(), in
// name order: real NEFs from the bench (dropped in by hand) or frames of an
// earlier session, to run the capture path without a camera. Each file is
// checked with the LibRaw decoder before it is served.
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "app/devices/camera/camera.h"

namespace scanbench {

struct ReplayCameraOptions {
  std::filesystem::path folder;  // where the RAW files are; must exist
  // Served extensions, lower case with the dot, matched case-insensitively; empty = RawFileExtensions().
  std::vector<std::string> extensions;
  bool loop = false;              // after the last file start again; false: Capture() then throws kExhausted
  bool validate = true;           // decode each file (LibRaw) before serving it; errors name the file
  bool require_same_size = true;  // with validate: every frame must have the first served frame's size

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

class ReplayCamera : public Camera {
 public:
  // Lists the folder. Throws CameraError: kNotFound when the folder does not
  // exist or holds no file with a served extension.
  explicit ReplayCamera(ReplayCameraOptions options);

  std::string description() const override;  // "replay camera on <folder>"
  // make, model, serial from the first file's metadata (decoded once).
  CameraDeviceInfo Info() override;
  // Free values (no choices): the value last set, else the next file's metadata.
  CameraSettingState GetSetting(CameraSetting setting) override;
  // Recorded only (the files are what they are); must parse as a number.
  void SetSetting(CameraSetting setting, const std::string& value) override;
  std::vector<std::string> CheckReady() override;  // empty while files remain
  // The next file's bytes; settings from its metadata (0 where it has none).
  // Throws CameraError kBadFile naming the file when it cannot be read or
  // decoded or has another size than the first, kExhausted after the last.
  // A bad file is skipped by the next call (as a retried capture would).
  CapturedFrame Capture() override;
  // A small PPM of the next file (or the last served one once exhausted).
  PreviewFrame CapturePreview() override;
  void StopPreview() override {}
  std::vector<CameraEvent> DrainEvents(std::chrono::milliseconds wait) override;
  void Reconnect() override {}

  const std::vector<std::filesystem::path>& files() const { return files_; }
  // Index into files() of the file the next Capture() serves.
  size_t next_index() const { return next_; }
  void Rewind() { next_ = 0; }

 private:
  ReplayCameraOptions options_;
  std::vector<std::filesystem::path> files_;
  size_t next_ = 0;
  std::optional<size_t> last_served_;
  std::optional<int> width_, height_;  // of the first served frame
  std::optional<CameraDeviceInfo> info_;
  std::vector<std::optional<ExposureSettings>> metadata_;  // per file, decoded on demand
  std::optional<std::string> set_values_[3];
  std::vector<CameraEvent> events_;
};

// Orders names as people do: digit runs by value ("led_2" before "led_10"),
// the rest case-insensitively.
bool NaturalLess(const std::string& a, const std::string& b);

}  // namespace scanbench
