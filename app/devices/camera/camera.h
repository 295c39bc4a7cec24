// What the capture sequencer needs from a camera: who it is, its exposure
// settings (ISO, shutter, aperture) within the values it allows, one RAW
// frame at a time into memory, live-view previews and the events it raised.
//
// Implementations: GPhotoCamera (a real camera over USB, libgphoto2),
// ReplayCamera (RAW files from a folder, e.g. real NEFs) and SimulatedCamera
// (renders the frame for whichever LED is actually lit). None is
// thread-safe: one owner at a time.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace scanbench {

enum class CameraErrorKind {
  kNotFound,          // no camera attached, or not the one asked for; no such port or file
  kBusy,              // the camera is busy (still writing, in a menu); retrying may help
  kClaimed,           // another program holds the camera's USB interface (gvfs, another gphoto2)
  kPermissionDenied,  // no access to the USB device (udev rules, plugdev group)
  kNotSupported,      // a setting, value or operation this camera or driver does not have
  kWrongMode,         // the camera must be changed by hand first (mode dial on M, manual focus, RAW)
  kDisconnected,      // it went away mid-session (unplugged, switched off, asleep)
  kTimeout,           // no answer in time
  kIo,                // any other transfer or library failure
  kBadFile,           // a RAW file that does not decode (replay) or a download that is not RAW
  kExhausted,         // replay: every file has been served
};

const char* CameraErrorKindName(CameraErrorKind kind);

// Every camera failure. what() is "<camera>: <problem>", the problem naming
// the value at fault and, where the operator can fix it, how.
class CameraError : public std::runtime_error {
 public:
  CameraError(CameraErrorKind kind, const std::string& camera, const std::string& problem)
      : std::runtime_error(camera + ": " + problem), kind_(kind), camera_(camera) {}

  CameraErrorKind kind() const { return kind_; }
  // The camera's description() ("camera Nikon DSC D5100 (PTP mode) on usb:001,004").
  const std::string& camera() const { return camera_; }

 private:
  CameraErrorKind kind_;
  std::string camera_;
};

// Who the camera is. Empty strings are unknown.
struct CameraDeviceInfo {
  std::string backend;   // "gphoto2", "replay" or "simulated"
  std::string make;      // "Nikon Corporation"
  std::string model;     // "D5100" (libgphoto2: "Nikon DSC D5100 (PTP mode)")
  std::string serial;
  std::string lens;      // "AF-S Nikkor 85mm f/1.8G"
  std::string firmware;  // the camera's firmware version
  std::string port;      // "usb:001,004", the replay folder, "simulated"
};

enum class CameraSetting { kIso, kShutter, kAperture };

// "ISO", "shutter speed", "aperture", for messages.
const char* CameraSettingName(CameraSetting setting);

// The exposure a frame was (or will be) taken with; 0 = unknown.
struct ExposureSettings {
  double iso = 0;
  double exposure_time_s = 0;
  double f_number = 0;
};

// The one of three per-setting values that `setting` names.
template <typename T>
const T& ForSetting(CameraSetting setting, const T& iso, const T& shutter, const T& aperture) {
  switch (setting) {
    case CameraSetting::kIso:
      return iso;
    case CameraSetting::kShutter:
      return shutter;
    case CameraSetting::kAperture:
      return aperture;
  }
  return iso;
}

// The field of `settings` that `setting` names.
double ExposureValue(const ExposureSettings& settings, CameraSetting setting);

// One setting as the camera states it. Values are the camera's own text
// ("1/125", "f/5.6", "100").
struct CameraSettingState {
  CameraSetting setting = CameraSetting::kIso;
  std::string current;               // "" = unknown
  std::vector<std::string> choices;  // allowed values in the camera's order; empty = free (see range)
  std::optional<double> range_min;   // numeric slider bounds, when the camera gives a range
  std::optional<double> range_max;
  bool read_only = false;            // e.g. the aperture of a lens without CPU
  std::string source;                // where it comes from, for messages ("widget shutterspeed2")
};

// The setting's text as a number: ISO "100" / "ISO 100" -> 100; shutter
// "1/125", "10/13", "1 1/3", "0.0080s", "30" -> seconds; aperture "f/5.6",
// "F5.6", "5.6" -> 5.6. nullopt for text without a number ("Auto", "Bulb").
std::optional<double> ParseSettingValue(CameraSetting setting, const std::string& text);

// Picks the allowed value for `requested`: an exact (case-insensitive)
// choice, else the choice numerically nearest to it within a sixth of a stop
// (or within the rounding of the camera's text), else for a free setting the
// request itself (checked against the range). Throws CameraError naming
// `camera`, the setting, the request and the allowed values
// (kNotSupported), or that the setting is read-only.
std::string MatchSettingValue(const CameraSettingState& state, const std::string& requested,
                              const std::string& camera);

class Camera;

