// Internal to scanbench_session (not installed, not for other libraries): reads
// parsed JSON while remembering where it is, so that every error names the file
// and the field, "<file>: <json path>: <value> <rule broken>".
#pragma once

#include <chrono>
#include <cstddef>
#include <initializer_list>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "app/session/session_error.h"
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
  void ExpectOnlyKeys(std::span<const std::string_view> known) const;

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

// I/O helpers throw std::runtime_error / fs::filesystem_error naming the path;
// callers of this library catch one type.
template <typename Function>
decltype(auto) RethrowAsSessionError(Function&& function) {
  try {
    return function();
  } catch (const SessionError&) {
    throw;
  } catch (const std::exception& error) {
    throw SessionError(error.what());
  }
}

// 64 lower-case hex digits, as Sha256Hex writes them.
bool IsSha256Hex(std::string_view text);
// "<file>: <path>: "<sha256>" must be 64 lower-case hex digits" unless it is.
void CheckSha256Format(const std::string& sha256, const std::string& file, const std::string& path);

// The one reader of YYYY-MM-DDTHH:MM:SS[.fraction]Z. Only UTC: local times
// without a zone are ambiguous once a session travels. Throws SessionError
// "<what>: <value> <rule>".
std::chrono::system_clock::time_point ParseIso8601Utc(const std::string& text, const std::string& what);

// ----------------------------------------------------------------------------
// One key list per JSON object.
//
// Each object of a file is described once, by a visitor over its fields in
// file order:
//
//   template <class Io>
//   void CameraFields(Io& io, CameraInfo& camera) {
//     io.Field("make", camera.make);
//     io.Object("settings", [&](auto& settings) { settings.Field("iso", camera.iso); });
//   }
//
// WriteObject runs it with an ObjectWriter (keys in visit order: the file's
// layout), ReadObject first with a KeyList (any other key is refused) and
// then with an ObjectReader, in the same order, so that errors come field by
// field from the top. Adding a field is one line in its visitor.
//
// The writer visits a const value through a non-const reference (as
// boost::serialization does) so that one visitor serves both directions; it
// never changes it.

// Whether a key must be in the file. Every field is always written.
enum class Presence {
  kRequired,
  kOptionalOnRead,  // absent or null keeps the value the reader started with
};

Json ValueToJson(const std::string& value);
Json ValueToJson(bool value);
Json ValueToJson(int value);
Json ValueToJson(double value);
Json ValueToJson(const Eigen::Vector3d& value);
Json ValueToJson(const std::vector<double>& values);
Json ValueToJson(const std::vector<std::string>& values);
void ValueFromJson(const JsonField& field, std::string& value);
void ValueFromJson(const JsonField& field, bool& value);
void ValueFromJson(const JsonField& field, int& value);
void ValueFromJson(const JsonField& field, double& value);
void ValueFromJson(const JsonField& field, Eigen::Vector3d& value);
void ValueFromJson(const JsonField& field, std::vector<double>& values);
void ValueFromJson(const JsonField& field, std::vector<std::string>& values);

// Lists the keys only; nothing is read or written.
class KeyList {
 public:
  template <typename T>
  void Field(std::string_view key, T&, Presence = Presence::kRequired) { keys_.push_back(key); }
  template <typename Visit>
  void Object(std::string_view key, Visit&&, Presence = Presence::kRequired) { keys_.push_back(key); }
  template <typename T, typename Visit>
  void Optional(std::string_view key, std::optional<T>&, Visit&&) { keys_.push_back(key); }
  template <typename T, typename Visit>
  void Array(std::string_view key, std::vector<T>&, Visit&&) { keys_.push_back(key); }
  template <typename Write, typename Read>
  void Custom(std::string_view key, Write&&, Read&&, Presence = Presence::kRequired) { keys_.push_back(key); }

  std::span<const std::string_view> keys() const { return keys_; }

 private:
  std::vector<std::string_view> keys_;
};

class ObjectWriter;
class ObjectReader;

