#include "app/devices/camera/replay_camera.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "app/devices/camera/raw_preview.h"
#include "app/io/file_util.h"
#include "app/io/raw_decoder.h"

namespace scanbench {

namespace {

std::string FormatSetting(CameraSetting setting, double value) {
  char text[32];
  switch (setting) {
    case CameraSetting::kIso:
      std::snprintf(text, sizeof(text), "%g", value);
      break;
    case CameraSetting::kShutter:
      // 1/125 rather than 0.008, as a camera shows it.
      if (value < 1 && std::abs(1 / value - std::round(1 / value)) < 1e-3 * (1 / value)) {
        std::snprintf(text, sizeof(text), "1/%g", std::round(1 / value));
      } else {
        std::snprintf(text, sizeof(text), "%g", value);
      }
      break;
    case CameraSetting::kAperture:
      std::snprintf(text, sizeof(text), "f/%g", value);
      break;
  }
  return text;
}

}  // namespace

bool NaturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      size_t i_end = i, j_end = j;
      while (i_end < a.size() && std::isdigit(static_cast<unsigned char>(a[i_end]))) ++i_end;
      while (j_end < b.size() && std::isdigit(static_cast<unsigned char>(b[j_end]))) ++j_end;
      // Compare the runs' values without overflow: drop leading zeros, then
      // the longer run is larger, else compare digit by digit.
      size_t i_start = i, j_start = j;
      while (i_start + 1 < i_end && a[i_start] == '0') ++i_start;
      while (j_start + 1 < j_end && b[j_start] == '0') ++j_start;
      const size_t i_length = i_end - i_start, j_length = j_end - j_start;
      if (i_length != j_length) return i_length < j_length;
      const int order = a.compare(i_start, i_length, b, j_start, j_length);
      if (order != 0) return order < 0;
      i = i_end;
      j = j_end;
      continue;
    }
    const int ca = std::tolower(static_cast<unsigned char>(a[i]));
    const int cb = std::tolower(static_cast<unsigned char>(b[j]));
    if (ca != cb) return ca < cb;
    ++i;
    ++j;
  }
  if ((a.size() - i) != (b.size() - j)) return (a.size() - i) < (b.size() - j);
  return a < b;
}

void ReplayCameraOptions::Check() const {
  if (folder.empty()) throw std::invalid_argument("ReplayCameraOptions.folder is empty: name the folder of RAW files");
  for (const std::string& extension : extensions) {
    if (extension.size() < 2 || extension[0] != '.') {
      throw std::invalid_argument("ReplayCameraOptions.extensions: '" + extension +
                                  "' must start with a dot and name an extension (\".nef\")");
    }
  }
}

ReplayCamera::ReplayCamera(ReplayCameraOptions options) : options_(std::move(options)) {
  options_.Check();
  std::vector<std::string> extensions = options_.extensions.empty() ? RawFileExtensions() : options_.extensions;
  for (std::string& extension : extensions) extension = LowerCaseExtension("x" + extension);
  std::error_code error;
  if (!std::filesystem::is_directory(options_.folder, error)) {
    throw CameraError(CameraErrorKind::kNotFound, description(),
                      "the folder " + options_.folder.string() + " does not exist or is not a folder");
  }
  for (const auto& entry : std::filesystem::directory_iterator(options_.folder, error)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name[0] == '.' || !entry.is_regular_file(error)) continue;
    const std::string extension = LowerCaseExtension(name);
    if (std::find(extensions.begin(), extensions.end(), extension) != extensions.end()) {
      files_.push_back(entry.path());
    }
  }
  if (error) {
    throw CameraError(CameraErrorKind::kNotFound, description(), "cannot list the folder: " + error.message());
  }
  if (files_.empty()) {
    std::string list;
    for (size_t i = 0; i < extensions.size(); ++i) list += (i ? " " : "") + extensions[i];
    throw CameraError(CameraErrorKind::kNotFound, description(), "no RAW file (" + list + ") in the folder");
  }
  std::sort(files_.begin(), files_.end(), [](const auto& a, const auto& b) {
    return NaturalLess(a.filename().string(), b.filename().string());
  });
  metadata_.resize(files_.size());
}

std::string ReplayCamera::description() const { return "replay camera on " + options_.folder.string(); }

CameraDeviceInfo ReplayCamera::Info() {
  if (!info_) {
    CameraDeviceInfo info;
    info.backend = "replay";
    info.port = options_.folder.string();
    try {
      const DecodedRaw first = DecodeRawFileWithInfo(files_.front());
      info.make = first.make;
      info.model = first.model;
      info.serial = first.serial;
      info.firmware = first.software;
    } catch (const std::exception&) {
      // Unreadable metadata is not an identity problem; Capture() reports the file.
    }
    info_ = info;
  }
  return *info_;
}