// One exposure setting as an operator chooses it (the GUI's Capture page;
// `camera info` lists the same state): the camera's allowed values that name
// a number, because a capture carries each setting as a number
// (CaptureOptions.exposure, `capture --iso / --exposure-time / --f-number`)
// that the camera matches back to its own value; "Auto" or "Bulb" cannot be.
struct ExposureChoices {
  CameraSetting setting = CameraSetting::kIso;
  std::optional<CameraSettingState> state;  // as the camera stated it; nullopt = not read (see unavailable)
  std::vector<std::string> values;          // the values that may be chosen, in the camera's order
  std::string unavailable;                  // why none may be chosen; "" when values has some
};

// Asks `camera` for `setting`. A camera without the setting, or one that
// fails to answer (CameraError), gives no values and says why.
ExposureChoices ExposureChoicesOf(Camera& camera, CameraSetting setting);

// The number CaptureOptions.exposure takes for `value`, one of
// `choices.values` ("1/125" -> 0.008); 0, which leaves the camera's own
// value, for "". Throws std::invalid_argument naming the setting, the value
// and the values allowed for anything else.
double ExposureChoiceNumber(const ExposureChoices& choices, const std::string& value);

// Sets the field of `settings` that `setting` names.
void SetExposureValue(ExposureSettings* settings, CameraSetting setting, double value);

// The RAW file as the camera wrote it, in memory.
struct CapturedFrame {
  std::vector<uint8_t> bytes;
  std::string extension;    // lower case with the dot: ".nef", ".dng"
  std::string source_name;  // the name on the camera or in the replay folder ("DSC_0042.NEF")
  std::chrono::system_clock::time_point capture_time;  // host clock when the exposure was triggered
  ExposureSettings settings;  // what it was taken with
};

// One live-view frame, encoded as the camera sent it.
struct PreviewFrame {
  std::vector<uint8_t> bytes;
  std::string mime_type;  // "image/jpeg" (a DSLR's live view), "image/x-portable-pixmap" (simulated, replay)
  std::string extension;  // ".jpg", ".ppm"
  std::chrono::system_clock::time_point time;
};

struct CameraEvent {
  enum class Type {
    kUnknown,          // anything else the camera said (property changes...); see detail
    kFileAdded,        // detail: "/folder/name" on the camera
    kFolderAdded,      // detail: the folder
    kFileChanged,      // detail: "/folder/name"
    kCaptureComplete,
    kNote,             // something the backend did or could not do (a file it could not delete)
  };
  Type type = Type::kUnknown;
  std::string detail;
  std::chrono::system_clock::time_point time;
};

const char* CameraEventTypeName(CameraEvent::Type type);

class Camera {
 public:
  virtual ~Camera() = default;

  // "camera Nikon DSC D5100 (PTP mode) on usb:001,004"; starts every error.
  virtual std::string description() const = 0;
  virtual CameraDeviceInfo Info() = 0;

  // Throws CameraError (kNotSupported) when the camera has no such setting.
  virtual CameraSettingState GetSetting(CameraSetting setting) = 0;
  // `value` is an allowed value or a number matched to one (MatchSettingValue).
  virtual void SetSetting(CameraSetting setting, const std::string& value) = 0;

  // What keeps the next Capture() from working, or from giving frames fit for
  // photometric stereo, each naming what to change on the camera (mode dial
  // on M, manual focus, RAW image quality); empty when ready.
  virtual std::vector<std::string> CheckReady() = 0;
  // Takes one RAW frame. Throws CameraError; kWrongMode lists CheckReady()'s
  // problems.
  virtual CapturedFrame Capture() = 0;

  virtual PreviewFrame CapturePreview() = 0;
  // Ends live view (mirror down) if a preview started it; harmless otherwise.
  virtual void StopPreview() = 0;

  // Events the camera raised since the last call (those seen while capturing
  // included), after waiting up to `wait` for more.
  virtual std::vector<CameraEvent> DrainEvents(std::chrono::milliseconds wait) = 0;

  // Drops the connection and opens the camera again (after it was unplugged
  // or switched off and on); settings made through SetSetting are kept where
  // the camera keeps them.
  virtual void Reconnect() = 0;

  // The three settings as numbers (0 where unknown or not a number).
  ExposureSettings CurrentExposure();
  // Numeric conveniences: the allowed value nearest within a sixth of a stop.
  void SetIso(double iso);
  void SetExposureTime(double seconds);
  void SetFNumber(double f_number);

 private:
  void SetNumber(CameraSetting setting, double value);
};

// RAW file extensions served or accepted (lower case, with the dot).
const std::vector<std::string>& RawFileExtensions();
// Whether `name`'s extension is one of them (case-insensitive).
bool IsRawFileName(const std::string& name);
// ".nef" for "DSC_0001.NEF"; "" if none.
std::string LowerCaseExtension(const std::string& name);

}  // namespace scanbench
