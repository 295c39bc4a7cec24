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
  ExpectOnlyKeys(std::span<const std::string_view>(known.begin(), known.size()));
}

void JsonField::ExpectOnlyKeys(std::span<const std::string_view> known) const {
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

bool IsSha256Hex(std::string_view text) {
  if (text.size() != 64) return false;
  for (const char c : text) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

void CheckSha256Format(const std::string& sha256, const std::string& file, const std::string& path) {
  if (!IsSha256Hex(sha256)) ThrowFieldError(file, path, FormatValue(sha256) + " must be 64 lower-case hex digits");
}

namespace {

bool IsDigits(std::string_view text, size_t pos, size_t count) {
  if (pos + count > text.size()) return false;
  for (size_t i = pos; i < pos + count; ++i) {
    if (text[i] < '0' || text[i] > '9') return false;
  }
  return true;
}

int DigitsValue(std::string_view text, size_t pos, size_t count) {
  int value = 0;
  for (size_t i = pos; i < pos + count; ++i) value = value * 10 + (text[i] - '0');
  return value;
}

int64_t DaysFromCivil(int64_t y, unsigned m, unsigned d) {
  // Days since 1970-01-01 of a proleptic Gregorian date.
  y -= m <= 2;
  const int64_t era = (y >= 0 ? y : y - 399) / 400;
  const unsigned yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<int64_t>(doe) - 719468;
}

}  // namespace

std::chrono::system_clock::time_point ParseIso8601Utc(const std::string& text, const std::string& what) {
  auto fail = [&](const char* detail) {
    throw SessionError(what + ": " + FormatValue(text) + " must be an ISO 8601 UTC time like 2024-05-01T12:34:56Z" +
                       detail);
  };
  // Digits only where digits belong: no sign, no space.
  if (text.size() < 20 || !IsDigits(text, 0, 4) || text[4] != '-' || !IsDigits(text, 5, 2) || text[7] != '-' ||
      !IsDigits(text, 8, 2) || text[10] != 'T' || !IsDigits(text, 11, 2) || text[13] != ':' ||
      !IsDigits(text, 14, 2) || text[16] != ':' || !IsDigits(text, 17, 2)) {
    fail("");
  }
  const int year = DigitsValue(text, 0, 4), month = DigitsValue(text, 5, 2), day = DigitsValue(text, 8, 2);
  const int hour = DigitsValue(text, 11, 2), minute = DigitsValue(text, 14, 2), second = DigitsValue(text, 17, 2);
  if (month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59 || second > 60) fail("");
  size_t pos = 19;
  double fraction = 0;
  if (text[pos] == '.') {
    const size_t start = ++pos;
    while (pos < text.size() && IsDigits(text, pos, 1)) ++pos;
    if (pos == start) fail(" (the fraction of a second is empty)");
    fraction = std::stod("0." + text.substr(start, pos - start));
  }
  if (pos + 1 != text.size() || text[pos] != 'Z') fail(" (it must end in Z: UTC)");
  const int64_t seconds = DaysFromCivil(year, month, day) * 86400 + hour * 3600 + minute * 60 + second;
  // system_clock counts nanoseconds in 64 bits: 1677-09-22 to 2262-04-11. A
  // time outside would overflow the conversion below (found by fuzzing).
  using ClockSeconds = std::chrono::duration<int64_t>;
  constexpr int64_t kFirst =
      std::chrono::duration_cast<ClockSeconds>(std::chrono::system_clock::duration::min()).count() + 1;
  constexpr int64_t kLast =
      std::chrono::duration_cast<ClockSeconds>(std::chrono::system_clock::duration::max()).count() - 1;
  if (seconds < kFirst || seconds > kLast) fail(" (outside 1677-09-22 to 2262-04-11, the times the system clock holds)");
  return std::chrono::system_clock::time_point(std::chrono::duration_cast<std::chrono::system_clock::duration>(
      std::chrono::duration<double>(static_cast<double>(seconds) + fraction)));
}

// ----------------------------------------------------------------------------
// Field values

Json ValueToJson(const std::string& value) { return value; }
Json ValueToJson(bool value) { return value; }
Json ValueToJson(int value) { return value; }
Json ValueToJson(double value) { return value; }
Json ValueToJson(const Eigen::Vector3d& value) { return Vector3ToJson(value); }
Json ValueToJson(const std::vector<double>& values) { return values; }
Json ValueToJson(const std::vector<std::string>& values) { return values; }

void ValueFromJson(const JsonField& field, std::string& value) { value = field.String(); }
void ValueFromJson(const JsonField& field, bool& value) { value = field.Bool(); }
void ValueFromJson(const JsonField& field, int& value) { value = field.Int(); }
void ValueFromJson(const JsonField& field, double& value) { value = field.Double(); }
void ValueFromJson(const JsonField& field, Eigen::Vector3d& value) { value = field.Vector3(); }

void ValueFromJson(const JsonField& field, std::vector<double>& values) {
  values.clear();
  for (const JsonField& element : field.Elements()) values.push_back(element.Double());
}

void ValueFromJson(const JsonField& field, std::vector<std::string>& values) {
  values.clear();
  for (const JsonField& element : field.Elements()) values.push_back(element.String());
}

}  // namespace scanbench::session_internal