CameraSettingState ReplayCamera::GetSetting(CameraSetting setting) {
  CameraSettingState state;
  state.setting = setting;
  state.source = "recorded only: the replayed files decide";
  const auto& set = set_values_[static_cast<int>(setting)];
  if (set) {
    state.current = *set;
    return state;
  }
  const size_t index = std::min(next_, files_.size() - 1);
  if (!metadata_[index]) {
    ExposureSettings settings;
    try {
      const DecodedRaw decoded = DecodeRawFileWithInfo(files_[index]);
      settings = {decoded.iso, decoded.exposure_time_s, decoded.f_number};
    } catch (const std::exception&) {
      // Unknown until Capture() names the file.
    }
    metadata_[index] = settings;
  }
  const double value = ExposureValue(*metadata_[index], setting);
  if (value > 0) state.current = FormatSetting(setting, value);
  return state;
}

void ReplayCamera::SetSetting(CameraSetting setting, const std::string& value) {
  if (!ParseSettingValue(setting, value)) {
    throw CameraError(CameraErrorKind::kNotSupported, description(),
                      std::string(CameraSettingName(setting)) + " '" + value +
                          "' is not a number (the replay camera records settings as numbers)");
  }
  set_values_[static_cast<int>(setting)] = value;
}

std::vector<std::string> ReplayCamera::CheckReady() {
  if (next_ < files_.size() || options_.loop) return {};
  return {"all " + std::to_string(files_.size()) + " files have been served"};
}

CapturedFrame ReplayCamera::Capture() {
  if (next_ >= files_.size()) {
    if (!options_.loop) {
      throw CameraError(CameraErrorKind::kExhausted, description(),
                        "all " + std::to_string(files_.size()) + " RAW files have been served (the last was " +
                            files_.back().filename().string() + ")");
    }
    next_ = 0;
  }
  const size_t index = next_++;
  const std::filesystem::path& path = files_[index];
  const std::string frame_name = "frame " + std::to_string(index + 1) + " of " + std::to_string(files_.size());
  CapturedFrame frame;
  frame.capture_time = std::chrono::system_clock::now();
  try {
    frame.bytes = ReadFileBytes(path);
  } catch (const std::exception& error) {
    throw CameraError(CameraErrorKind::kBadFile, description(), frame_name + ": " + error.what());
  }
  frame.extension = LowerCaseExtension(path.filename().string());
  frame.source_name = path.filename().string();
  if (options_.validate) {
    DecodedRaw decoded;
    try {
      decoded = DecodeRawWithInfo(frame.bytes, path.string());
    } catch (const std::exception& error) {
      throw CameraError(CameraErrorKind::kBadFile, description(), frame_name + ": " + error.what());
    }
    if (options_.require_same_size) {
      if (!width_) {
        width_ = decoded.image.width();
        height_ = decoded.image.height();
      } else if (decoded.image.width() != *width_ || decoded.image.height() != *height_) {
        throw CameraError(CameraErrorKind::kBadFile, description(),
                          frame_name + ": " + path.string() + ": image is " + std::to_string(decoded.image.width()) +
                              "x" + std::to_string(decoded.image.height()) + " but the first replayed frame was " +
                              std::to_string(*width_) + "x" + std::to_string(*height_));
      }
    }
    frame.settings = {decoded.iso, decoded.exposure_time_s, decoded.f_number};
    metadata_[index] = frame.settings;
  }
  last_served_ = index;
  events_.push_back({CameraEvent::Type::kFileAdded, path.string(), frame.capture_time});
  return frame;
}

PreviewFrame ReplayCamera::CapturePreview() {
  const size_t index = next_ < files_.size() ? next_ : last_served_.value_or(0);
  PreviewFrame preview;
  try {
    preview.bytes = EncodePreviewPpm(DecodeRawFileWithInfo(files_[index]).image);
  } catch (const std::exception& error) {
    throw CameraError(CameraErrorKind::kBadFile, description(), std::string("preview: ") + error.what());
  }
  preview.mime_type = "image/x-portable-pixmap";
  preview.extension = ".ppm";
  preview.time = std::chrono::system_clock::now();
  return preview;
}

std::vector<CameraEvent> ReplayCamera::DrainEvents(std::chrono::milliseconds) {
  std::vector<CameraEvent> events;
  events.swap(events_);
  return events;
}

}  // namespace scanbench