// `visit(io)` describes one object's fields.
template <typename Visit>
Json WriteObject(Visit&& visit);
template <typename Visit>
void ReadObject(const JsonField& field, Visit&& visit);

class ObjectWriter {
 public:
  template <typename T>
  void Field(std::string_view key, const T& value, Presence = Presence::kRequired) {
    json_[std::string(key)] = ValueToJson(value);
  }
  template <typename Visit>
  void Object(std::string_view key, Visit&& visit, Presence = Presence::kRequired) {
    json_[std::string(key)] = WriteObject(visit);
  }
  // Written only when set.
  template <typename T, typename Visit>
  void Optional(std::string_view key, const std::optional<T>& value, Visit&& visit) {
    if (value) json_[std::string(key)] = WriteObject([&](auto& io) { visit(io, const_cast<T&>(*value)); });
  }
  // An array of objects, `visit(io, element)` each.
  template <typename T, typename Visit>
  void Array(std::string_view key, const std::vector<T>& values, Visit&& visit) {
    Json array = Json::array();
    for (const T& value : values) array.push_back(WriteObject([&](auto& io) { visit(io, const_cast<T&>(value)); }));
    json_[std::string(key)] = std::move(array);
  }
  // `write()` returns the value (Json, or std::optional<Json>: nullopt writes
  // nothing); `read(field)` is the reader's.
  template <typename Write, typename Read>
  void Custom(std::string_view key, Write&& write, Read&&, Presence = Presence::kRequired) {
    std::optional<Json> value = write();
    if (value) json_[std::string(key)] = std::move(*value);
  }

  Json& json() { return json_; }

 private:
  Json json_ = Json::object();
};

class ObjectReader {
 public:
  explicit ObjectReader(const JsonField& object) : object_(object) {}

  template <typename T>
  void Field(std::string_view key, T& value, Presence presence = Presence::kRequired) {
    if (const auto member = Find(key, presence)) ValueFromJson(*member, value);
  }
  template <typename Visit>
  void Object(std::string_view key, Visit&& visit, Presence presence = Presence::kRequired) {
    if (const auto member = Find(key, presence)) ReadObject(*member, visit);
  }
  // Read when given (absent and null are both "not given").
  template <typename T, typename Visit>
  void Optional(std::string_view key, std::optional<T>& value, Visit&& visit) {
    if (const auto member = object_.OptionalMember(key)) {
      T& element = value.emplace();
      ReadObject(*member, [&](auto& io) { visit(io, element); });
    }
  }
  template <typename T, typename Visit>
  void Array(std::string_view key, std::vector<T>& values, Visit&& visit) {
    values.clear();
    for (const JsonField& member : object_.Member(key).Elements()) {
      T& element = values.emplace_back();
      ReadObject(member, [&](auto& io) { visit(io, element); });
    }
  }
  template <typename Write, typename Read>
  void Custom(std::string_view key, Write&&, Read&& read, Presence presence = Presence::kRequired) {
    if (const auto member = Find(key, presence)) read(*member);
  }

 private:
  std::optional<JsonField> Find(std::string_view key, Presence presence) const {
    if (presence == Presence::kRequired) return object_.Member(key);
    return object_.OptionalMember(key);
  }

  const JsonField& object_;
};

template <typename Visit>
Json WriteObject(Visit&& visit) {
  ObjectWriter writer;
  visit(writer);
  return std::move(writer.json());
}

template <typename Visit>
void ReadObject(const JsonField& field, Visit&& visit) {
  KeyList keys;
  visit(keys);
  field.ExpectOnlyKeys(keys.keys());
  ObjectReader reader(field);
  visit(reader);
}

// `fields(io, value)` is the struct's visitor.
template <typename T, typename Fields>
Json ToJsonObject(const T& value, Fields&& fields) {
  return WriteObject([&](auto& io) { fields(io, const_cast<T&>(value)); });
}
template <typename T, typename Fields>
T FromJsonObject(const JsonField& field, Fields&& fields) {
  T value;
  ReadObject(field, [&](auto& io) { fields(io, value); });
  return value;
}

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
