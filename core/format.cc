#include "core/format.h"

#include <cmath>
#include <algorithm>
#include <iomanip>
#include <sstream>

namespace scanbench {

std::string Fixed(double value, int digits) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << value;
  return out.str();
}

std::string Significant(double value, int digits) {
  if (!std::isfinite(value) || value == 0) return Fixed(value, 0);
  const int magnitude = static_cast<int>(std::floor(std::log10(std::abs(value))));  // 0.0797 -> -2
  int decimals = std::max(0, digits - 1 - magnitude);
  // Rounding may carry into the next power of ten (0.09996 -> "0.100"): one decimal fewer then.
  std::string text = Fixed(value, decimals);
  if (decimals > 0 && std::abs(std::stod(text)) >= std::pow(10.0, magnitude + 1)) text = Fixed(value, decimals - 1);
  return text;
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string FormatDuration(double seconds) {
  const long total = std::isfinite(seconds) ? std::lround(std::max(seconds, 0.0)) : 0;
  std::ostringstream out;
  if (total >= 3600) out << total / 3600 << "h";
  out << std::setw(total >= 3600 ? 2 : 1) << std::setfill('0') << (total / 60) % 60 << ":" << std::setw(2)
      << total % 60;
  return out.str();
}

std::string XmlEscaped(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace scanbench
