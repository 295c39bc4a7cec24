#include "app/devices/camera/camera.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string_view>

namespace scanbench {

namespace {

std::string_view Trim(std::string_view text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) text.remove_prefix(1);
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.remove_suffix(1);
  return text;
}

std::string Lower(std::string_view text) {
  std::string lower(text);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return lower;
}

bool StartsWith(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

// The whole of `text` as a finite number, nothing else.
std::optional<double> ParseNumber(std::string_view text) {
  text = Trim(text);
  if (text.empty()) return std::nullopt;
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

// "a/b" or a plain number.
std::optional<double> ParseFraction(std::string_view text) {
  const size_t slash = text.find('/');
  if (slash == std::string_view::npos) return ParseNumber(text);
  const std::optional<double> numerator = ParseNumber(text.substr(0, slash));
  const std::optional<double> denominator = ParseNumber(text.substr(slash + 1));
  if (!numerator || !denominator || *denominator == 0) return std::nullopt;
  return *numerator / *denominator;
}

// Half a unit of the last decimal the camera printed ("0.0080s" -> 0.00005):
// how far the true value may lie from the text.
double RoundingHalfUnit(const std::string& text) {
  const size_t dot = text.find('.');
  if (dot == std::string::npos) return 0;
  int decimals = 0;
  for (size_t i = dot + 1; i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); ++i) ++decimals;
  return 0.5 * std::pow(10.0, -decimals);
}

std::string JoinChoices(const std::vector<std::string>& choices) {
  std::string joined;
  for (size_t i = 0; i < choices.size(); ++i) joined += (i ? ", " : "") + choices[i];
  return joined;
}

std::string FormatNumber(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6g", value);
  return text;
}

// A sixth of a stop: half the step of the usual third-stop scales.
constexpr double kStopTolerance = 1.0 / 6.0 + 1e-9;

}  // namespace

const char* CameraErrorKindName(CameraErrorKind kind) {
  switch (kind) {
    case CameraErrorKind::kNotFound:
      return "not found";
    case CameraErrorKind::kBusy:
      return "busy";
    case CameraErrorKind::kClaimed:
      return "claimed by another program";
    case CameraErrorKind::kPermissionDenied:
      return "permission denied";
    case CameraErrorKind::kNotSupported:
      return "not supported";
    case CameraErrorKind::kWrongMode:
      return "wrong mode";
    case CameraErrorKind::kDisconnected:
      return "disconnected";
    case CameraErrorKind::kTimeout:
      return "timeout";
    case CameraErrorKind::kIo:
      return "i/o error";
    case CameraErrorKind::kBadFile:
      return "bad file";
    case CameraErrorKind::kExhausted:
      return "no more frames";
  }
  return "unknown";
}

const char* CameraSettingName(CameraSetting setting) {
  switch (setting) {
    case CameraSetting::kIso:
      return "ISO";
    case CameraSetting::kShutter:
      return "shutter speed";
    case CameraSetting::kAperture:
      return "aperture";
  }
  return "setting";
}

const char* CameraEventTypeName(CameraEvent::Type type) {
  switch (type) {
    case CameraEvent::Type::kUnknown:
      return "event";
    case CameraEvent::Type::kFileAdded:
      return "file added";
    case CameraEvent::Type::kFolderAdded:
      return "folder added";
    case CameraEvent::Type::kFileChanged:
      return "file changed";
    case CameraEvent::Type::kCaptureComplete:
      return "capture complete";
    case CameraEvent::Type::kNote:
      return "note";
  }
  return "event";
}

std::optional<double> ParseSettingValue(CameraSetting setting, const std::string& text) {
  std::string value = Lower(Trim(text));
  std::optional<double> number;
  switch (setting) {
    case CameraSetting::kIso:
      if (StartsWith(value, "iso")) value = value.substr(3);
      number = ParseNumber(value);
      break;
    case CameraSetting::kShutter: {
      // Units the drivers append: "0.0080s", "30\"", "1/125 sec".
      for (const std::string_view unit : {"sec", "s", "\""}) {
        if (value.size() > unit.size() && value.ends_with(unit)) {
          value.resize(value.size() - unit.size());
          break;
        }
      }
      std::string_view view = Trim(value);
      // "1 1/3": whole seconds plus a fraction.
      const size_t space = view.find(' ');
      if (space != std::string_view::npos && view.find('/') != std::string_view::npos) {
        const std::optional<double> whole = ParseNumber(view.substr(0, space));
        const std::optional<double> fraction = ParseFraction(Trim(view.substr(space + 1)));
        if (whole && fraction) number = *whole + *fraction;
      } else {
        number = ParseFraction(view);
      }
      break;
    }
    case CameraSetting::kAperture:
      if (StartsWith(value, "f/")) {
        value = value.substr(2);
      } else if (StartsWith(value, "f")) {
        value = value.substr(1);
      }
      number = ParseNumber(value);
      break;
  }
  if (!number || *number <= 0) return std::nullopt;
  return number;
}

std::string MatchSettingValue(const CameraSettingState& state, const std::string& requested,
                              const std::string& camera) {
  const std::string name = CameraSettingName(state.setting);
  const std::string source = state.source.empty() ? "" : " (" + state.source + ")";
  if (state.read_only) {
    std::string hint;
    if (state.setting == CameraSetting::kAperture) {
      hint = "; a lens without CPU contacts is set on its ring, and a CPU lens needs its ring locked at the "
             "smallest aperture";
    }
    throw CameraError(CameraErrorKind::kNotSupported, camera,
                      name + " is read-only on this camera" + source + ", cannot set it to '" + requested +
                          "'" + hint);
  }
  const std::string wanted(Trim(requested));
  if (wanted.empty()) {
    throw CameraError(CameraErrorKind::kNotSupported, camera, "empty value for the " + name);
  }
  const std::optional<double> number = ParseSettingValue(state.setting, wanted);

  if (!state.choices.empty()) {
    for (const std::string& choice : state.choices) {
      if (Lower(Trim(choice)) == Lower(wanted)) return choice;
    }
    const std::string allowed = "; allowed values" + source + ": " + JoinChoices(state.choices);
    if (!number) {
      throw CameraError(CameraErrorKind::kNotSupported, camera,
                        name + " '" + wanted + "' is neither an allowed value nor a number" + allowed);
    }
    const std::string* best = nullptr;
    double best_stops = 0;
    const std::string* nearest = nullptr;
    double nearest_stops = 0;
    for (const std::string& choice : state.choices) {
      const std::optional<double> value = ParseSettingValue(state.setting, choice);
      if (!value) continue;
      const double stops = std::abs(std::log2(*value / *number));
      if (!nearest || stops < nearest_stops) {
        nearest = &choice;
        nearest_stops = stops;
      }
      const bool close = stops <= kStopTolerance || std::abs(*value - *number) <= RoundingHalfUnit(choice);
      if (close && (!best || stops < best_stops)) {
        best = &choice;
        best_stops = stops;
      }
    }
    if (best) return *best;
    throw CameraError(CameraErrorKind::kNotSupported, camera,
                      name + " '" + wanted + "' is not an allowed value (none within a sixth of a stop" +
                          (nearest ? "; nearest: " + *nearest : std::string()) + ")" + allowed);
  }

  if (state.range_min || state.range_max) {
    if (!number) {
      throw CameraError(CameraErrorKind::kNotSupported, camera, name + " '" + wanted + "' is not a number");
    }
    const double low = state.range_min.value_or(-INFINITY);
    const double high = state.range_max.value_or(INFINITY);
    if (*number < low - 1e-9 || *number > high + 1e-9) {
      throw CameraError(CameraErrorKind::kNotSupported, camera,
                        name + " " + wanted + " is outside the camera's range [" + FormatNumber(low) + ", " +
                            FormatNumber(high) + "]" + source);
    }
    return FormatNumber(*number);
  }
  return wanted;
}

ExposureChoices ExposureChoicesOf(Camera& camera, CameraSetting setting) {
  ExposureChoices choices;
  choices.setting = setting;
  const std::string name = CameraSettingName(setting);
  try {
    choices.state = camera.GetSetting(setting);
  } catch (const CameraError& error) {
    choices.unavailable = error.kind() == CameraErrorKind::kNotSupported
                              ? "this camera has no " + name + " setting"
                              : "the camera did not say its " + name + " (" + error.what() + ")";
    return choices;
  }
  const CameraSettingState& state = *choices.state;
  if (state.read_only) {
    choices.unavailable = name + " is read-only on this camera" +
                          (setting == CameraSetting::kAperture ? " (a lens without CPU contacts is set on its ring)"
                                                               : "");
    return choices;
  }
  for (const std::string& value : state.choices) {
    if (ParseSettingValue(setting, value)) choices.values.push_back(value);
  }
  if (!choices.values.empty()) return choices;
  if (state.choices.empty()) {
    choices.unavailable = "this camera takes its " + name + " as a number from " +
                          FormatNumber(state.range_min.value_or(0)) + " to " +
                          (state.range_max ? FormatNumber(*state.range_max) : std::string("any")) +
                          ", not from a list: set it on the camera";
  } else {
    choices.unavailable = "none of this camera's " + name + " values is a number (" + JoinChoices(state.choices) + ")";
  }
  return choices;
}

double ExposureChoiceNumber(const ExposureChoices& choices, const std::string& value) {
  if (value.empty()) return 0;
  const std::string name = CameraSettingName(choices.setting);
  if (std::find(choices.values.begin(), choices.values.end(), value) == choices.values.end()) {
    throw std::invalid_argument(
        name + " '" + value + "' is not one of the camera's values" +
        (choices.values.empty() ? " (" + choices.unavailable + ")" : ": " + JoinChoices(choices.values)));
  }
  return *ParseSettingValue(choices.setting, value);
}

void SetExposureValue(ExposureSettings* settings, CameraSetting setting, double value) {
  switch (setting) {
    case CameraSetting::kIso:
      settings->iso = value;
      return;
    case CameraSetting::kShutter:
      settings->exposure_time_s = value;
      return;
    case CameraSetting::kAperture:
      settings->f_number = value;
      return;
  }
}

ExposureSettings Camera::CurrentExposure() {
  ExposureSettings settings;
  const auto value = [this](CameraSetting setting) {
    try {
      return ParseSettingValue(setting, GetSetting(setting).current).value_or(0.0);
    } catch (const CameraError& error) {
      if (error.kind() == CameraErrorKind::kNotSupported) return 0.0;
      throw;
    }
  };
  settings.iso = value(CameraSetting::kIso);
  settings.exposure_time_s = value(CameraSetting::kShutter);
  settings.f_number = value(CameraSetting::kAperture);
  return settings;
}

void Camera::SetNumber(CameraSetting setting, double value) {
  if (!(value > 0) || !std::isfinite(value)) {
    throw CameraError(CameraErrorKind::kNotSupported, description(),
                      std::string(CameraSettingName(setting)) + " " + FormatNumber(value) + " must be > 0");
  }
  const CameraSettingState state = GetSetting(setting);
  SetSetting(setting, MatchSettingValue(state, FormatNumber(value), description()));
}

void Camera::SetIso(double iso) { SetNumber(CameraSetting::kIso, iso); }
void Camera::SetExposureTime(double seconds) { SetNumber(CameraSetting::kShutter, seconds); }
void Camera::SetFNumber(double f_number) { SetNumber(CameraSetting::kAperture, f_number); }

const std::vector<std::string>& RawFileExtensions() {
  static const std::vector<std::string> extensions = {".nef", ".nrw", ".dng", ".cr2", ".cr3", ".crw", ".arw",
                                                      ".sr2", ".raf", ".orf", ".rw2", ".pef", ".srw", ".erf",
                                                      ".3fr", ".iiq", ".x3f", ".mrw", ".dcr", ".kdc"};
  return extensions;
}

std::string LowerCaseExtension(const std::string& name) {
  const size_t dot = name.find_last_of('.');
  const size_t slash = name.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash) || dot + 1 == name.size()) return "";
  return Lower(name.substr(dot));
}

bool IsRawFileName(const std::string& name) {
  const std::string extension = LowerCaseExtension(name);
  const std::vector<std::string>& raw = RawFileExtensions();
  return !extension.empty() && std::find(raw.begin(), raw.end(), extension) != raw.end();
}

double ExposureValue(const ExposureSettings& settings, CameraSetting setting) {
  return ForSetting(setting, settings.iso, settings.exposure_time_s, settings.f_number);
}

}  // namespace scanbench
