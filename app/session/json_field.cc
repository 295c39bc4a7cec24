#include "app/session/json_field.h"

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <limits>

#include "app/session/session_error.h"

namespace scanbench::session_internal {
namespace {

// Error messages quote values; a whole "frames" array would drown the rule.
constexpr size_t kMaxQuotedLength = 80;

std::string CutShort(std::string text) {
  if (text.size() > kMaxQuotedLength) {
    text.resize(kMaxQuotedLength - 3);
    text += "...";
  }
  return text;
}

// "line 3, column 8" of the character at `offset`, 1-based like nlohmann's.
std::string LineAndColumn(const std::string& text, size_t offset) {
  offset = std::min(offset, text.size());
  const size_t line = 1 + static_cast<size_t>(std::count(text.begin(), text.begin() + offset, '\n'));
  const size_t line_start = offset == 0 ? 0 : text.rfind('\n', offset - 1) + 1;  // npos + 1 == 0
  return "line " + std::to_string(line) + ", column " + std::to_string(offset - line_start + 1);
}

// "[json.exception.parse_error.101] parse error at line 3, column 8: syntax
// error ..." -> "syntax error ...": the file and position are said our way.
std::string WithoutNlohmannPrefix(const nlohmann::json::exception& error) {
  std::string description = error.what();
  const size_t id_end = description.find("] ");
  if (id_end != std::string::npos) description.erase(0, id_end + 2);
  if (description.rfind("parse error", 0) == 0) {
    const size_t position_end = description.find(": ");
    if (position_end != std::string::npos) description.erase(0, position_end + 2);
  }
  return description;
}

}  // namespace

void ThrowFieldError(const std::string& file, const std::string& path, const std::string& value_and_rule) {
  throw SessionError(file + ": " + (path.empty() ? "(top level)" : path) + ": " + value_and_rule);
}

std::string MemberPath(const std::string& parent, std::string_view key) {
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

std::string ElementPath(const std::string& parent, size_t index) {
  return parent + "[" + std::to_string(index) + "]";
}

std::string FormatValue(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string FormatValue(const std::string& value) {
  // Replace rather than throw on invalid UTF-8: this text only explains an error.
  return CutShort(Json(value).dump(-1, ' ', false, Json::error_handler_t::replace));
}

std::string FormatValue(const Eigen::Vector3d& value) {
  std::string text = "[";
  for (int i = 0; i < 3; ++i) {
    if (i > 0) text += ", ";
    text += FormatValue(value[i]);
  }
  return text + "]";
}

std::string FormatJson(const Json& value) {
  return CutShort(value.dump(-1, ' ', false, Json::error_handler_t::replace));
}

Json ParseJson(const std::string& text, const std::string& file) {
  try {
    return Json::parse(text);
  } catch (const Json::parse_error& error) {
    // error.byte is the 1-based index of the character that broke the parse.
    const size_t offset = error.byte > 0 ? error.byte - 1 : 0;
    throw SessionError(file + ": " + LineAndColumn(text, offset) + ": parse error: " + WithoutNlohmannPrefix(error));
  } catch (const Json::out_of_range& error) {
    // A number beyond double range (1e999): nlohmann quotes the token but not
    // where it is, so look for it.
    const std::string description = WithoutNlohmannPrefix(error);
    const size_t open = description.find('\'');
    const size_t close = description.rfind('\'');
    const size_t offset = close > open + 1 && open != std::string::npos
                              ? text.find(description.substr(open + 1, close - open - 1))
                              : std::string::npos;
    const std::string where = offset != std::string::npos ? LineAndColumn(text, offset) : "parse error";
    throw SessionError(file + ": " + where + ": " + description + " (numbers must be finite doubles)");
  } catch (const Json::exception& error) {
    throw SessionError(file + ": parse error: " + WithoutNlohmannPrefix(error));
  }
}

std::string DumpJson(const Json& json) {
  try {
    return json.dump(2) + "\n";
  } catch (const Json::type_error& error) {
    throw SessionError(std::string("cannot write JSON: ") + error.what());
  }
}

void JsonField::Fail(const std::string& rule) const {
  ThrowFieldError(*file_, path_, FormatJson(*value_) + " " + rule);
}

void JsonField::ExpectObject() const {
  if (!value_->is_object()) Fail("must be an object");
}

JsonField JsonField::Member(std::string_view key) const {
  ExpectObject();
  const auto it = value_->find(key);
  if (it == value_->end()) ThrowFieldError(*file_, MemberPath(path_, key), "missing required field");
  return JsonField(*it, MemberPath(path_, key), *file_);
}

std::optional<JsonField> JsonField::OptionalMember(std::string_view key) const {
  ExpectObject();
  const auto it = value_->find(key);
  if (it == value_->end() || it->is_null()) return std::nullopt;
  return JsonField(*it, MemberPath(path_, key), *file_);
}

void JsonField::ExpectOnlyKeys(std::initializer_list<std::string_view> known) const {
  ExpectObject();
  for (const auto& item : value_->items()) {
    if (std::find(known.begin(), known.end(), item.key()) == known.end()) {
      ThrowFieldError(*file_, MemberPath(path_, item.key()), "unknown field (misspelt?)");
    }
  }
}

std::vector<JsonField> JsonField::Elements() const {
  if (!value_->is_array()) Fail("must be an array");
  std::vector<JsonField> elements;
  elements.reserve(value_->size());
  for (size_t i = 0; i < value_->size(); ++i) {
    elements.emplace_back((*value_)[i], ElementPath(path_, i), *file_);
  }
  return elements;
}

std::string JsonField::String() const {
  if (!value_->is_string()) Fail("must be a string");
  return value_->get<std::string>();
}

bool JsonField::Bool() const {
  if (!value_->is_boolean()) Fail("must be true or false");
  return value_->get<bool>();
}

int JsonField::Int() const {
  if (!value_->is_number_integer()) Fail("must be an integer");
  if (value_->is_number_unsigned()) {
    if (value_->get<uint64_t>() > static_cast<uint64_t>(std::numeric_limits<int>::max())) {
      Fail("is out of range for an integer");
    }
    return static_cast<int>(value_->get<uint64_t>());
  }
  const int64_t value = value_->get<int64_t>();
  if (value < std::numeric_limits<int>::min() || value > std::numeric_limits<int>::max()) {
    Fail("is out of range for an integer");
  }
  return static_cast<int>(value);
}

double JsonField::Double() const {
  if (!value_->is_number()) Fail("must be a number");
  return value_->get<double>();
}

Eigen::Vector3d JsonField::Vector3() const {
  if (!value_->is_array() || value_->size() != 3 ||
      !std::all_of(value_->begin(), value_->end(), [](const Json& v) { return v.is_number(); })) {
    Fail("must be an array of 3 numbers");
  }
  return {(*value_)[0].get<double>(), (*value_)[1].get<double>(), (*value_)[2].get<double>()};
}

Json Vector3ToJson(const Eigen::Vector3d& value) { return Json::array({value.x(), value.y(), value.z()}); }

}  // namespace scanbench::session_internal
