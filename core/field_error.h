// The one form of an options error: "where.field = value rule", and the one-line checks that throw it.
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace scanbench {

// What FieldError throws: a std::invalid_argument whose what() is "where.field = value rule", with its parts
// kept, so that a front end can name the field in its own words (the command line names the option the
// user typed: "--width -5: must be > 0", app/cli/option_fields.h).
class FieldValueError : public std::invalid_argument {
 public:
  FieldValueError(std::string where, std::string field, std::string value, std::string rule)
      : std::invalid_argument(where + "." + field + " = " + value + " " + rule),
        where_(std::move(where)),
        field_(std::move(field)),
        value_(std::move(value)),
        rule_(std::move(rule)) {}

  const std::string& where() const { return where_; }  // "SimulatedRigOptions"
  const std::string& field() const { return field_; }  // "width"
  const std::string& value() const { return value_; }  // "-5", as the message prints it
  const std::string& rule() const { return rule_; }    // "must be > 0"

 private:
  std::string where_, field_, value_, rule_;
};

template <typename T>
FieldValueError FieldError(const std::string& where, const std::string& field, const T& value,
                           const std::string& rule) {
  std::ostringstream text;
  text << value;
  return FieldValueError(where, field, text.str(), rule);
}

}  // namespace scanbench

// One line per rule, in the spirit of Ceres' OPTION_GE: each throws FieldError(where, field, value, rule)
// unless the value keeps the rule, e.g.
//   SCANBENCH_REQUIRE_GE_LE("PhotometricSolverOptions", "min_lights", min_lights, 3, 1000);
//   -> "PhotometricSolverOptions.min_lights = 2 must lie in [3, 1000]"
// The rule text carries the bounds as written in the source (1e-6 stays "1e-6", never "1e-06"), so the
// bounds must be literals (or names whose spelling is meant to appear in the message). An optional last
// argument, a string literal, is appended after a space: a unit or a note ("mm", "(0 = automatic)").
// Every rule is written as "holds", so NaN fails each of them. The value is evaluated once; the field
// (which may be built with std::to_string) only when the rule fails.
#define SCANBENCH_REQUIRE_GE_LE(where, field, value, lo, hi, ...)                                               \
  SCANBENCH_REQUIRE_RULE_(where, field, value, scanbench_value_ >= (lo) && scanbench_value_ <= (hi),            \
                          "must lie in [" #lo ", " #hi "]" __VA_OPT__(" " __VA_ARGS__))
#define SCANBENCH_REQUIRE_GE_LT(where, field, value, lo, hi, ...)                                               \
  SCANBENCH_REQUIRE_RULE_(where, field, value, scanbench_value_ >= (lo) && scanbench_value_ < (hi),             \
                          "must lie in [" #lo ", " #hi ")" __VA_OPT__(" " __VA_ARGS__))
#define SCANBENCH_REQUIRE_GT_LE(where, field, value, lo, hi, ...)                                               \
  SCANBENCH_REQUIRE_RULE_(where, field, value, scanbench_value_ > (lo) && scanbench_value_ <= (hi),             \
                          "must lie in (" #lo ", " #hi "]" __VA_OPT__(" " __VA_ARGS__))
#define SCANBENCH_REQUIRE_GT_LT(where, field, value, lo, hi, ...)                                               \
  SCANBENCH_REQUIRE_RULE_(where, field, value, scanbench_value_ > (lo) && scanbench_value_ < (hi),              \
                          "must lie in (" #lo ", " #hi ")" __VA_OPT__(" " __VA_ARGS__))
#define SCANBENCH_REQUIRE_GT(where, field, value, lo, ...)                                                      \
  SCANBENCH_REQUIRE_RULE_(where, field, value, scanbench_value_ > (lo),                                         \
                          "must be > " #lo __VA_OPT__(" " __VA_ARGS__))
#define SCANBENCH_REQUIRE_GE(where, field, value, lo, ...)                                                      \
  SCANBENCH_REQUIRE_RULE_(where, field, value, scanbench_value_ >= (lo),                                        \
                          "must be >= " #lo __VA_OPT__(" " __VA_ARGS__))
#define SCANBENCH_REQUIRE_LE(where, field, value, hi, ...)                                                      \
  SCANBENCH_REQUIRE_RULE_(where, field, value, scanbench_value_ <= (hi),                                        \
                          "must be <= " #hi __VA_OPT__(" " __VA_ARGS__))
#define SCANBENCH_REQUIRE_FINITE(where, field, value, ...)                                                      \
  SCANBENCH_REQUIRE_RULE_(where, field, value, std::isfinite(scanbench_value_),                                 \
                          "must be finite" __VA_OPT__(" " __VA_ARGS__))
#define SCANBENCH_REQUIRE_FINITE_GT(where, field, value, lo, ...)                                               \
  SCANBENCH_REQUIRE_RULE_(where, field, value, scanbench_value_ > (lo) && std::isfinite(scanbench_value_),      \
                          "must be finite and > " #lo __VA_OPT__(" " __VA_ARGS__))
#define SCANBENCH_REQUIRE_FINITE_GE(where, field, value, lo, ...)                                               \
  SCANBENCH_REQUIRE_RULE_(where, field, value, scanbench_value_ >= (lo) && std::isfinite(scanbench_value_),     \
                          "must be finite and >= " #lo __VA_OPT__(" " __VA_ARGS__))

// The shared body: `holds` reads the value as scanbench_value_.
#define SCANBENCH_REQUIRE_RULE_(where, field, value, holds, rule)                                               \
  do {                                                                                                          \
    const auto& scanbench_value_ = (value);                                                                     \
    if (!(holds)) throw ::scanbench::FieldError((where), (field), scanbench_value_, (rule));                    \
  } while (false)
