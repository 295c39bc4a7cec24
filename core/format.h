// Number and duration formatting shared by reports, logs and the CLI.
#pragma once

#include <chrono>
#include <string>

namespace scanbench {

// `value` with `digits` digits after the point ("0.378").
std::string Fixed(double value, int digits);

// `value` to `digits` significant digits, never in exponent form, as reports
// print times: 0.0797305 -> "0.0797", 12.345 -> "12.3", 1234.5 -> "1235"
// (whole numbers keep all their digits).
std::string Significant(double value, int digits = 3);

// Seconds elapsed since `start` on the steady clock.
double SecondsSince(std::chrono::steady_clock::time_point start);

// A duration on a clock face, rounded to whole seconds: "0:42", "3:07",
// "1h02:09" (negative counts as 0).
std::string FormatDuration(double seconds);

// `text` with the five XML entities escaped (& < > " '): safe in XML, SVG
// and HTML text and attribute values.
std::string XmlEscaped(const std::string& text);

}  // namespace scanbench
