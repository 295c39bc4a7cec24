// Internal to scanbench_session (not installed, not for other libraries): reads
// parsed JSON while remembering where it is, so that every error names the file
// and the field, "<file>: <json path>: <value> <rule broken>".
#pragma once

#include <cstddef>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "calibration/rig.h"

namespace scanbench::session_internal {

// Keeps keys in the order they were written, so session.json reads top-down.
using Json = nlohmann::ordered_json;

[[noreturn]] void ThrowFieldError(const std::string& file, const std::string& path,
                                  const std::string& value_and_rule);

// "rig" + "leds" -> "rig.leds"; "rig.leds" + 2 -> "rig.leds[2]".
std::string MemberPath(const std::string& parent, std::string_view key);
std::string ElementPath(const std::string& parent, size_t index);

// Values as they appear in error messages: shortest round-trip numbers,
// quoted and escaped strings, long text cut short.
std::string FormatValue(double value);
std::string FormatValue(const std::string& value);
std::string FormatValue(const Eigen::Vector3d& value);
std::string FormatJson(const Json& value);

// Parse errors name the line and column.
Json ParseJson(const std::string& text, const std::string& file);
// Indented text; throws SessionError if a string is not valid UTF-8.
std::string DumpJson(const Json& json);

class JsonField {
 public:
  JsonField(const Json& value, std::string path, const std::string& file)
      : value_(&value), path_(std::move(path)), file_(&file) {}

  const std::string& path() const { return path_; }
  const std::string& file() const { return *file_; }

  // "<file>: <path>: <this value> <rule>".
  [[noreturn]] void Fail(const std::string& rule) const;

  // This must be an object with `key`.
  JsonField Member(std::string_view key) const;
  // This must be an object; absent and null members are both "not given".
  std::optional<JsonField> OptionalMember(std::string_view key) const;
  // Every key must be one of `known`: the whole file is rewritten from the
  // Session struct, so an unknown (e.g. misspelt) field would be lost silently.
  void ExpectOnlyKeys(std::initializer_list<std::string_view> known) const;

  std::vector<JsonField> Elements() const;

  std::string String() const;
  bool Bool() const;
  int Int() const;
  double Double() const;  // any JSON number; range checks happen on the struct
  Eigen::Vector3d Vector3() const;

 private:
  void ExpectObject() const;

  const Json* value_;
  std::string path_;
  const std::string* file_;
};

Json Vector3ToJson(const Eigen::Vector3d& value);

// The rig, with paths below `path` ("" for a rig file, "rig" in a session).
Json RigToJson(const RigDescription& rig);
RigDescription RigFromJson(const JsonField& field);
void CheckRig(const RigDescription& rig, const std::string& file, const std::string& path);

// Parts of the rig on their own (a calibration set stores them).
Json CameraGeometryToJson(const CameraGeometry& camera);
CameraGeometry CameraGeometryFromJson(const JsonField& field);
void CheckCameraGeometry(const CameraGeometry& camera, const std::string& file, const std::string& path);
Json LedDescriptionToJson(const LedDescription& led);
LedDescription LedDescriptionFromJson(const JsonField& field);
void CheckLedDescription(const LedDescription& led, const std::string& file, const std::string& path);

}  // namespace scanbench::session_internal
